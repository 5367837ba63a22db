//! Mitsuba XML scenes written by the tests themselves, parsed into the expected `Scene`, plus the
//! error cases (each message must name the file and the line).

use crate::fixtures::{assert_names, load, load_err, write};
use btfpt::bsdf::{Bsdf, Bxdf, MicrofacetType, Texture};
use btfpt::io::{RgbImage, write_exr, write_png_srgb};
use btfpt::math::{Mat4, Vec2, Vec3};
use btfpt::render::camera::ProjectiveCamera;
use btfpt::scene::{self, Emitter, LoadOptions};
use std::path::{Path, PathBuf};

const SENSOR: &str = r#"
    <sensor type="perspective">
        <float name="fov" value="45"/>
        <film type="hdrfilm"><rfilter type="box"/></film>
    </sensor>"#;

fn scene_with(dir: &Path, body: &str) -> PathBuf {
    write(
        dir,
        "s.xml",
        &format!("<scene version=\"3.0.0\">\n{SENSOR}\n{body}\n</scene>\n"),
    )
}

/// Asserts that loading fails with a message naming the file, the line and containing `needle`.
fn expect_err(p: &Path, defines: &[(String, String)], line: u32, needle: &str) {
    let fname = p.file_name().unwrap().to_str().unwrap();
    assert_names(&load_err(p, defines), fname, line, &[needle]);
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-4
}

#[test]
fn full_scene_parses_into_expected_values() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // textures and meshes written by the test
    let mut tex = RgbImage::new(2, 1);
    tex.set(0, 0, [1.0, 0.0, 0.0]);
    tex.set(1, 0, [0.0, 0.0, 1.0]);
    write_png_srgb(&d.join("tex.png"), &tex).unwrap();
    let mut env = RgbImage::new(4, 2);
    env.set(3, 1, [2.0, 3.0, 4.0]);
    write_exr(&d.join("env.exr"), &env).unwrap();
    write(
        d,
        "tri.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 0.25\nf 1/1 2/2 3/3\n",
    );
    write(
        d,
        "tri.ply",
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
         element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
    );
    let xml = r#"<?xml version="1.0"?>
<scene version="3.0.0">
    <default name="spp" value="16"/>
    <default name="res" value="64"/>
    <default name="alpha" value="0.2"/>
    <integrator type="path">
        <integer name="max_depth" value="3"/>
        <boolean name="hide_emitters" value="true"/>
    </integrator>
    <sensor type="perspective">
        <float name="fov" value="30"/>
        <string name="fov_axis" value="y"/>
        <float name="near_clip" value="0.1"/>
        <transform name="to_world">
            <lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/>
        </transform>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="$res"/>
            <integer name="height" value="32"/>
            <integer name="crop_offset_x" value="8"/>
            <integer name="crop_width" value="16"/>
            <rfilter type="box"/>
        </film>
    </sensor>
    <bsdf type="diffuse" id="tex">
        <texture type="bitmap" name="reflectance"><string name="filename" value="tex.png"/></texture>
    </bsdf>
    <bsdf type="twosided" id="two"><ref id="tex"/></bsdf>
    <bsdf type="roughconductor" id="metal">
        <string name="distribution" value="ggx"/>
        <float name="alpha_u" value="$alpha"/>
        <float name="alpha_v" value="0.3"/>
        <rgb name="eta" value="0.2, 0.9, 1.1"/>
        <rgb name="k" value="3.9 2.4 2.2"/>
    </bsdf>
    <shape type="obj" id="o">
        <string name="filename" value="tri.obj"/>
        <transform name="to_world"><translate x="1"/><scale value="2"/></transform>
        <ref id="two"/>
    </shape>
    <shape type="ply">
        <string name="filename" value="tri.ply"/>
        <ref name="bsdf" id="metal"/>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><rotate x="1" angle="90"/></transform>
        <emitter type="area"><rgb name="radiance" value="1, 2, 3"/></emitter>
    </shape>
    <shape type="cube"><bsdf type="dielectric"><string name="int_ior" value="water"/></bsdf></shape>
    <shape type="sphere">
        <point name="center" x="0" y="1" z="0"/><float name="radius" value="0.5"/>
        <bsdf type="thindielectric"><float name="int_ior" value="1.6"/><float name="ext_ior" value="1.2"/></bsdf>
    </shape>
    <shape type="disk"><bsdf type="conductor"/></shape>
    <emitter type="point"><point name="position" value="1 2 3"/><rgb name="intensity" value="5"/></emitter>
    <emitter type="spot">
        <transform name="to_world"><translate value="0 4 0"/></transform>
        <float name="cutoff_angle" value="40"/>
    </emitter>
    <emitter type="directional"><vector name="direction" x="0" y="-2" z="0"/></emitter>
    <emitter type="constant"><float name="radiance" value="0.25"/></emitter>
    <emitter type="envmap"><string name="filename" value="env.exr"/><float name="scale" value="2"/></emitter>
