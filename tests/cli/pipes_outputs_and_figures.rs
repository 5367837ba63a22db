//! A CLI users can trust: closed pipes, merge fingerprints, compare self-tests,
//! output extension and output-path rules, and one definition of each reported figure.

use crate::common::btfpt;
use btfpt::btf::{self, DirectionSet, RawBtf, StoredEncoding};
use std::path::{Path, PathBuf};
use std::process::{Output, Stdio};

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// A 2×2-texel, 3-direction linear BTF cache in `dir`.
fn tiny_cache(dir: &Path) -> PathBuf {
    let d = DirectionSet::from_angles_deg(vec![(0.0, 0.0), (30.0, 0.0), (60.0, 180.0)]);
    let n = 3 * 3 * 2 * 2;
    let data: Vec<f32> = (0..n)
        .flat_map(|i| [0.25, i as f32 / n as f32, 0.5])
        .collect();
    let raw = RawBtf::from_f32(d.clone(), d, 2, 2, StoredEncoding::Linear, &data).unwrap();
    let cache = dir.join("t.btfc");
    btf::cache::write_raw(&raw, &cache).unwrap();
    cache
}

/// `btfpt ARGS` with stdout connected to a pipe whose reading end is already closed (what
/// `| head -1` leaves behind): the command must not panic.
fn into_closed_pipe(args: &[&std::ffi::OsStr]) -> Output {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    btfpt()
        .args(args)
        .stdout(Stdio::from(writer))
        .stderr(Stdio::piped())
        .output()
        .unwrap()
}

