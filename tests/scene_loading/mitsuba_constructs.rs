//! Mitsuba scene-file constructs written by the tests themselves: `<include>`, `<path>`,
//! `<alias>`, `<spectrum>`, Mitsuba 0.6 upgrades, serialized and cylinder shapes, bitmap and
//! checkerboard textures, samplers, the direct integrator; and their bad inputs (each message
//! names the file and the line).

use crate::fixtures::{assert_names, load, load_err, write};
use btfpt::bsdf::{Bsdf, Texture};
use btfpt::io::{RgbImage, write_png_srgb};
use btfpt::math::{Spectrum, Vec2};
use btfpt::scene::{self, LoadOptions, SamplerType, Scene};
use std::path::Path;

const SENSOR: &str = r#"
    <sensor type="perspective">
        <float name="fov" value="45"/>
        <film type="hdrfilm"><rfilter type="box"/></film>
    </sensor>"#;

fn scene_text(body: &str) -> String {
    format!("<scene version=\"3.0.0\">\n{SENSOR}\n{body}\n</scene>\n")
}

/// Asserts that loading fails with a message naming `file`, `line` and containing `needle`.
fn expect_err(p: &Path, file: &str, line: u32, needle: &str) {
    assert_names(&load_err(p, &[]), file, line, &[needle]);
}

fn diffuse_reflectance(s: &Scene, mesh: usize) -> &Texture {
    match &s.bsdfs[s.meshes[mesh].bsdf as usize] {
        Bsdf::Diffuse(d) => &d.reflectance,
        b => panic!("expected diffuse, got {b:?}"),
    }
}

#[test]
fn include_path_alias_and_spectrum() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut img = RgbImage::new(2, 1);
    img.set(0, 0, [1.0, 0.0, 0.0]);
    img.set(1, 0, [0.0, 0.0, 1.0]);
    std::fs::create_dir_all(d.join("tex")).unwrap();
    write_png_srgb(&d.join("tex/two.png"), &img).unwrap();
    // sub/part.xml includes nested.xml relative to itself (sub/), not to the root file.
    write(
        d,
        "sub/part.xml",
        r#"<scene version="3.0.0">
            <texture type="bitmap" id="tx"><string name="filename" value="two.png"/></texture>
            <include filename="nested.xml"/>
        </scene>"#,
    );
    write(
        d,
        "sub/nested.xml",
        r#"<scene version="3.0.0">
            <shape type="rectangle" id="a">
                <bsdf type="diffuse"><spectrum name="reflectance" value="0.25"/></bsdf>
            </shape>
        </scene>"#,
    );
    // An included object file (not a scene): the object itself.
    write(
        d,
        "mat.xml",
        r#"<bsdf version="3.0.0" type="diffuse" id="m"><ref name="reflectance" id="tex2"/></bsdf>"#,
    );
    let p = write(
        d,
        "main.xml",
        &scene_text(
            r#"<path value="tex"/>
               <include filename="sub/part.xml"/>
               <alias id="tx" as="tex2"/>
               <include filename="mat.xml"/>
               <shape type="sphere"><ref id="m"/></shape>"#,
        ),
    );
    let s = load(&p);
    assert_eq!(s.meshes.len(), 2);
    assert_eq!(
        diffuse_reflectance(&s, 0).eval(Vec2::ZERO),
        Spectrum::splat(0.25)
    );
    let t = diffuse_reflectance(&s, 1);
    assert!(t.is_spatially_varying());
    assert!((t.eval(Vec2::new(0.25, 0.5)) - Spectrum::new(1.0, 0.0, 0.0)).length() < 1e-3);
}