</scene>
"#;
    let p = write(d, "full.xml", xml);
    let s = scene::load(
        &p,
        &LoadOptions::with_defines(&[("res".into(), "48".into())]),
    )
    .unwrap();
    assert_eq!(s.spp, 16);
    assert_eq!(s.integrator.max_depth, 3);
    assert_eq!(s.integrator.rr_depth, 5);
    assert!(s.integrator.hide_emitters);
    let c = &s.camera;
    assert_eq!(
        (c.width, c.height),
        (48, 32),
        "define must override the default"
    );
    assert_eq!(c.crop, Some([8, 0, 16, 32]));
    assert_eq!(c.image_size(), (16, 32));
    // fov 30° along y with aspect 1.5 → horizontal fov
    let expect = 2.0 * ((15f32).to_radians().tan() * 1.5).atan();
    assert!((c.fov_x_deg.to_radians() - expect).abs() < 1e-5);
    assert!((c.near_clip - 0.1).abs() < 1e-7 && c.far_clip == 1e4);
    assert!(close(
        c.to_world.transform_point3(Vec3::ZERO),
        Vec3::new(0.0, 0.0, 5.0)
    ));

    // bsdfs: tex, two, metal (top level, in order), then the nested ones
    assert_eq!(s.meshes.len(), 6);
    let b = |i: usize| &s.bsdfs[s.meshes[i].bsdf as usize];
    match b(0) {
        Bsdf::TwoSided(t) => match (&*t.front, &*t.back) {
            (Bsdf::Diffuse(f), Bsdf::Diffuse(_)) => match &f.reflectance {
                Texture::Bitmap(img) => {
                    assert_eq!((img.width, img.height), (2, 1));
                    assert!((img.get(0, 0)[0] - 1.0).abs() < 1e-6);
                }
                t => panic!("{t:?}"),
            },
            o => panic!("{o:?}"),
        },
        o => panic!("{o:?}"),
    }
    match b(1) {
        Bsdf::RoughConductor(r) => {
            assert_eq!(r.distribution, MicrofacetType::Ggx);
            assert!(matches!(r.alpha_u, Texture::Constant(c) if c == Vec3::splat(0.2)));
            assert!(matches!(r.alpha_v, Texture::Constant(c) if c == Vec3::splat(0.3)));
            let uv = Vec2::ZERO;
            assert!(
                close(r.eta.eval(uv), Vec3::new(0.2, 0.9, 1.1))
                    && close(r.k.eval(uv), Vec3::new(3.9, 2.4, 2.2))
            );
            assert!(r.sample_visible);
        }
        o => panic!("{o:?}"),
    }
    match b(3) {
        Bsdf::Dielectric(x) => assert!((x.eta - 1.3330 / 1.00028).abs() < 1e-6),
        o => panic!("{o:?}"),
    }
    match b(4) {
        Bsdf::ThinDielectric(x) => assert!((x.eta - 1.6 / 1.2).abs() < 1e-6),
        o => panic!("{o:?}"),
    }
    match b(5) {
        Bsdf::Conductor(x) => {
            assert!(matches!(x.eta, Texture::Constant(v) if v == Vec3::ZERO));
            assert!(matches!(x.k, Texture::Constant(v) if v == Vec3::ONE));
            assert!(matches!(x.specular_reflectance, Texture::Constant(v) if v == Vec3::ONE));
        }
        o => panic!("{o:?}"),
    }
    // the rectangle (no bsdf, an area emitter) gets Mitsuba's default for emitters: black diffuse
    match b(2) {
        Bsdf::Diffuse(x) => {
            assert!(matches!(x.reflectance, Texture::Constant(v) if v == Vec3::ZERO))
        }
        o => panic!("{o:?}"),
    }
    assert_eq!(
        s.meshes[0].bsdf, 1,
        "ref to a top-level bsdf reuses its index"
    );

    // OBJ: to_world = scale · translate (document order: translate first), v flipped, smooth
    // normals recomputed
    let o = &s.meshes[0];
    assert_eq!(o.name, "o");
    let i = o
        .positions
        .iter()
        .position(|p| close(*p, Vec3::new(2.0, 2.0, 0.0)))
        .unwrap();
    assert_eq!(o.uvs[i], Vec2::new(0.0, 0.75));
    assert!(o.normals.iter().all(|n| close(*n, Vec3::Z)));
    // rectangle rotated +90° about x: normal +z → −y... R_x(90°)·z = (0, −1, 0)
    let r = &s.meshes[2];
    assert_eq!(r.emitter, Some(Vec3::new(1.0, 2.0, 3.0)));
    assert!(
        r.normals
            .iter()
            .all(|n| close(*n, Vec3::new(0.0, -1.0, 0.0)))
    );
    // sphere centre/radius
    let sp = s.meshes[4].sphere.expect("analytic sphere");
    assert!((sp.center - Vec3::Y).length() < 1e-6 && (sp.radius - 0.5).abs() < 1e-6);
    assert!(s.meshes[4].indices.is_empty() && !sp.flip_normals);

    assert_eq!(s.emitters.len(), 5);
    assert!(
        matches!(s.emitters[0], Emitter::Point { position, intensity }
        if position == Vec3::new(1.0, 2.0, 3.0) && intensity == Vec3::splat(5.0))
    );
    match &s.emitters[1] {
        Emitter::Spot {
            to_world,
            cutoff_angle,
            beam_width,
            intensity,
            ..
        } => {
            assert_eq!((*cutoff_angle, *beam_width), (40.0, 30.0));
            assert_eq!(*intensity, Vec3::ONE);
            assert_eq!(*to_world, Mat4::from_translation(Vec3::new(0.0, 4.0, 0.0)));
        }
        e => panic!("{e:?}"),
    }
    assert!(
        matches!(s.emitters[2], Emitter::Directional { direction, irradiance }
        if close(direction, -Vec3::Y) && irradiance == Vec3::ONE)
    );
    assert!(
        matches!(s.emitters[3], Emitter::Constant { radiance } if radiance == Vec3::splat(0.25))
    );
    match &s.emitters[4] {
        Emitter::EnvMap { image, scale, .. } => {
            assert_eq!(*scale, 2.0);
            assert_eq!(image.get(3, 1), [2.0, 3.0, 4.0]);
        }
        e => panic!("{e:?}"),
    }
}