#[test]
fn a_closed_pipe_ends_commands_quietly() {
    let dir = tempfile::tempdir().unwrap();
    let cache = tiny_cache(dir.path());
    for args in [
        vec!["info".as_ref(), cache.as_os_str()],
        vec!["synth".as_ref(), "--list".as_ref()],
    ] {
        let o = into_closed_pipe(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert_ne!(o.status.code(), Some(101), "{args:?}: {err}");
    }
}

fn fails_with(o: &Output, needles: &[&str]) {
    let t = text(o);
    assert_eq!(o.status.code(), Some(1), "{t}");
    for n in needles {
        assert!(t.contains(n), "expected {n:?} in: {t}");
    }
    assert!(!t.contains("panicked"), "{t}");
}

#[test]
fn output_extensions_pick_the_format_or_are_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let synth = |dirs: &str, out: &Path| {
        btfpt()
            .args([
                "synth",
                "wool",
                "--size",
                "2",
                "--strata",
                "1",
                "--directions",
                dirs,
                "-o",
            ])
            .arg(out)
            .output()
            .unwrap()
    };
    // Refused before measuring, and nothing is created.
    fails_with(&synth("ubo2003", &d.join("x.btf")), &["x.btf", ".btfc"]);
    fails_with(&synth("ubo2003", &d.join("x.abc")), &["x.abc", ".abc"]);
    fails_with(
        &synth("ubo2014", &d.join("folder")),
        &["folder", "151", "81", ".btfc"],
    );
    assert_eq!(std::fs::read_dir(d).unwrap().count(), 0);
    // .btfc writes the cache (a file), with any direction set.
    let cache = d.join("w.btfc");
    let o = synth("ubo2014", &cache);
    assert!(o.status.success(), "{}", text(&o));
    assert!(cache.is_file());
    let o = btfpt().arg("info").arg(&cache).output().unwrap();
    assert!(
        text(&o).contains("151 (θ up to 75.0°) views × 151"),
        "{}",
        text(&o)
    );
    // convert: the same rules; a 151-direction BTF cannot become a UBO2003 folder.
    let o = btfpt()
        .arg("convert")
        .arg(&cache)
        .arg(d.join("c.btf"))
        .output()
        .unwrap();
    fails_with(&o, &["c.btf", ".btfc"]);
    let o = btfpt()
        .arg("convert")
        .arg(&cache)
        .arg(d.join("c.dat"))
        .output()
        .unwrap();
    fails_with(&o, &["c.dat", ".dat"]);
    let o = btfpt()
        .arg("convert")
        .arg(&cache)
        .arg(d.join("c"))
        .output()
        .unwrap();
    fails_with(&o, &["151 views", "81"]);
    let names: Vec<_> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("w.btfc")]);
    // A UBO2003 folder: sRGB PNGs clip values above 1, and say how many.
    let o = btfpt()
        .args(["synth", "foil", "--size", "2", "--strata", "1", "-o"])
        .arg(d.join("foil"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let t = text(&o);
    assert!(
        t.contains("exceed 1") && t.contains("clipped") && t.contains("%"),
        "{t}"
    );
    assert!(d.join("foil").is_dir());
}

#[test]
fn outputs_are_checked_before_the_work_and_no_folder_is_created() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cache = tiny_cache(d);
    let missing = d.join("missing");
    let m = |name: &str| missing.join(name);
    let s = |p: PathBuf| p.display().to_string();
    // Inputs that do not exist: the output is checked first, so its error is the one shown.
    let runs: Vec<Vec<String>> = vec![
        vec![
            "render".into(),
            "scenes/cornell-box/scene.xml".into(),
            "-o".into(),
            s(m("r.exr")),
        ],
        vec!["merge".into(), "a.exr".into(), "-o".into(), s(m("m.exr"))],
        vec!["fit".into(), s(cache.clone()), "-o".into(), s(m("f.plmc"))],
        vec![
            "eval".into(),
            "nope.plmc".into(),
            "--against".into(),
            s(cache.clone()),
            "--plot".into(),
            s(m("x.png")),
        ],
        vec![
            "eval".into(),
            "nope.plmc".into(),
            "--against".into(),
            s(cache.clone()),
            "--json".into(),
            s(m("x.json")),
        ],
        vec!["synth".into(), "wool".into(), "-o".into(), s(m("w"))],
        vec!["convert".into(), s(cache.clone()), s(m("c.btfc"))],
        vec![
            "tile-preview".into(),
            "nope.plmc".into(),
            "-o".into(),
            s(m("t.png")),
        ],
        vec![
            "compare".into(),
            "a.exr".into(),
            "b.exr".into(),
            "--diff".into(),
            s(m("d.png")),
        ],
    ];
    for args in runs {
        let o = btfpt()
            .args(&args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap();
        let t = text(&o);
        fails_with(&o, &["missing", "does not exist"]);
        assert!(!missing.exists(), "{args:?} created {}", missing.display());
        // One OS error, printed once.
        assert!(t.matches("os error").count() <= 1, "{t}");
    }
}

/// `btfpt render` of the Cornell box at 8×8 with `extra` arguments.
fn render_box(out: &Path, extra: &[&str]) {
    render_box_sized(out, "8", "8", extra)
}

/// `btfpt render` of the Cornell box at `w`×`h` with `extra` arguments; panics with the output
/// on failure.
fn render_box_sized(out: &Path, w: &str, h: &str, extra: &[&str]) {
    let o = btfpt()
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["render", "scenes/cornell-box/scene.xml"])
        .args(["-D", &format!("width={w}"), "-D", &format!("height={h}")])
        .args(["--checkpoint-interval", "1000", "-o"])
        .arg(out)
        .args(extra)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
}

#[test]
fn merge_refuses_parts_of_different_scenes_or_options() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n);
    render_box(&p("left.exr"), &["--spp", "2", "--crop", "0,0,4,8"]);
    render_box(&p("right.exr"), &["--spp", "2", "--crop", "4,0,4,8"]);
    render_box(
        &p("right_d2.exr"),
        &["--spp", "2", "--crop", "4,0,4,8", "-D", "max_depth=2"],
    );
    render_box(&p("late.exr"), &["--spp-range", "2..4"]);
    render_box(
        &p("late_d2.exr"),
        &["--spp-range", "2..4", "-D", "max_depth=2"],
    );
    let merge = |inputs: &[&str], out: &str| {
        let mut c = btfpt();
        c.arg("merge");
        for i in inputs {
            c.arg(p(i));
        }
        c.arg("-o").arg(p(out)).output().unwrap()
    };
    let o = merge(&["left.exr", "right.exr"], "m.exr");
    assert!(o.status.success(), "{}", text(&o));
    // Same film and seed, but another max_depth: refused, naming the odd file.
    fails_with(
        &merge(&["left.exr", "right_d2.exr"], "bad.exr"),
        &["right_d2.exr", "another scene or with other options"],
    );
    fails_with(
        &merge(&["m.exr", "late_d2.exr"], "bad.exr"),
        &["late_d2.exr", "fingerprint"],
    );
    let o = merge(&["m.exr", "late.exr"], "all.exr");
    assert!(o.status.success(), "{}", text(&o));
    assert!(!p("bad.exr").exists() && !p("bad.png").exists());
}