#[test]
fn include_errors_name_the_including_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let p = write(
        d,
        "main.xml",
        &scene_text("\n<include filename=\"missing.xml\"/>"),
    );
    expect_err(&p, "main.xml", 8, "included file");
    // a.xml → b.xml → a.xml
    write(
        d,
        "a.xml",
        "<scene version=\"3.0.0\">\n<include filename=\"b.xml\"/>\n</scene>",
    );
    write(
        d,
        "b.xml",
        "<scene version=\"3.0.0\">\n\n<include filename=\"a.xml\"/>\n</scene>",
    );
    let p = write(d, "cyc.xml", &scene_text("<include filename=\"a.xml\"/>"));
    expect_err(&p, "b.xml", 3, "cycle");
    // A malformed included file names itself.
    write(
        d,
        "bad.xml",
        "<scene version=\"3.0.0\">\n<shape type=\"x\">\n</scene>",
    );
    let p = write(d, "m2.xml", &scene_text("<include filename=\"bad.xml\"/>"));
    let e = scene::load(&p, &LoadOptions::default())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("bad.xml") && e.contains("malformed XML"), "{e}");
    // An error inside an included file names that file and its line.
    write(
        d,
        "inner.xml",
        "<scene version=\"3.0.0\">\n\n<shape type=\"torus\"/>\n</scene>",
    );
    let p = write(
        d,
        "m3.xml",
        &scene_text("<include filename=\"inner.xml\"/>"),
    );
    expect_err(&p, "inner.xml", 3, "unsupported shape type");
}

#[test]
fn alias_path_and_spectrum_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let p = write(d, "a.xml", &scene_text("<alias id=\"nothing\" as=\"x\"/>"));
    expect_err(&p, "a.xml", 7, "alias source ID \"nothing\" not found");
    let p = write(
        d,
        "b.xml",
        &scene_text(
            "<bsdf type=\"diffuse\" id=\"x\"/>\n<bsdf type=\"diffuse\" id=\"y\"/>\n<alias id=\"x\" as=\"y\"/>",
        ),
    );
    expect_err(&p, "b.xml", 9, "already exists");
    let p = write(d, "c.xml", &scene_text("<path value=\"no-such-folder\"/>"));
    expect_err(&p, "c.xml", 7, "not found");
    let bad = [
        ("400:0.1, 400:0.5", "increasing order"),
        ("400:0.1, 500:x", "invalid spectrum value \"500:x\""),
        ("400:0.1", "at least two entries"),
        ("400:0.1, 500", "expected wavelength:value pairs"),
    ];
    for (value, needle) in bad {
        let p = write(
            d,
            "e.xml",
            &scene_text(&format!(
                "<shape type=\"sphere\"><bsdf type=\"diffuse\">\n<spectrum name=\"reflectance\" value=\"{value}\"/></bsdf></shape>"
            )),
        );
        expect_err(&p, "e.xml", 8, needle);
    }
    // Spectral-only uses: a spectrum plugin, a wavelength list where a number is needed.
    let p = write(
        d,
        "f.xml",
        &scene_text(
            "<shape type=\"sphere\"><emitter type=\"area\">\n<spectrum type=\"blackbody\" name=\"radiance\"/></emitter></shape>",
        ),
    );
    expect_err(&p, "f.xml", 8, "spectral plugin");
    let p = write(
        d,
        "g.xml",
        &scene_text(
            "<shape type=\"sphere\"><bsdf type=\"dielectric\">\n<spectrum name=\"int_ior\" value=\"400:1.5, 700:1.4\"/></bsdf></shape>",
        ),
    );
    expect_err(&p, "g.xml", 8, "int_ior");
    let p = write(
        d,
        "h.xml",
        &scene_text(
            "<shape type=\"sphere\"><bsdf type=\"diffuse\">\n<spectrum name=\"reflectance\" filename=\"none.spd\"/></bsdf></shape>",
        ),
    );
    expect_err(&p, "h.xml", 8, "none.spd");
    write(d, "bad.spd", "# nm value\n400 0.5\n500 oops\n");
    let p = write(
        d,
        "i.xml",
        &scene_text(
            "<shape type=\"sphere\"><bsdf type=\"diffuse\">\n<spectrum name=\"reflectance\" filename=\"bad.spd\"/></bsdf></shape>",
        ),
    );
    expect_err(&p, "i.xml", 8, "line 3");
}

