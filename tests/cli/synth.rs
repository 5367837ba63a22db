//! `btfpt synth` command line: listing and clear errors on bad arguments.
use crate::common;
use crate::common::btfpt_output as btfpt;

#[test]
fn list_names_all_five_materials() {
    let (ok, out, _) = btfpt(&["synth", "--list"]);
    assert!(ok);
    for m in ["wool", "corduroy", "leather", "wood", "foil"] {
        assert!(
            out.lines().any(|l| l.starts_with(m)),
            "{m} missing in:\n{out}"
        );
    }
}

#[test]
fn bad_arguments_fail_with_a_clear_message() {
    let dir = tempfile::tempdir().expect("tempdir");
    let o = dir.path().join("x");
    let o = o.to_str().expect("utf-8 temp path");
    for (args, needle) in [
        (
            vec!["synth", "velvet", "-o", o],
            "unknown synth material 'velvet'",
        ),
        (vec!["synth", "wool", "--size", "0", "-o", o], "--size"),
        (vec!["synth", "wool", "--size", "8y8", "-o", o], "--size"),
        (
            vec!["synth", "wool", "--directions", "ubo1999", "-o", o],
            "--directions",
        ),
        (
            vec!["synth", "wool", "--format", "jpg", "-o", o],
            "--format",
        ),
        (vec!["synth", "wool"], "-o"),
        (vec!["synth"], "--list"),
    ] {
        let (ok, _, err) = btfpt(&args);
        assert!(!ok, "{args:?} should fail");
        assert!(err.contains(needle), "{args:?}: '{err}' lacks '{needle}'");
    }
}

/// `btfpt ARGS` with the `synth:` cache in `cache`: (success, stdout, stderr).
fn with_cache(cache: &std::path::Path, args: &[&str]) -> (bool, String, String) {
    let o = common::btfpt()
        .env("BTFPT_CACHE_DIR", cache)
        .args(args)
        .output()
        .expect("run btfpt");
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

const SOURCE: &str = "synth:leather?size=2&seed=3&strata=1&subdiv=1";

#[test]
fn synth_sources_are_read_by_every_command_that_reads_a_btf() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let d = |n: &str| dir.path().join(n).to_string_lossy().into_owned();
    let (ok, out, err) = with_cache(&cache, &["info", SOURCE]);
    assert!(ok, "{err}");
    assert!(out.contains("2 × 2 texels") && out.contains("81"), "{out}");
    assert!(err.contains("cached as"), "{err}");
    let (ok, _, err) = with_cache(
        &cache,
        &["fit", SOURCE, "-o", &d("m.plmc"), "--model", "lm"],
    );
    assert!(ok, "{err}");
    assert!(err.contains("read from the cache"), "{err}");
    let (ok, out, err) = with_cache(&cache, &["eval", &d("m.plmc"), "--against", SOURCE]);
    assert!(ok && out.contains("lm"), "{err}");
    let (ok, _, err) = with_cache(&cache, &["convert", SOURCE, &d("c.btfc")]);
    assert!(ok, "{err}");
    let (ok, out, _) = with_cache(&cache, &["info", &d("c.btfc")]);
    assert!(ok && out.contains("2 × 2 texels"), "{out}");
    let (ok, _, err) = with_cache(&cache, &["info", "synth:velvet"]);
    assert!(!ok && err.contains("velvet"), "{err}");
}

/// A scene of one `synth:` BTF rectangle under a constant light, 8×8 pixels.
fn synth_scene(dir: &std::path::Path) -> std::path::PathBuf {
    let xml = format!(
        r#"<scene version="3.0.0">
{}    <shape type="rectangle"><bsdf type="btf"><string name="filename" value="{}"/></bsdf></shape>
    <emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
</scene>
"#,
        crate::common::perspective_sensor(40.0, 3.0, 2, 8, 8),
        SOURCE.replace('&', "&amp;")
    );
    let p = dir.join("s.xml");
    std::fs::write(&p, xml).unwrap();
    p
}

#[test]
fn a_synth_material_is_generated_once_cached_and_regenerated_when_corrupt() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let scene = synth_scene(dir.path());
    let render = |out: &str| {
        let out = dir.path().join(out);
        let (ok, _, err) = with_cache(
            &cache,
            &[
                "render",
                scene.to_str().unwrap(),
                "-o",
                out.to_str().unwrap(),
            ],
        );
        assert!(ok, "{err}");
        (btfpt::io::read_image(&out).unwrap().data, err)
    };
    // Two renders at once on an empty cache: both generate, both write atomically.
    let spawn = |out: &str| {
        common::btfpt()
            .env("BTFPT_CACHE_DIR", &cache)
            .args(["render", scene.to_str().unwrap(), "-o"])
            .arg(dir.path().join(out))
            .output()
            .unwrap()
    };
    let (a, b) = std::thread::scope(|s| {
        let a = s.spawn(|| spawn("a.exr"));
        let b = s.spawn(|| spawn("b.exr"));
        (a.join().unwrap(), b.join().unwrap())
    });
    for o in [&a, &b] {
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{err}");
        assert!(err.contains(SOURCE.split('?').next().unwrap()), "{err}");
        // The summary states what the raw material's light-sampling tables cost.
        assert!(
            err.contains(", light sampling: ") && err.contains(" MiB)"),
            "{err}"
        );
    }
    let entries: Vec<_> = std::fs::read_dir(&cache)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(
        entries.len(),
        1,
        "one entry, no temporary files: {entries:?}"
    );
    let first = btfpt::io::read_image(&dir.path().join("a.exr"))
        .unwrap()
        .data;
    assert_eq!(
        first,
        btfpt::io::read_image(&dir.path().join("b.exr"))
            .unwrap()
            .data
    );

    let (img, err) = render("c.exr");
    assert!(err.contains("read from the cache"), "{err}");
    assert_eq!(img, first);
    // A corrupt entry is regenerated, not trusted.
    let mut bytes = std::fs::read(&entries[0]).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x10;
    std::fs::write(&entries[0], &bytes).unwrap();
    let (img, err) = render("d.exr");
    assert!(
        err.contains("generated in") && err.contains("replacing"),
        "{err}"
    );
    assert_eq!(img, first);
    let (_, err) = render("e.exr");
    assert!(err.contains("read from the cache"), "{err}");
}
