//! `btfpt merge` on bands rendered by the real binary: parts of either integrator merge into the
//! one-machine image, a part rendered with another BTF or mesh file is refused, and a merge that
//! lacks bands says so.

use crate::common::btfpt_output;
use btfpt::btf::{self, DirectionSet, RawBtf, StoredEncoding};
use std::path::{Path, PathBuf};

/// A 1×1-texel BTF on the UBO2003 directions, of constant colour `rgb`.
fn write_btf(path: &Path, rgb: [f32; 3]) {
    let d = DirectionSet::ubo2003();
    let data: Vec<f32> = (0..81 * 81).flat_map(|_| rgb).collect();
    let raw = RawBtf::from_f32(d.clone(), d, 1, 1, StoredEncoding::Linear, &data).unwrap();
    btf::cache::write_raw(&raw, path).unwrap();
}

/// A quad in the plane z = `z` as an OBJ file.
fn write_obj(path: &Path, z: f32) {
    std::fs::write(
        path,
        format!(
            "v -1 -1 {z}\nv 1 -1 {z}\nv 1 1 {z}\nv -1 1 {z}\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
             f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"
        ),
    )
    .unwrap();
}

/// A scene in `dir`: a BTF rectangle (`m.btfc`) in front of an OBJ backdrop (`wall.obj`).
fn scene(dir: &Path) -> PathBuf {
    write_btf(&dir.join("m.btfc"), [0.5, 0.4, 0.3]);
    write_obj(&dir.join("wall.obj"), -1.0);
    let xml = format!(
        r#"<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="3"/></integrator>
{}    <shape type="rectangle">
        <transform name="to_world"><scale value="0.6"/></transform>
        <bsdf type="btf"><string name="filename" value="m.btfc"/></bsdf>
    </shape>
    <shape type="obj"><string name="filename" value="wall.obj"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.7, 0.7"/></bsdf></shape>
    <emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
</scene>
"#,
        crate::common::perspective_sensor(60.0, 3.0, 4, 8, 8)
    );
    let p = dir.join("s.xml");
    std::fs::write(&p, xml).unwrap();
    p
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn render(scene: &Path, out: &Path, extra: &[&str]) {
    let mut args = vec!["render", s(scene), "-o", s(out), "--threads", "1"];
    args.extend_from_slice(extra);
    let (ok, _, err) = btfpt_output(&args);
    assert!(ok, "{err}");
}

fn merge(parts: &[&Path], out: &Path) -> (bool, String) {
    let mut args = vec!["merge"];
    args.extend(parts.iter().map(|p| s(p)));
    args.extend(["-o", s(out)]);
    let (ok, _, err) = btfpt_output(&args);
    (ok, err)
}

fn pixels(p: &Path) -> Vec<f32> {
    btfpt::io::read_image(p).unwrap().data
}

#[test]
fn bands_of_the_packet_and_scalar_integrators_merge_into_the_one_machine_image() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sc = scene(d);
    let full = d.join("full.exr");
    render(&sc, &full, &[]);
    let (b0, b1) = (d.join("b0.exr"), d.join("b1.exr"));
    render(&sc, &b0, &["--band", "0/2", "--integrator", "scalar"]);
    render(&sc, &b1, &["--band", "1/2", "--integrator", "packet"]);
    let merged = d.join("m.exr");
    let (ok, err) = merge(&[&b0, &b1], &merged);
    assert!(ok, "{err}");
    assert!(!err.contains("warning"), "{err}");
    assert_eq!(pixels(&merged), pixels(&full));
}

#[test]
fn a_merge_of_some_bands_only_warns_that_parts_are_missing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sc = scene(d);
    let parts: Vec<PathBuf> = (0..3).map(|i| d.join(format!("b{i}.exr"))).collect();
    for (i, p) in parts.iter().enumerate() {
        render(&sc, p, &["--band", &format!("{i}/3")]);
    }
    let m01 = d.join("m01.exr");
    let (ok, err) = merge(&[&parts[0], &parts[1]], &m01);
    assert!(ok, "{err}");
    assert!(
        err.contains("warning:") && err.contains("missing") && err.contains("0,0,8×8"),
        "{err}"
    );
    let (ok, err) = merge(&[&parts[2]], &d.join("m2.exr"));
    assert!(ok && err.contains("missing"), "{err}");
    // The missing band added to the earlier merge completes the image: no warning.
    let (ok, err) = merge(&[&m01, &parts[2]], &d.join("all.exr"));
    assert!(ok && !err.contains("warning"), "{err}");
}