/// A top-level area emitter with an id, referenced by a shape written before it (Mitsuba's
/// Cornell boxes, `cbox-rgb.xml`); one that no shape references is an error.
#[test]
fn top_level_area_emitter_referenced_by_a_shape() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let s = load(&write(
        d,
        "a.xml",
        &scene_text(
            "<shape type=\"sphere\"><ref id=\"area-emitter\"/></shape>\n<emitter type=\"area\" id=\"area-emitter\"><rgb name=\"radiance\" value=\"1, 2, 3\"/></emitter>",
        ),
    ));
    assert_eq!(s.meshes[0].emitter, Some(Spectrum::new(1.0, 2.0, 3.0)));
    assert!(s.emitters.is_empty());
    let p = write(
        d,
        "b.xml",
        &scene_text(
            "<shape type=\"sphere\"/>\n<emitter type=\"area\" id=\"lonely\"><rgb name=\"radiance\" value=\"1\"/></emitter>",
        ),
    );
    expect_err(&p, "b.xml", 8, "no shape references this one");
}

/// Mitsuba 3.9.1's values (`reference-images/spectrum_golden.py`): `<use> r g b <spectrum>`.
const SPECTRUM_GOLDEN: &str = include_str!("../../reference-images/spectrum_golden.txt");

/// Wavelength-list spectra load as Mitsuba's RGB variants convert them: a diffuse reflectance
/// (D65-weighted, clipped to [0, 1]), a conductor's eta (unbounded), an area light's and a
/// constant emitter's radiance (no D65 weighting; a constant spectrum is Mitsuba's purplish
/// white), inline or from a `.spd` file.
#[test]
fn wavelength_list_spectra_match_mitsuba() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let close =
        |a: Spectrum, b: Spectrum| (a - b).abs().max_element() <= 2e-6 * b.max_element().max(1.0);
    let mut n = 0;
    for line in SPECTRUM_GOLDEN.lines() {
        let f: Vec<&str> = line.splitn(5, ' ').collect();
        let want = Spectrum::new(
            f[1].parse().unwrap(),
            f[2].parse().unwrap(),
            f[3].parse().unwrap(),
        );
        let spec = |name: &str| format!("<spectrum name=\"{name}\" value=\"{}\"/>", f[4]);
        let body = match f[0] {
            "reflectance" => format!(
                "<shape type=\"sphere\"><bsdf type=\"diffuse\">{}</bsdf></shape>",
                spec("reflectance")
            ),
            "unbounded" => format!(
                "<shape type=\"sphere\"><bsdf type=\"conductor\">{}</bsdf></shape>",
                spec("eta")
            ),
            _ => format!(
                "<shape type=\"sphere\"><emitter type=\"area\">{}</emitter></shape>\n<emitter type=\"constant\">{}</emitter>",
                spec("radiance"),
                spec("radiance")
            ),
        };
        let s = load(&write(d, "s.xml", &scene_text(&body)));
        let got: Vec<Spectrum> = match f[0] {
            "reflectance" => vec![diffuse_reflectance(&s, 0).eval(Vec2::ZERO)],
            "unbounded" => match &s.bsdfs[s.meshes[0].bsdf as usize] {
                Bsdf::Conductor(c) => vec![c.eta.eval(Vec2::ZERO)],
                b => panic!("{b:?}"),
            },
            _ => {
                let area = s.meshes[0].emitter.unwrap();
                match s.emitters[..] {
                    [scene::Emitter::Constant { radiance }] => vec![area, radiance],
                    ref e => panic!("{e:?}"),
                }
            }
        };
        for g in got {
            assert!(close(g, want), "{line}: ours {g}, Mitsuba {want}");
        }
        n += 1;
    }
    assert_eq!(n, 14);
    // A .spd file (comments, blank lines, extra columns ignored) is the same spectrum.
    write(
        d,
        "red.spd",
        "# cbox red, a few samples\n400 0.04\n\n550 0.063 x\n700 0.642\n",
    );
    let s = load(&write(
        d,
        "spd.xml",
        &scene_text(
            "<shape type=\"sphere\"><bsdf type=\"diffuse\"><spectrum name=\"reflectance\" filename=\"red.spd\"/></bsdf></shape>\n\
             <shape type=\"sphere\"><bsdf type=\"diffuse\"><spectrum name=\"reflectance\" value=\"400:0.04 550:0.063 700:0.642\"/></bsdf></shape>",
        ),
    ));
    let (a, b) = (
        diffuse_reflectance(&s, 0).eval(Vec2::ZERO),
        diffuse_reflectance(&s, 1).eval(Vec2::ZERO),
    );
    assert!(a == b && a.x > 0.3 && a.y < 0.2, "{a} {b}");
}