#[test]
fn defaults_without_integrator_and_sampler() {
    let dir = tempfile::tempdir().unwrap();
    let s = load(&scene_with(dir.path(), "<shape type=\"rectangle\"/>"));
    assert_eq!(s.integrator, Default::default());
    assert_eq!(s.spp, 4);
    assert_eq!((s.camera.width, s.camera.height), (768, 576));
    assert_eq!(s.camera.crop, None);
    assert_eq!(s.camera.to_world, Mat4::IDENTITY);
}

#[test]
fn transforms_compose_in_document_order() {
    let dir = tempfile::tempdir().unwrap();
    let body = r#"<shape type="rectangle">
        <transform name="to_world">
            <scale x="2"/>
            <rotate value="0 0 1" angle="90"/>
            <translate value="0, 0, 3"/>
            <matrix value="1 0 0 0  0 1 0 5  0 0 1 0  0 0 0 1"/>
        </transform></shape>"#;
    let s = load(&scene_with(dir.path(), body));
    // local (1, 1, 0) → scale (2, 1, 0) → rot z 90° (−1, 2, 0) → +z 3 → +y 5
    let m = &s.meshes[0];
    assert!(
        m.positions
            .iter()
            .any(|p| close(*p, Vec3::new(-1.0, 7.0, 3.0))),
        "{:?}",
        m.positions
    );
}

#[test]
fn fov_axes_resolve_to_horizontal_fov() {
    let dir = tempfile::tempdir().unwrap();
    let fov = |axis: &str, w: u32, h: u32| {
        let xml = format!(
            r#"<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/>
            <string name="fov_axis" value="{axis}"/>
            <film type="hdrfilm"><integer name="width" value="{w}"/><integer name="height" value="{h}"/>
            <rfilter type="box"/></film></sensor></scene>"#
        );
        load(&write(dir.path(), "f.xml", &xml)).camera.fov_x_deg as f64
    };
    let t = (20f64).to_radians().tan();
    let y = |a: f64| (2.0 * (t * a).atan()).to_degrees();
    assert!((fov("x", 200, 100) - 40.0).abs() < 1e-4);
    assert!((fov("y", 200, 100) - y(2.0)).abs() < 1e-4);
    assert!((fov("smaller", 200, 100) - y(2.0)).abs() < 1e-4);
    assert!((fov("larger", 200, 100) - 40.0).abs() < 1e-4);
    assert!((fov("smaller", 100, 200) - 40.0).abs() < 1e-4);
    let diag = {
        let a = 2.0f64;
        let w = 2.0 * t / (1.0 + 1.0 / (a * a)).sqrt();
        (2.0 * (w / 2.0).atan()).to_degrees()
    };
    assert!((fov("diagonal", 200, 100) - diag).abs() < 1e-4);
}

#[test]
fn camera_rays_follow_mitsuba_orientation() {
    let dir = tempfile::tempdir().unwrap();
    let xml = r#"<scene version="3.0.0"><sensor type="perspective">
        <float name="fov" value="90"/>
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="100"/><integer name="height" value="50"/>
        <rfilter type="box"/></film></sensor></scene>"#;
    // The renderer's camera, built from what the loader produced.
    let c = ProjectiveCamera::new(&load(&write(dir.path(), "c.xml", xml)).camera).unwrap();
    let (o, d, _) = c.ray(50.0, 25.0);
    // The ray starts on the near plane (Mitsuba's default near_clip = 0.01) in front of the origin.
    assert!(
        close(o, Vec3::new(0.0, 0.0, 4.99)) && close(d, -Vec3::Z),
        "{o:?} {d:?}"
    );
    // The left edge of the image sees world −x (the viewer's left when looking down −z with +y up).
    let (_, d, _) = c.ray(0.0, 25.0);
    assert!(close(d, Vec3::new(-1.0, 0.0, -1.0).normalize()), "{d:?}");
    // The top edge sees +y; vertical extent is tan(45°)/aspect.
    let (_, d, _) = c.ray(50.0, 0.0);
    assert!(close(d, Vec3::new(0.0, 0.5, -1.0).normalize()), "{d:?}");
}

