//! The `btfpt merge` and `btfpt render` command lines: success path and clear errors.

use crate::common::*;
use btfpt::geometry::generate::sphere;
use btfpt::math::{Spectrum, Vec3};
use btfpt::render::RenderScene;
use btfpt::render::partial::{PartialMeta, read_partial_exr, write_partial_exr};
use btfpt::scene::Emitter;

#[test]
fn merge_cli_combines_crops_and_reports_bad_input() {
    let s = scene(
        Vec3::new(0.0, 0.0, 3.0),
        Vec3::ZERO,
        50.0,
        (10, 6),
        vec![sphere(Vec3::ZERO, 1.0, 8, 16, false, true)],
        vec![diffuse(0.5)],
        vec![Emitter::Constant {
            radiance: Spectrum::ONE,
        }],
    );
    let rs = RenderScene::new(s).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mut args = vec!["merge".to_string()];
    for (i, crop) in [[0, 0, 4, 6], [4, 0, 6, 6]].iter().enumerate() {
        let mut st = settings(&rs.scene, 2, 1);
        st.crop = *crop;
        let r = render(&rs, st);
        let p = dir.path().join(format!("p{i}.exr"));
        let meta = PartialMeta {
            width: 10,
            height: 6,
            crop: *crop,
            spp_begin: 0,
            spp_end: 2,
            seed: 1,
            scene: 0x5eed,
            whole: None,
        };
        write_partial_exr(&p, &r.mean_image(), &meta).unwrap();
        args.push(p.display().to_string());
    }
    let out = dir.path().join("m.exr");
    let st = btfpt().args(&args).arg("-o").arg(&out).status().unwrap();
    assert!(st.success());
    let (img, meta) = read_partial_exr(&out).unwrap();
    assert_eq!(meta.crop, [0, 0, 10, 6]);
    let full = render(&rs, settings(&rs.scene, 2, 1)).mean_image();
    assert_eq!(img, full);
    assert!(dir.path().join("m.png").exists());

    // A plain EXR without the btfpt attribute is refused with its name.
    let plain = dir.path().join("plain.exr");
    btfpt::io::write_exr(&plain, &full).unwrap();
    let o = btfpt()
        .args(["merge", plain.to_str().unwrap(), "-o"])
        .arg(dir.path().join("x.exr"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("plain.exr") && err.contains("partial"),
        "{err}"
    );
}

#[test]
fn render_cli_reports_a_missing_scene_and_bad_arguments() {
    let o = btfpt()
        .args(["render", "/nonexistent/scene.xml", "--spp", "4"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert_eq!(o.status.code(), Some(1), "no panic");
    assert!(String::from_utf8_lossy(&o.stderr).contains("scene.xml"));
    let o = btfpt()
        .args(["render", "scene.xml", "--spp-range", "8..4"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("empty"));
    let o = btfpt()
        .args(["render", "scene.xml", "--crop", "1,2,x"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--crop"));
}

/// A small scene file for the command-line renders below.
fn band_scene() -> String {
    format!(
        r#"<scene version="3.0.0">
{}    <shape type="sphere"><bsdf type="diffuse"/></shape>
    <emitter type="constant"/>
</scene>
"#,
        crate::common::perspective_sensor(45.0, 3.0, 4, 12, 7)
    )
}

#[test]
fn render_bands_merge_byte_identically_and_bad_bands_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.xml");
    std::fs::write(&scene, band_scene()).unwrap();
    let run = |extra: &[&str], out: &str| {
        btfpt()
            .arg("render")
            .arg(&scene)
            .arg("-o")
            .arg(dir.path().join(out))
            .args(["--seed", "5"])
            .args(extra)
            .output()
            .unwrap()
    };
    assert!(run(&[], "full.exr").status.success());
    // 7 rows in 3 bands: 2, 2 and 3 rows.
    let mut merge = btfpt();
    merge.arg("merge");
    for i in 0..3 {
        let name = format!("b{i}.exr");
        let o = run(&["--band", &format!("{i}/3")], &name);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (_, meta) = read_partial_exr(&dir.path().join(&name)).unwrap();
        let rows = [[0, 2], [2, 2], [4, 3]][i];
        assert_eq!(meta.crop, [0, rows[0], 12, rows[1]], "band {i}");
        merge.arg(dir.path().join(name));
    }
    let merged = dir.path().join("merged.exr");
    assert!(merge.arg("-o").arg(&merged).status().unwrap().success());
    assert!(
        std::fs::read(&merged).unwrap() == std::fs::read(dir.path().join("full.exr")).unwrap(),
        "merged bands differ from the one-process render"
    );
    for (band, msg) in [
        ("3/3", "0..3"),
        ("1/0", "0..0"),
        ("x/2", "bad band index"),
        ("1", "expected I/N"),
        ("0/8", "only 7 rows"),
    ] {
        let o = run(&["--band", band], "bad.exr");
        assert_eq!(o.status.code(), Some(1), "--band {band}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("--band") && err.contains(msg), "{band}: {err}");
    }
    let o = run(&["--band", "0/2", "--crop", "0,0,2,2"], "bad.exr");
    assert!(!o.status.success(), "--band and --crop conflict");
}