#[test]
fn mitsuba_06_files_are_upgraded_like_mitsuba_3() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut img = RgbImage::new(4, 4);
    for (i, v) in img.data.iter_mut().enumerate() {
        *v = (i % 7) as f32 / 7.0;
    }
    write_png_srgb(&d.join("t.png"), &img).unwrap();
    let old = write(
        d,
        "old.xml",
        r#"<scene version="0.6.0">
            <integrator type="path"><integer name="maxDepth" value="4"/>
                <boolean name="hideEmitters" value="true"/></integrator>
            <sensor type="perspective"><float name="fov" value="45"/>
                <sampler type="ldsampler"><integer name="sampleCount" value="9"/></sampler>
                <film type="hdrfilm"><rfilter type="box"/></film></sensor>
            <shape type="sphere"><transform name="toWorld"><translate x="1"/></transform>
                <bsdf type="diffuse"><texture type="bitmap" name="diffuseReflectance">
                    <string name="filename" value="t.png"/><float name="uoffset" value="0.25"/>
                    <float name="uscale" value="2"/><float name="vscale" value="3"/>
                </texture></bsdf></shape>
            <shape type="sphere"><bsdf type="dielectric"><float name="intIOR" value="1.7"/>
                <float name="extIOR" value="1.1"/></bsdf></shape>
        </scene>"#,
    );
    let new = write(
        d,
        "new.xml",
        r#"<scene version="3.0.0">
            <integrator type="path"><integer name="max_depth" value="4"/>
                <boolean name="hide_emitters" value="true"/></integrator>
            <sensor type="perspective"><float name="fov" value="45"/>
                <sampler type="ldsampler"><integer name="sample_count" value="9"/></sampler>
                <film type="hdrfilm"><rfilter type="box"/></film></sensor>
            <shape type="sphere"><transform name="to_world"><translate x="1"/></transform>
                <bsdf type="diffuse"><texture type="bitmap" name="reflectance">
                    <string name="filename" value="t.png"/>
                    <transform name="to_uv"><translate x="0.25"/><scale x="2" y="3"/></transform>
                </texture></bsdf></shape>
            <shape type="sphere"><bsdf type="dielectric"><float name="int_ior" value="1.7"/>
                <float name="ext_ior" value="1.1"/></bsdf></shape>
        </scene>"#,
    );
    let (a, b) = (load(&old), load(&new));
    assert_eq!(a.integrator, b.integrator);
    assert_eq!((a.spp, b.spp), (16, 16)); // ldsampler rounds 9 up to 4²
    assert_eq!(format!("{:?}", a.bsdfs), format!("{:?}", b.bsdfs));
    assert_eq!(format!("{:?}", a.meshes), format!("{:?}", b.meshes));
    // The upgrade is only for old files: a 3.0 file with camelCase names is an error.
    let bad = write(
        d,
        "bad.xml",
        &std::fs::read_to_string(&old)
            .unwrap()
            .replace("0.6.0", "3.0.0"),
    );
    expect_err(&bad, "bad.xml", 2, "maxDepth");
}