#[test]
fn flip_normals_and_face_normals() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "t.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 1\nvn 0 0 1\nf 1//1 2//2 3//3\n",
    );
    let body = r#"<shape type="obj"><string name="filename" value="t.obj"/><boolean name="flip_normals" value="true"/></shape>
        <shape type="obj"><string name="filename" value="t.obj"/><boolean name="face_normals" value="true"/></shape>
        <shape type="sphere"><boolean name="flip_normals" value="true"/></shape>"#;
    let s = load(&scene_with(dir.path(), body));
    let m = &s.meshes[0];
    assert!(m.normals.iter().all(|n| close(*n, -Vec3::Z)));
    let [a, b, c] = m.indices[0].map(|i| m.positions[i as usize]);
    assert!((b - a).cross(c - a).z < 0.0, "winding must be reversed");
    assert!(s.meshes[1].normals.is_empty());
    assert!(s.meshes[2].sphere.expect("analytic sphere").flip_normals);
}

#[test]
fn btf_bsdf_routes_to_build_btf() {
    let dir = tempfile::tempdir().unwrap();
    let body = r#"<shape type="rectangle">
        <bsdf type="btf"><string name="filename" value="m.plmc"/><float name="uv_scale" value="4"/></bsdf>
    </shape>"#;
    // Without a model the file's own representation is read: missing here, so the error names it
    // and the line.
    expect_err(&scene_with(dir.path(), body), &[], 8, "m.plmc");
    // LoadOptions::btf_model reaches the BTF builder and replaces the model property.
    let options = LoadOptions {
        btf_model: Some(btfpt::model::BtfModel::Raw),
        ..LoadOptions::default()
    };
    let e = scene::load(&scene_with(dir.path(), body), &options)
        .unwrap_err()
        .to_string();
    // Raw data of m.plmc are looked for beside it (m, m.btfc, m.btf).
    assert!(e.contains(":8:") && e.contains("m.btfc"), "{e}");
}

#[test]
fn malformed_xml_names_line() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "bad.xml",
        "<scene version=\"3.0.0\">\n<shape type=\"cube\">\n</scene>\n",
    );
    expect_err(&p, &[], 3, "malformed XML");
}

#[test]
fn missing_mesh_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = scene_with(
        dir.path(),
        "<shape type=\"obj\">\n<string name=\"filename\" value=\"nope.obj\"/></shape>",
    );
    expect_err(&p, &[], 7, "nope.obj");
}

#[test]
fn unknown_plugin_property_and_element() {
    let dir = tempfile::tempdir().unwrap();
    let p = scene_with(
        dir.path(),
        "<shape type=\"cube\"><bsdf type=\"hair\"/></shape>",
    );
    expect_err(&p, &[], 7, "unsupported bsdf type");
    let p = scene_with(
        dir.path(),
        "<shape type=\"cube\">\n<float name=\"radius\" value=\"1\"/></shape>",
    );
    expect_err(&p, &[], 8, "unreferenced property \"radius\"");
    let p = scene_with(dir.path(), "<shape type=\"torus\"/>");
    expect_err(&p, &[], 7, "unsupported shape type");
    let p = scene_with(
        dir.path(),
        "<shape type=\"cube\"><colour name=\"x\" value=\"1\"/></shape>",
    );
    expect_err(&p, &[], 7, "unexpected element <colour>");
    let p = scene_with(dir.path(), "<integrator type=\"bdpt\"/>");
    expect_err(&p, &[], 7, "unsupported integrator type");
    let p = scene_with(dir.path(), "<emitter type=\"area\"/>");
    expect_err(&p, &[], 7, "must be nested inside a <shape>");
    let p = scene_with(
        dir.path(),
        "<bsdf type=\"roughconductor\"><string name=\"distribution\" value=\"phong\"/></bsdf>",
    );
    expect_err(&p, &[], 7, "must be \"beckmann\" or \"ggx\"");
    let p = scene_with(
        dir.path(),
        "<bsdf type=\"conductor\"><string name=\"material\" value=\"Xx\"/></bsdf>",
    );
    expect_err(&p, &[], 7, "unknown conductor material");
    let p = scene_with(
        dir.path(),
        "<shape type=\"sphere\"><transform name=\"to_world\"><scale x=\"2\"/></transform></shape>",
    );
    expect_err(&p, &[], 7, "non-uniform scale");
    let p = scene_with(dir.path(), "<shape type=\"cube\" colour=\"red\"/>");
    expect_err(&p, &[], 7, "unexpected attribute \"colour\"");
    let p = scene_with(dir.path(), "<shape><bsdf type=\"diffuse\"/></shape>");
    expect_err(&p, &[], 7, "missing attribute \"type\"");
    let p = scene_with(
        dir.path(),
        "<shape type=\"cube\"><float name=\"fov\" value=\"$x\"/></shape>",
    );
    expect_err(
        &p,
        &[("x".into(), "1".into())],
        7,
        "unreferenced property \"fov\"",
    );
    let p = write(
        dir.path(),
        "lum.xml",
        "<scene version=\"3.0.0\">\n<sensor type=\"perspective\">\n<film type=\"hdrfilm\"><string name=\"pixel_format\" value=\"luminance\"/><rfilter type=\"box\"/></film></sensor></scene>",
    );
    expect_err(&p, &[], 3, "pixel_format");
}