#[test]
fn parts_rendered_with_another_btf_or_mesh_file_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sc = scene(d);
    let (b0, b1) = (d.join("b0.exr"), d.join("b1.exr"));
    render(&sc, &b0, &["--band", "0/2"]);
    // Another material in the same file name.
    write_btf(&d.join("m.btfc"), [0.9, 0.1, 0.1]);
    render(&sc, &b1, &["--band", "1/2"]);
    let (ok, err) = merge(&[&b0, &b1], &d.join("m.exr"));
    assert!(
        !ok && err.contains("fingerprint") && err.contains("BTF"),
        "{err}"
    );
    // The original material back, another mesh.
    write_btf(&d.join("m.btfc"), [0.5, 0.4, 0.3]);
    write_obj(&d.join("wall.obj"), -1.5);
    render(&sc, &b1, &["--band", "1/2"]);
    let (ok, err) = merge(&[&b0, &b1], &d.join("m.exr"));
    assert!(!ok && err.contains("mesh"), "{err}");
    // Both back as they were: the parts merge.
    write_obj(&d.join("wall.obj"), -1.0);
    render(&sc, &b1, &["--band", "1/2"]);
    let (ok, err) = merge(&[&b0, &b1], &d.join("m.exr"));
    assert!(ok, "{err}");
}

#[test]
fn aov_channels_merge_like_the_image_and_resume_bit_exactly() {
    use btfpt::render::partial::read_partial_exr_with;
    let dir = tempfile::tempdir().unwrap();
    let scene = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/mitsuba-aov/scene.xml");
    let out = |n: &str| dir.path().join(n);
    let render = |o: &Path, extra: &[&str]| {
        let mut a = vec!["render", s(&scene), "-o", s(o), "--threads", "2"];
        if !extra.contains(&"--spp-range") {
            a.extend(["--spp", "6"]);
        }
        a.extend_from_slice(extra);
        let (ok, _, err) = btfpt_output(&a);
        assert!(ok, "{err}");
    };
    render(&out("full.exr"), &[]);
    render(&out("b0.exr"), &["--band", "0/2"]);
    render(&out("b1.exr"), &["--band", "1/2"]);
    render(&out("s0.exr"), &["--spp-range", "0..2"]);
    render(&out("s1.exr"), &["--spp-range", "2..6"]);
    let merge = |parts: &[&str], o: &str| {
        let mut a = vec!["merge"];
        let paths: Vec<PathBuf> = parts.iter().map(|p| out(p)).collect();
        a.extend(paths.iter().map(|p| s(p)));
        let o = out(o);
        a.extend(["-o", s(&o)]);
        btfpt_output(&a)
    };
    let (full_img, full, _) = read_partial_exr_with(&out("full.exr")).unwrap();
    assert_eq!(
        full.len(),
        31,
        "{:?}",
        full.iter().map(|c| &c.0).collect::<Vec<_>>()
    );
    // Bands (crop windows) merge into the same bits, every channel.
    let (ok, _, err) = merge(&["b0.exr", "b1.exr"], "bands.exr");
    assert!(ok, "{err}");
    let (img, ch, _) = read_partial_exr_with(&out("bands.exr")).unwrap();
    assert_eq!((img, &ch), (full_img.clone(), &full));
    // Sample ranges merge to float rounding.
    let (ok, _, err) = merge(&["s0.exr", "s1.exr"], "ranges.exr");
    assert!(ok, "{err}");
    let (_, ch, _) = read_partial_exr_with(&out("ranges.exr")).unwrap();
    for ((name, a), (_, b)) in ch.iter().zip(&full) {
        for (x, y) in a.iter().zip(b) {
            assert!(
                (x - y).abs() <= 1e-5 * (1.0 + y.abs()),
                "{name}: {x} vs {y}"
            );
        }
    }
    // A part without the channels (another render) is refused.
    let plain = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box/scene.xml");
    let (ok, _, _) = btfpt_output(&[
        "render",
        s(&plain),
        "-o",
        s(&out("p.exr")),
        "--spp",
        "1",
        "--threads",
        "1",
    ]);
    assert!(ok);
    let (ok, _, err) = merge(&["b0.exr", "p.exr"], "bad.exr");
    assert!(!ok && !out("bad.exr").exists(), "{err}");

    // A checkpoint of the channel sums resumes to the same state.
    use btfpt::render::film::{RenderSettings, RenderState};
    use btfpt::render::{RenderScene, checkpoint};
    let sc = btfpt::scene::load(&scene, &Default::default()).unwrap();
    let n = sc.channels.per_sample.len();
    let rs = RenderScene::new(sc).unwrap();
    let st = RenderSettings {
        width: 40,
        height: 30,
        crop: [0, 0, 40, 30],
        spp_begin: 0,
        spp_end: 4,
        seed: 3,
    };
    let filter = rs.scene.camera.filter;
    let mut whole = RenderState::with_channels(st, filter, n).unwrap();
    btfpt::render::driver::render_all(&rs, &mut whole);
    let mut part = RenderState::with_channels(st, filter, n).unwrap();
    let stop = std::sync::atomic::AtomicBool::new(false);
    btfpt::render::driver::run_pass(&rs, &mut part, 1, &stop, &|_, _| {});
    let ck = out("a.ckpt");
    checkpoint::save(&ck, &part, 9).unwrap();
    let mut resumed = checkpoint::load_channels(&ck, &st, &filter, n, 9).unwrap();
    assert!(resumed == part);
    btfpt::render::driver::render_all(&rs, &mut resumed);
    assert!(resumed == whole, "resumed channel sums differ");
}