#[test]
fn serialized_and_cylinder_shapes() {
    // The committed feature scene: its serialized file holds a floor and a tetrahedron.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let s = load(&root.join("scenes/mitsuba-features/scene.xml"));
    let floor = s
        .meshes
        .iter()
        .find(|m| m.name.contains("floor"))
        .expect("floor");
    assert_eq!((floor.indices.len(), floor.uvs.len()), (2, 4));
    let tet = s
        .meshes
        .iter()
        .find(|m| m.name.contains("tetra"))
        .expect("tetra");
    assert_eq!(tet.indices.len(), 4);
    // Mitsuba 3 ignores the file's face-normals flag in v4 files: smooth normals are computed.
    assert_eq!(tet.normals.len(), tet.positions.len());

    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "c.xml",
        &scene_text(
            r#"<shape type="cylinder"><float name="radius" value="0.5"/>
               <point name="p0" x="1" y="0" z="0"/><point name="p1" x="1" y="0" z="2"/></shape>"#,
        ),
    );
    let s = load(&p);
    let m = &s.meshes[0];
    // Mitsuba's uv: (φ / 2π, z / length) with φ from the frame's s (= +x for an axis along +z).
    for (p, uv) in m.positions.iter().zip(&m.uvs) {
        let (x, y) = (p.x - 1.0, p.y);
        assert!(((x * x + y * y).sqrt() - 0.5).abs() < 1e-5);
        let phi = y.atan2(x).rem_euclid(std::f32::consts::TAU) / std::f32::consts::TAU;
        let du = (phi - uv.x).abs();
        assert!(du < 1e-4 || (du - 1.0).abs() < 1e-4, "{p} {uv}");
        assert!((p.z / 2.0 - uv.y).abs() < 1e-5);
    }
    // Normals point outwards.
    for (p, n) in m.positions.iter().zip(&m.normals) {
        assert!(n.dot(btfpt::math::Vec3::new(p.x - 1.0, p.y, 0.0)) > 0.0);
    }
    let p = write(
        dir.path(),
        "c2.xml",
        &scene_text(
            "<shape type=\"serialized\">\n<string name=\"filename\" value=\"none.serialized\"/></shape>",
        ),
    );
    expect_err(&p, "c2.xml", 7, "none.serialized");
    let p = write(
        dir.path(),
        "c3.xml",
        &scene_text("<shape type=\"cylinder\"><float name=\"radius\" value=\"0\"/></shape>"),
    );
    expect_err(&p, "c3.xml", 7, "positive radius");
}