#[test]
fn nan_transform_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let p = scene_with(
        dir.path(),
        "<shape type=\"cube\"><transform name=\"to_world\">\n<translate x=\"nan\"/></transform></shape>",
    );
    expect_err(&p, &[], 8, "non-finite");
    let p = scene_with(
        dir.path(),
        "<shape type=\"cube\"><transform name=\"to_world\">\n<lookat origin=\"1,1,1\" target=\"1,1,1\"/></transform></shape>",
    );
    expect_err(&p, &[], 8, "invalid lookat");
    let p = scene_with(
        dir.path(),
        "<shape type=\"cube\"><transform name=\"to_world\">\n<scale y=\"0\"/></transform></shape>",
    );
    expect_err(&p, &[], 7, "singular");
}

#[test]
fn rfilters_and_missing_film() {
    use btfpt::math::filter::Filter;
    let dir = tempfile::tempdir().unwrap();
    let film = |name: &str, inner: &str| {
        write(
            dir.path(),
            name,
            &format!(
                "<scene version=\"3.0.0\">\n<sensor type=\"perspective\">\n<film type=\"hdrfilm\">\n{inner}</film>\n</sensor>\n</scene>"
            ),
        )
    };
    // No <rfilter>: Mitsuba's default gaussian; each type with its parameters.
    assert_eq!(
        load(&film("nofilter.xml", "")).camera.filter,
        Filter::default()
    );
    for (inner, want) in [
        ("<rfilter type=\"box\"/>", Filter::BOX),
        ("<rfilter type=\"tent\"/>", Filter::tent(1.0).unwrap()),
        (
            "<rfilter type=\"gaussian\"><float name=\"stddev\" value=\"0.3\"/></rfilter>",
            Filter::gaussian(0.3).unwrap(),
        ),
        (
            "<rfilter type=\"mitchell\"/>",
            Filter::mitchell(1.0 / 3.0, 1.0 / 3.0, 2.0).unwrap(),
        ),
        (
            "<rfilter type=\"catmullrom\"/>",
            Filter::mitchell(0.0, 0.5, 2.0).unwrap(),
        ),
        (
            "<rfilter type=\"lanczos\"><integer name=\"lobes\" value=\"2\"/></rfilter>",
            Filter::lanczos(2).unwrap(),
        ),
    ] {
        assert_eq!(load(&film("f.xml", inner)).camera.filter, want, "{inner}");
    }
    let p = film("bad.xml", "<rfilter type=\"sinc\"/>");
    expect_err(&p, &[], 4, "unsupported reconstruction filter");
    let p = film(
        "neg.xml",
        "<rfilter type=\"gaussian\"><float name=\"stddev\" value=\"-1\"/></rfilter>",
    );
    expect_err(&p, &[], 4, "radius");
    // No <film>: Mitsuba's default hdrfilm (768 × 576, gaussian filter).
    let p = write(
        dir.path(),
        "nofilm.xml",
        "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/><shape type=\"cube\"/>\n</scene>",
    );
    let s = load(&p);
    assert_eq!((s.camera.width, s.camera.height), (768, 576));
    assert_eq!(s.camera.filter, btfpt::math::filter::Filter::default());
}

#[test]
fn ids_refs_and_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let p = scene_with(
        dir.path(),
        "<bsdf type=\"diffuse\" id=\"a\"/>\n<bsdf type=\"diffuse\" id=\"a\"/>",
    );
    expect_err(&p, &[], 8, "duplicate id \"a\" (previous was at ");
    expect_err(&p, &[], 8, "s.xml line 7)");
    let p = scene_with(
        dir.path(),
        "<shape type=\"cube\"><ref id=\"missing\"/></shape>",
    );
    expect_err(&p, &[], 7, "unknown object \"missing\"");
    let p = scene_with(
        dir.path(),
        "<shape type=\"cube\"><float name=\"x\" value=\"$nope\"/></shape>",
    );
    expect_err(
        &p,
        &[("other".into(), "1".into())],
        7,
        "undefined parameter",
    );
    let p = scene_with(dir.path(), "<shape type=\"cube\"/>");
    let e = scene::load(
        &p,
        &LoadOptions::with_defines(&[("unused".into(), "1".into())]),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("s.xml") && e.contains("unused parameter \"unused\""),
        "{e}"
    );
    // a default declared after its use is not yet defined at the use (Mitsuba order)
    let p = scene_with(
        dir.path(),
        "<default name=\"r\" value=\"1\"/><shape type=\"sphere\"><float name=\"radius\" value=\"$r\"/></shape>",
    );
    assert!(scene::load(&p, &LoadOptions::default()).is_ok());
    let p = scene_with(
        dir.path(),
        "<bsdf type=\"twosided\" id=\"t\"><ref id=\"t2\"/></bsdf><bsdf type=\"twosided\" id=\"t2\"><ref id=\"t\"/></bsdf>",
    );
    assert!(scene::load(&p, &LoadOptions::default()).is_err());
}

#[test]
fn missing_version_and_sensor() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "nv.xml", "<scene>\n</scene>");
    expect_err(&p, &[], 1, "missing version attribute");
    let p = write(
        dir.path(),
        "ns.xml",
        "<scene version=\"3.0.0\">\n<shape type=\"cube\"/>\n</scene>",
    );
    expect_err(&p, &[], 1, "no <sensor>");
}