/// `btfpt compare ARGS` (run from the crate root).
fn compare(args: &[&dyn AsRef<std::ffi::OsStr>]) -> Output {
    let mut c = btfpt();
    c.current_dir(env!("CARGO_MANIFEST_DIR")).arg("compare");
    for a in args {
        c.arg(a);
    }
    c.output().unwrap()
}

/// `img` × `k` written to `out`.
fn scaled(img: &Path, k: f32, out: &Path) {
    let mut i = btfpt::io::read_image(img).unwrap();
    i.data.iter_mut().for_each(|v| *v *= k);
    btfpt::io::write_exr(out, &i).unwrap();
}

#[test]
fn compare_tests_btfpt_against_btfpt_and_mitsuba_and_says_when_nothing_was_tested() {
    let dir = tempfile::tempdir().unwrap();
    let p = |n: &str| dir.path().join(n);
    // Two independent 16-spp renders with their own variance of the mean.
    for seed in ["1", "2"] {
        let (img, var) = (p(&format!("a{seed}.exr")), p(&format!("a{seed}_var.exr")));
        let v = var.display().to_string();
        render_box_sized(
            &img,
            "96",
            "72",
            &["--spp", "16", "--seed", seed, "--variance", &v],
        );
    }
    let (a1, a2, v1, v2) = (p("a1.exr"), p("a2.exr"), p("a1_var.exr"), p("a2_var.exr"));
    // Only the reference's noise: the test's own noise is left out of the pixel tests, so
    // hundreds of pixels fail them (the block verdict, a 16-spp test at var(z) ≈ 2, may pass).
    let failing_pixels = |t: &str| -> usize {
        let after = t.split(" pixels: ").nth(1).unwrap_or_else(|| panic!("{t}"));
        after.split(' ').next().unwrap().parse().unwrap()
    };
    let o = compare(&[&a1, &a2, &"--variance", &v2]);
    let reference_noise_only = failing_pixels(&text(&o));
    assert!(reference_noise_only > 100, "{}", text(&o));
    // Both images' noise: a correct render passes against another btfpt render...
    let diff = p("diff.png");
    let o = compare(&[
        &a1,
        &a2,
        &"--test-variance",
        &v1,
        &"--variance",
        &v2,
        &"--diff",
        &diff,
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let t = text(&o);
    assert!(t.contains("0 failing") && t.contains("\nPASS"), "{t}");
    assert!(failing_pixels(&t) * 4 < reference_noise_only, "{t}");
    assert!(t.contains("the scale is drawn under the image"), "{t}");
    let d = image::open(&diff).unwrap();
    assert!(
        d.width() >= 96 && d.height() == 72 + 18,
        "{}×{}",
        d.width(),
        d.height()
    );
    // ...and 3 % too bright does not.
    scaled(&a1, 1.03, &p("bright.exr"));
    let o = compare(&[
        &p("bright.exr"),
        &a2,
        &"--test-variance",
        &v1,
        &"--variance",
        &v2,
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    // No variance: figures only, and no PASS.
    let o = compare(&[&a1, &a2]);
    assert!(o.status.success());
    let t = text(&o);
    assert!(
        t.contains("no statistical test run") && !t.contains("PASS"),
        "{t}"
    );
    let o = compare(&[&a1, &a2, &"--max-relmse", &"1"]);
    assert!(text(&o).contains("PASS (relMSE bound only; no statistical test run)"));

    // Against the committed Mitsuba reference (16384 spp) at 16 spp: its per-sample variance
    // predicts the test's noise; rare light paths fail 23 single pixels (measured), no 4×4 block.
    let m = p("m.exr");
    render_box_sized(&m, "128", "128", &["--spp", "16", "--seed", "3"]);
    let reference = Path::new("reference-images/cornell-box/cornell-box.exr");
    let strict = [
        "--spp",
        "16",
        "--max-failing-pixels",
        "40",
        "--max-failing-blocks",
        "0",
    ];
    let args = |t: &Path| -> Vec<std::ffi::OsString> {
        let mut a = vec![t.into(), reference.into()];
        a.extend(strict.iter().map(Into::into));
        a
    };
    let run = |t: &Path| {
        let a = args(t);
        compare(
            &a.iter()
                .map(|s| s as &dyn AsRef<std::ffi::OsStr>)
                .collect::<Vec<_>>(),
        )
    };
    let o = run(&m);
    assert!(o.status.success(), "{}", text(&o));
    scaled(&m, 1.03, &p("m_bright.exr"));
    let o = run(&p("m_bright.exr"));
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("fail the z-test"), "{}", text(&o));
}

/// 2 views × 81 lights of a 16×16 noise texture (linear), as a cache.
fn small_sample(path: &Path) {
    let mut rng = btfpt::math::Pcg32::new(5, 5);
    let tex: Vec<f32> = (0..16 * 16).map(|_| 0.2 + 0.6 * rng.next_f32()).collect();
    crate::common::write_two_view_btf(path, 16, 16, &tex);
}

/// The text after `key` up to the end of its line.
fn line_after<'a>(text: &'a str, key: &str) -> &'a str {
    let i = text
        .find(key)
        .unwrap_or_else(|| panic!("{key:?} not in {text}"))
        + key.len();
    text[i..].lines().next().unwrap_or("").trim()
}

#[test]
fn fit_info_and_eval_report_the_same_figures() {
    let dir = tempfile::tempdir().unwrap();
    let (data, model, json) = (
        dir.path().join("s.btfc"),
        dir.path().join("t.plmc"),
        dir.path().join("e.json"),
    );
    small_sample(&data);
    // An 8×8 tile (64 texels) with the default 256 clusters asked for.
    let o = btfpt()
        .arg("fit")
        .arg(&data)
        .arg("-o")
        .arg(&model)
        .args(["--tile", "8"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let fit = String::from_utf8_lossy(&o.stdout).into_owned();
    let o = btfpt().arg("info").arg(&model).output().unwrap();
    assert!(o.status.success(), "{}", text(&o));
    let info = String::from_utf8_lossy(&o.stdout).into_owned();
    // Compression: one definition, against the tile's own texels, in both.
    let ratio = line_after(&info, "bytes, ");
    assert!(
        ratio.starts_with("1:") && ratio.contains("of its 8×8 texels"),
        "{info}"
    );
    assert!(fit.contains(ratio), "fit says:\n{fit}\ninfo says: {ratio}");
    // Clusters: per view and colour channel, at most the 64 texels, the same in both; fit warns
    // that 256 could not be made.
    let clusters = line_after(&info, "clusters:    ");
    assert!(
        clusters.contains("per view and colour channel, for 64 texels"),
        "{info}"
    );
    let k: usize = clusters
        .split(|c: char| !c.is_ascii_digit())
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(k <= 64, "{info}");
    assert!(fit.contains(&format!("clusters: {clusters}")), "{fit}");
    assert!(fit.contains("256 requested"), "{fit}");
    assert!(info.contains("value space: linear"), "{info}");
    // eval: the table, the tile line and the JSON use the same ratio.
    let o = btfpt()
        .arg("eval")
        .arg(&model)
        .arg("--against")
        .arg(&data)
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains(ratio), "{}", text(&o));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let want: f64 = ratio[2..]
        .split_whitespace()
        .next()
        .unwrap()
        .parse()
        .unwrap();
    for r in [&v["models"]["plmc"]["ratio"], &v["tile"]["ratio"]] {
        let r = r.as_f64().unwrap();
        assert!(
            (r - want).abs() < 0.051,
            "JSON ratio {r} vs printed 1:{want}"
        );
    }
}