#[test]
fn textures_bitmap_options_and_checkerboard() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut img = RgbImage::new(2, 2);
    img.set(0, 0, [1.0, 0.0, 0.0]);
    img.set(1, 0, [0.0, 1.0, 0.0]);
    img.set(0, 1, [0.0, 0.0, 1.0]);
    img.set(1, 1, [1.0, 1.0, 1.0]);
    write_png_srgb(&d.join("q.png"), &img).unwrap();
    let p = write(
        d,
        "t.xml",
        &scene_text(
            r#"<shape type="sphere"><bsdf type="diffuse">
                 <texture type="bitmap" name="reflectance"><string name="filename" value="q.png"/>
                   <string name="filter_type" value="nearest"/><string name="wrap_mode" value="clamp"/>
                 </texture></bsdf></shape>
               <shape type="sphere"><bsdf type="diffuse">
                 <texture type="checkerboard" name="reflectance">
                   <texture type="bitmap" name="color0"><string name="filename" value="q.png"/>
                     <boolean name="raw" value="true"/></texture>
                   <float name="color1" value="0.3"/>
                 </texture></bsdf></shape>
               <shape type="sphere"><bsdf type="roughconductor">
                 <string name="distribution" value="ggx"/>
                 <texture type="checkerboard" name="specular_reflectance"/></bsdf></shape>"#,
        ),
    );
    let s = load(&p);
    let t = diffuse_reflectance(&s, 0);
    assert_eq!(t.eval(Vec2::new(3.0, -2.0)), Spectrum::new(0.0, 1.0, 0.0)); // clamp → (1, 0)
    let c = diffuse_reflectance(&s, 1);
    assert_eq!(c.eval(Vec2::new(0.75, 0.25)), Spectrum::splat(0.3));
    // raw: the stored sRGB byte 255·linear_to_srgb(1) = 255 → 1 either way; 0 stays 0.
    assert_eq!(c.eval(Vec2::new(0.25, 0.25)), Spectrum::new(1.0, 0.0, 0.0));
    match &s.bsdfs[s.meshes[2].bsdf as usize] {
        Bsdf::RoughConductor(r) => {
            // Mitsuba's checkerboard defaults: 0.4 and 0.2.
            assert_eq!(
                r.specular_reflectance.eval(Vec2::new(0.1, 0.1)),
                Spectrum::splat(0.4)
            );
            assert!((r.specular_reflectance.mean() - 0.3).abs() < 1e-6);
        }
        b => panic!("{b:?}"),
    }
    for (name, body, needle) in [
        (
            "w.xml",
            "<texture type=\"bitmap\" id=\"t\">\n<string name=\"filename\" value=\"q.png\"/><string name=\"wrap_mode\" value=\"wobble\"/></texture>",
            "invalid wrap mode",
        ),
        (
            "f.xml",
            "<texture type=\"bitmap\" id=\"t\">\n<string name=\"filename\" value=\"q.png\"/><string name=\"filter_type\" value=\"cubic\"/></texture>",
            "invalid filter type",
        ),
        (
            "m.xml",
            "<texture type=\"bitmap\" id=\"t\">\n<string name=\"filename\" value=\"nope.png\"/></texture>",
            "nope.png",
        ),
        (
            "u.xml",
            "<texture type=\"voronoi\" id=\"t\">\n</texture>",
            "unsupported texture type",
        ),
    ] {
        let p = write(d, name, &scene_text(body));
        expect_err(&p, name, 7, needle);
    }
}

#[test]
fn rawconstant_texture_is_used_as_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let p = write(
        d,
        "r.xml",
        &scene_text(
            r#"<shape type="sphere"><bsdf type="diffuse">
                 <texture type="rawconstant" name="reflectance"><vector name="value" value="0.5, 0.25, 1"/></texture>
               </bsdf></shape>
               <shape type="sphere"><bsdf type="diffuse">
                 <texture type="rawconstant" name="reflectance"><float name="value" value="0.7"/></texture>
               </bsdf></shape>"#,
        ),
    );
    let s = load(&p);
    let uv = Vec2::new(0.3, 0.6);
    assert_eq!(
        diffuse_reflectance(&s, 0).eval(uv),
        Spectrum::new(0.5, 0.25, 1.0)
    );
    assert_eq!(diffuse_reflectance(&s, 1).eval(uv), Spectrum::splat(0.7));
    // A missing value is reported at the element, a wrong type at the property.
    for (name, body, line, needle) in [
        (
            "missing.xml",
            "<texture type=\"rawconstant\" id=\"t\">\n</texture>",
            7,
            "missing required parameter \"value\"",
        ),
        (
            "string.xml",
            "<texture type=\"rawconstant\" id=\"t\">\n<string name=\"value\" value=\"red\"/></texture>",
            8,
            "expected float, vector or rgb, got string",
        ),
    ] {
        let p = write(d, name, &scene_text(body));
        expect_err(&p, name, line, needle);
    }
}

