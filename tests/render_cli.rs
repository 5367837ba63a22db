//! The `btfpt merge` and `btfpt render` command lines: success path and clear errors.
mod common;

use btfpt::geometry::generate::sphere;
use btfpt::math::{Spectrum, Vec3};
use btfpt::render::RenderScene;
use btfpt::render::partial::{PartialMeta, read_partial_exr, write_partial_exr};
use btfpt::scene::Emitter;
use common::*;

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