#[test]
fn binary_ply_with_uvs_and_degenerate_faces() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
property float z\nproperty float u\nproperty float v\nelement face 2\nproperty list uchar uint vertex_indices\nend_header\n"
        .to_vec();
    for (x, y) in [(0.0f32, 0.0f32), (1.0, 0.0), (0.0, 1.0), (2.0, 0.0)] {
        for v in [x, y, 0.0, x, y] {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    for face in [[0u32, 1, 2], [0, 1, 3]] {
        b.push(3);
        for i in face {
            b.extend_from_slice(&i.to_le_bytes());
        }
    }
    std::fs::write(dir.path().join("m.ply"), b).unwrap();
    let s = load(&scene_with(
        dir.path(),
        "<shape type=\"ply\"><string name=\"filename\" value=\"m.ply\"/></shape>",
    ));
    let m = &s.meshes[0];
    assert_eq!(m.indices, vec![[0, 1, 2]], "collinear face dropped");
    assert_eq!(
        m.uvs[2],
        Vec2::new(0.0, 1.0),
        "PLY uvs are not flipped by default"
    );
    assert_eq!(m.normals.len(), 4);
}

/// Mitsuba 3.9.1's roughconductor takes alpha/alpha_u/alpha_v and its conductors eta/k as
/// (unbounded) textures: a checkerboard roughness, a bitmap IOR, a float k.
#[test]
fn conductor_roughness_and_ior_textures_parse() {
    let dir = tempfile::tempdir().unwrap();
    let mut img = RgbImage::new(2, 1);
    img.set(0, 0, [0.2, 1.5, 2.5]);
    img.set(1, 0, [0.4, 0.9, 1.1]);
    write_exr(&dir.path().join("eta.exr"), &img).unwrap();
    let p = scene_with(
        dir.path(),
        r#"<bsdf type="roughconductor" id="a"><texture type="checkerboard" name="alpha"><float name="color0" value="0.05"/><float name="color1" value="0.4"/></texture><texture type="bitmap" name="eta"><string name="filename" value="eta.exr"/></texture><float name="k" value="2"/></bsdf>
<bsdf type="roughconductor" id="b"><float name="alpha_u" value="0.2"/><texture type="checkerboard" name="alpha_v"/></bsdf>
<bsdf type="conductor" id="c"><texture type="bitmap" name="k"><string name="filename" value="eta.exr"/></texture></bsdf>
<shape type="cube"><ref id="a"/></shape>
<shape type="cube"><ref id="b"/></shape>
<shape type="cube"><ref id="c"/></shape>"#,
    );
    let s = load(&p);
    let b = |i: usize| &s.bsdfs[s.meshes[i].bsdf as usize];
    match b(0) {
        Bsdf::RoughConductor(r) => {
            // eval_1 of a checkerboard: color0 where the halves of uv differ (Mitsuba 3.9.1).
            assert_eq!(r.alpha_u.eval_1(Vec2::new(0.3, 0.6)), 0.05);
            assert_eq!(r.alpha_v.eval_1(Vec2::new(0.3, 0.3)), 0.4);
            assert_eq!(r.eta.eval(Vec2::new(0.25, 0.5)), Vec3::new(0.2, 1.5, 2.5));
            assert!(matches!(r.k, Texture::Constant(c) if c == Vec3::splat(2.0)));
            assert!(r.flags().has(btfpt::bsdf::BsdfFlags::SPATIALLY_VARYING));
        }
        o => panic!("{o:?}"),
    }
    match b(1) {
        Bsdf::RoughConductor(r) => {
            assert!(matches!(r.alpha_u, Texture::Constant(c) if c == Vec3::splat(0.2)));
            assert!(matches!(r.alpha_v, Texture::Checkerboard(_)));
        }
        o => panic!("{o:?}"),
    }
    match b(2) {
        Bsdf::Conductor(c) => {
            assert!(matches!(c.k, Texture::Bitmap(_) | Texture::Mapped(_)));
            assert!(matches!(c.eta, Texture::Constant(v) if v == Vec3::ZERO));
        }
        o => panic!("{o:?}"),
    }
}

#[test]
fn plastic_rough_blend_and_mask_bsdfs_parse() {
    let dir = tempfile::tempdir().unwrap();
    let p = scene_with(
        dir.path(),
        r#"<bsdf type="plastic" id="p"><rgb name="diffuse_reflectance" value="0.1 0.2 0.3"/></bsdf>
<bsdf type="roughplastic" id="rp"><string name="distribution" value="ggx"/><float name="alpha" value="0.2"/><boolean name="nonlinear" value="true"/></bsdf>
<bsdf type="roughdielectric" id="rd"><string name="distribution" value="GGX"/><float name="alpha_u" value="0.3"/><float name="alpha_v" value="0.1"/><string name="int_ior" value="water"/></bsdf>
<bsdf type="blendbsdf" id="b"><float name="weight" value="0.25"/><ref id="p"/><bsdf type="diffuse"/></bsdf>
<bsdf type="mixturebsdf" id="m"><string name="weights" value="0.6, 0.9"/><ref id="rp"/><bsdf type="diffuse"/></bsdf>
<bsdf type="mask" id="k"><float name="opacity" value="0.4"/><ref id="rd"/></bsdf>
<bsdf type="normalmap" id="nm"><rgb name="normalmap" value="0.6, 0.5, 0.9"/><boolean name="use_shadowing_function" value="false"/><ref id="p"/></bsdf>
<shape type="cube"><ref id="p"/></shape>
<shape type="cube"><ref id="rp"/></shape>
<shape type="cube"><ref id="rd"/></shape>
<shape type="cube"><ref id="b"/></shape>
<shape type="cube"><ref id="m"/></shape>
<shape type="cube"><ref id="k"/></shape>
<shape type="cube"><ref id="nm"/></shape>"#,
    );
    let s = load(&p);
    let b = |i: usize| &s.bsdfs[s.meshes[i].bsdf as usize];
    match b(0) {
        Bsdf::Plastic(p) => assert!((p.eta() - 1.49 / 1.00028).abs() < 1e-6),
        other => panic!("{other:?}"),
    }
    match b(1) {
        Bsdf::RoughPlastic(p) => assert!(p.nonlinear && p.internal_reflectance() > 0.3),
        other => panic!("{other:?}"),
    }
    match b(2) {
        Bsdf::RoughDielectric(d) => {
            assert!((d.eta - 1.333 / 1.00028).abs() < 1e-6);
            assert!(matches!(d.alpha_u, Texture::Constant(c) if c.x == 0.3));
        }
        other => panic!("{other:?}"),
    }
    match b(3) {
        Bsdf::Blend(bl) => {
            assert!(matches!(bl.weight, Texture::Constant(c) if c.x == 0.25));
            assert!(matches!(bl.bsdfs[0], Bsdf::Plastic(_)));
            assert!(matches!(bl.bsdfs[1], Bsdf::Diffuse(_)));
        }
        other => panic!("{other:?}"),
    }
    match b(4) {
        // Mitsuba 0.6 renormalises weights summing to more than 1.
        Bsdf::Blend(bl) => {
            assert!(matches!(bl.weight, Texture::Constant(c) if (c.x - 0.9 / 1.5).abs() < 1e-6))
        }
        other => panic!("{other:?}"),
    }
    match b(5) {
        Bsdf::Mask(m) => assert!(matches!(*m.nested, Bsdf::RoughDielectric(_))),
        other => panic!("{other:?}"),
    }
    match b(6) {
        Bsdf::NormalMap(n) => {
            assert!(!n.use_shadowing_function && n.flip_invalid_normals);
            assert!(matches!(*n.nested, Bsdf::Plastic(_)));
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn bad_bsdf_parameters_name_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let cases: &[(&str, &str)] = &[
        (
            r#"<bsdf type="roughplastic"><string name="distribution" value="blinn"/></bsdf>"#,
            "invalid distribution \"blinn\"",
        ),
        (
            r#"<bsdf type="bumpmap"><bsdf type="diffuse"/></bsdf>"#,
            "height texture",
        ),
        (
            r#"<bsdf type="bumpmap"><texture type="checkerboard"/><bsdf type="diffuse"/></bsdf>"#,
            "must be a bitmap",
        ),
        (
            r#"<bsdf type="bumpmap"><float name="scale" value="inf"/><texture type="bitmap"><string name="filename" value="h.png"/></texture><bsdf type="diffuse"/></bsdf>"#,
            "non-finite value \"inf\"",
        ),
        (
            r#"<bsdf type="roughplastic"><string name="distribution" value="ggx"/><float name="alpha" value="-0.1"/></bsdf>"#,
            "non-negative roughness",
        ),
        (
            r#"<bsdf type="roughplastic"><string name="distribution" value="ggx"/><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.2"/></bsdf>"#,
            "anisotropic",
        ),
        (
            r#"<bsdf type="roughdielectric"><string name="distribution" value="ggx"/><float name="alpha" value="nan"/></bsdf>"#,
            "non-finite",
        ),
        (
            r#"<bsdf type="roughdielectric"><string name="distribution" value="ggx"/><float name="alpha_u" value="0.1"/></bsdf>"#,
            "both \"alpha_u\" and \"alpha_v\"",
        ),
        (
            r#"<bsdf type="roughconductor"><texture type="checkerboard" name="alpha_u"/></bsdf>"#,
            "both \"alpha_u\" and \"alpha_v\"",
        ),
        (
            r#"<bsdf type="roughconductor"><float name="alpha" value="0.1"/><texture type="checkerboard" name="alpha_u"/><float name="alpha_v" value="0.1"/></bsdf>"#,
            "either \"alpha\" or",
        ),
        (
            r#"<bsdf type="roughconductor"><rgb name="alpha" value="0.1, -0.2, 0.3"/></bsdf>"#,
            "non-negative roughness",
        ),
        (
            r#"<bsdf type="roughconductor"><bsdf type="diffuse" name="alpha"/></bsdf>"#,
            "must be a <texture> or a colour",
        ),
        (
            r#"<bsdf type="conductor"><string name="material" value="Au"/><texture type="checkerboard" name="eta"/></bsdf>"#,
            "either (eta, k) or material",
        ),
        (
            r#"<bsdf type="roughdielectric"><string name="distribution" value="ggx"/><float name="int_ior" value="1"/><float name="ext_ior" value="1"/></bsdf>"#,
            "must be positive and differ",
        ),
        (
            r#"<bsdf type="plastic"><float name="int_ior" value="-1.5"/></bsdf>"#,
            "must be positive",
        ),
        (
            r#"<bsdf type="blendbsdf"><float name="weight" value="1.5"/><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>"#,
            "must lie in [0, 1]",
        ),
        (
            r#"<bsdf type="blendbsdf"><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>"#,
            "\"weight\"",
        ),
        (
            r#"<bsdf type="blendbsdf"><float name="weight" value="0.5"/><bsdf type="diffuse"/></bsdf>"#,
            "exactly two nested bsdfs, found 1",
        ),
        (
            r#"<bsdf type="mixturebsdf"><string name="weights" value="0.2, 0.3, 0.5"/><bsdf type="diffuse"/><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>"#,
            "more than two",
        ),
        (
            r#"<bsdf type="mixturebsdf"><string name="weights" value="0.2, 0.3"/><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>"#,
            "sum to 0.5",
        ),
        (
            r#"<bsdf type="mixturebsdf"><string name="weights" value="0.2, x"/><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>"#,
            "non-negative numbers",
        ),
        (r#"<bsdf type="mask"/>"#, "needs a nested bsdf"),
        (
            r#"<bsdf type="normalmap"><bsdf type="diffuse"/></bsdf>"#,
            "\"normalmap\" texture is required",
        ),
        (
            r#"<bsdf type="normalmap"><rgb name="normalmap" value="0.5, 0.5, 1"/></bsdf>"#,
            "needs a nested bsdf",
        ),
        (
            r#"<bsdf type="mask"><float name="opacity" value="-0.2"/><bsdf type="diffuse"/></bsdf>"#,
            "\"opacity\" must lie in [0, 1]",
        ),
    ];
    // The bump map's height image (errors after it is read must still name the bsdf's line).
    write_png_srgb(&dir.path().join("h.png"), &RgbImage::new(2, 2)).unwrap();
    for (body, needle) in cases {
        let p = scene_with(dir.path(), body);
        expect_err(&p, &[], 7, needle);
    }
}

#[test]
fn shapes_without_a_bsdf_get_mitsubas_default_black_on_emitters() {
    // Mitsuba 3 gives a shape without <bsdf> a diffuse 0.5, but reflectance 0 if it carries an
    // area emitter (src/render/shape.cpp): the light reflects nothing.
    let dir = tempfile::tempdir().unwrap();
    let p = scene_with(
        dir.path(),
        "<shape type=\"rectangle\"/>\n\
         <shape type=\"rectangle\"><emitter type=\"area\"><rgb name=\"radiance\" value=\"1\"/></emitter></shape>\n\
         <shape type=\"sphere\"/>",
    );
    let s = load(&p);
    let reflectance = |i: usize| match &s.bsdfs[s.meshes[i].bsdf as usize] {
        Bsdf::Diffuse(d) => match d.reflectance {
            Texture::Constant(c) => c,
            ref t => panic!("{t:?}"),
        },
        o => panic!("{o:?}"),
    };
    assert_eq!(reflectance(0), Vec3::splat(0.5));
    assert_eq!(reflectance(1), Vec3::ZERO);
    assert_eq!(reflectance(2), Vec3::splat(0.5));
    assert_eq!(
        s.meshes[0].bsdf, s.meshes[2].bsdf,
        "the default is built once"
    );
}

#[test]
fn unknown_plugins_are_named_with_what_btfpt_implements() {
    let dir = tempfile::tempdir().unwrap();
    for (body, needle) in [
        (
            "<texture type=\"noise\" id=\"t\"/>",
            "unsupported texture type (btfpt implements bitmap, checkerboard, rawconstant, mesh_attribute)",
        ),
        (
            "<shape type=\"torus\"/>",
            "unsupported shape type (btfpt implements shapegroup, instance, obj, ply, serialized, \
             rectangle, cube, sphere, disk, cylinder)",
        ),
        (
            "<emitter type=\"sunsky\"/>",
            "unsupported emitter type (btfpt implements area, point, spot, projector, directional, \
             constant, envmap)",
        ),
    ] {
        expect_err(&scene_with(dir.path(), body), &[], 7, needle);
    }
    for (name, sensor, needle) in [
        (
            "sensor.xml",
            "<sensor type=\"irradiancemeter\"/>",
            "unsupported sensor type (btfpt implements perspective, thinlens, orthographic)",
        ),
        (
            "film.xml",
            "<sensor type=\"perspective\">\n<film type=\"specfilm\"/></sensor>",
            "unsupported film type (btfpt implements hdrfilm)",
        ),
    ] {
        let p = write(
            dir.path(),
            name,
            &format!("<scene version=\"3.0.0\">\n{sensor}\n</scene>\n"),
        );
        let line = if name == "film.xml" { 3 } else { 2 };
        expect_err(&p, &[], line, needle);
    }
}