#[test]
fn volpath_without_media_reads_as_path() {
    let dir = tempfile::tempdir().unwrap();
    for ty in ["volpath", "volpathmis"] {
        let p = write(
            dir.path(),
            &format!("{ty}.xml"),
            &scene_text(&format!(
                r#"<integrator type="{ty}"><integer name="max_depth" value="7"/><integer name="rr_depth" value="3"/>
                     <boolean name="hide_emitters" value="true"/></integrator>
                   <shape type="sphere"/>"#
            )),
        );
        let i = load(&p).integrator;
        assert_eq!(
            (i.max_depth, i.rr_depth, i.hide_emitters),
            (7, 3, true),
            "{ty}"
        );
        assert!(i.direct.is_none(), "{ty} is a path tracer");
    }
}

/// `ptracer` reads as the path tracer where the two converge to the same image; a specular
/// surface, an environment emitter or an orthographic camera is refused naming the integrator.
#[test]
fn ptracer_reads_as_path_where_both_give_the_same_image() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let integrator = r#"<integrator type="ptracer"><integer name="max_depth" value="5"/>
        <integer name="samples_per_pass" value="4096"/></integrator>"#;
    let p = write(
        d,
        "ok.xml",
        &scene_text(&format!(
            r#"{integrator}
    <shape type="sphere"><bsdf type="roughconductor"/></shape>
    <shape type="rectangle"><emitter type="area"/></shape>
    <emitter type="spot"/>"#
        )),
    );
    let i = load(&p).integrator;
    assert_eq!((i.max_depth, i.rr_depth, i.hide_emitters), (5, 5, false));
    assert!(i.direct.is_none());
    for (name, body, why) in [
        (
            "mirror.xml",
            r#"<shape type="sphere" id="ball"><bsdf type="conductor"/></shape>"#,
            "shape \"ball\" has a specular",
        ),
        (
            "plastic.xml",
            r#"<shape type="sphere"><bsdf type="plastic"/></shape>"#,
            "specular (delta) BSDF",
        ),
        (
            "env.xml",
            r#"<shape type="sphere"/><emitter type="constant"/>"#,
            "environment emitter",
        ),
    ] {
        let p = write(d, name, &scene_text(&format!("{integrator}\n{body}")));
        expect_err(&p, name, 7, why);
    }
    let ortho = write(
        d,
        "ortho.xml",
        &format!(
            r#"<scene version="3.0.0">
    {integrator}
    <sensor type="orthographic"/>
    <shape type="sphere"/>
</scene>"#
        ),
    );
    expect_err(&ortho, "ortho.xml", 2, "orthographic");
}

#[test]
fn samplers_integrators_and_default_film() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let with = |name: &str, sampler: &str, integrator: &str| {
        write(
            d,
            name,
            &format!(
                "<scene version=\"3.0.0\">\n{integrator}\n<sensor type=\"perspective\">\n{sampler}\n</sensor>\n</scene>"
            ),
        )
    };
    for (ty, n, spp) in [
        ("independent", 10, 10),
        ("stratified", 10, 16),
        ("multijitter", 10, 12),
        ("ldsampler", 10, 16),
        ("ldsampler", 64, 64),
        ("orthogonal", 10, 25),
        ("orthogonal", 4, 4),
    ] {
        let p = with(
            "s.xml",
            &format!(
                "<sampler type=\"{ty}\"><integer name=\"sample_count\" value=\"{n}\"/></sampler>"
            ),
            "",
        );
        let s = load(&p);
        assert_eq!(s.spp, spp, "{ty} {n}");
        assert_eq!(s.integrator.sampler.name(), ty);
        // No <film>: Mitsuba's default hdrfilm (768 × 576, gaussian).
        assert_eq!((s.camera.width, s.camera.height), (768, 576));
        assert_eq!(s.camera.filter, btfpt::math::filter::Filter::default());
    }
    let p = with(
        "i.xml",
        "",
        "<integrator type=\"direct\"><integer name=\"emitter_samples\" value=\"3\"/></integrator>",
    );
    let s = load(&p);
    let ds = s.integrator.direct.expect("direct");
    assert_eq!((ds.emitter_samples, ds.bsdf_samples), (3, 1));
    assert_eq!(s.integrator.sampler, SamplerType::Independent);
    let p = with(
        "i2.xml",
        "",
        "<integrator type=\"direct\"><integer name=\"shading_samples\" value=\"4\"/></integrator>",
    );
    let ds = load(&p).integrator.direct.expect("direct");
    assert_eq!((ds.emitter_samples, ds.bsdf_samples), (4, 4));
    for (name, integrator, sampler, line, needle) in [
        (
            "e1.xml",
            "<integrator type=\"bdpt\"/>",
            "",
            2,
            "unsupported integrator type",
        ),
        (
            "e2.xml",
            "<integrator type=\"photonmapper\"/>",
            "",
            2,
            "unsupported integrator type",
        ),
        (
            "e3.xml",
            "<integrator type=\"direct\"><integer name=\"shading_samples\" value=\"1\"/><integer name=\"bsdf_samples\" value=\"1\"/></integrator>",
            "",
            2,
            "cannot specify both",
        ),
        (
            "e4.xml",
            "<integrator type=\"direct\"><integer name=\"emitter_samples\" value=\"0\"/><integer name=\"bsdf_samples\" value=\"0\"/></integrator>",
            "",
            2,
            "at least 1",
        ),
        (
            "e5.xml",
            "",
            "<sampler type=\"sobol\"/>",
            4,
            "unsupported sampler type",
        ),
        (
            "e6.xml",
            "",
            "<sampler type=\"stratified\"><integer name=\"sample_count\" value=\"-3\"/></sampler>",
            4,
            "sample_count",
        ),
    ] {
        let p = with(name, sampler, integrator);
        expect_err(&p, name, line, needle);
    }
}

/// An area emitter's radiance given as a texture: a bitmap or a checkerboard is kept for its
/// mesh (whose constant radiance is then 1), a constant texture stays a constant radiance, a
/// `mesh_attribute` radiance is refused naming its line.
#[test]
fn area_emitter_radiance_textures() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut img = RgbImage::new(2, 1);
    img.set(0, 0, [1.0, 0.5, 0.0]);
    img.set(1, 0, [0.0, 0.5, 1.0]);
    write_png_srgb(&d.join("glow.png"), &img).unwrap();
    let s = load(&write(
        d,
        "a.xml",
        &scene_text(
            r#"<shape type="rectangle"><emitter type="area">
        <texture type="bitmap" name="radiance"><string name="filename" value="glow.png"/></texture>
    </emitter></shape>
    <shape type="sphere"><emitter type="area">
        <texture type="rawconstant" name="radiance"><rgb name="value" value="1, 2, 3"/></texture>
    </emitter></shape>
    <shape type="disk"><emitter type="area">
        <texture type="checkerboard" name="radiance"/>
    </emitter></shape>"#,
        ),
    ));
    let textured: Vec<u32> = s.emission_textures.iter().map(|(m, _)| *m).collect();
    assert_eq!(textured, [0, 2]);
    assert!(matches!(s.emission_textures[0].1, Texture::Bitmap(_)));
    assert!(matches!(s.emission_textures[1].1, Texture::Checkerboard(_)));
    assert_eq!(s.meshes[0].emitter, Some(Spectrum::ONE));
    assert_eq!(s.meshes[1].emitter, Some(Spectrum::new(1.0, 2.0, 3.0)));
    assert_eq!(s.meshes[2].emitter, Some(Spectrum::ONE));
    let p = write(
        d,
        "b.xml",
        &scene_text(
            r#"<shape type="rectangle"><emitter type="area">
        <texture type="mesh_attribute" name="radiance"><string name="name" value="vertex_color"/></texture>
    </emitter></shape>"#,
        ),
    );
    expect_err(&p, "b.xml", 8, "mesh_attribute");
}
