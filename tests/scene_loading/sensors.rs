//! Mitsuba's projective sensors (`perspective`, `thinlens`, `orthographic`): the rays the loader
//! and the renderer's camera make, against Mitsuba 3.9.1's own `sample_ray`
//! (reference-images/sensor_golden.py), and the sensor parameters that are errors.

use crate::fixtures::{assert_names, load, load_err, write};
use btfpt::math::{Vec2, Vec3};
use btfpt::render::camera::ProjectiveCamera;
use btfpt::scene::Projection;

const GOLDEN: &str = include_str!("../../reference-images/sensor_golden.txt");

fn scene_xml(sensor: &str) -> String {
    format!("<scene version=\"3.0.0\">\n{sensor}\n</scene>\n")
}

/// Largest errors of one golden case: origin (relative to 1 + |o|), direction, max distance
/// (relative).
#[derive(Default, Debug)]
struct Errors {
    origin: f32,
    direction: f32,
    maxt: f32,
}

#[test]
fn rays_match_mitsuba_sample_ray() {
    let dir = tempfile::tempdir().unwrap();
    let mut cases = 0;
    let mut worst = Errors::default();
    let mut camera: Option<ProjectiveCamera> = None;
    for line in GOLDEN.lines() {
        if let Some(xml) = line.strip_prefix("sensor ") {
            let path = write(dir.path(), "s.xml", &scene_xml(xml));
            let s = load(&path);
            camera = Some(ProjectiveCamera::new(&s.camera).unwrap());
            cases += 1;
            continue;
        }
        let v: Vec<f32> = line.split(' ').map(|t| t.parse().unwrap()).collect();
        let c = camera.as_ref().unwrap();
        let (fx, fy) = (v[0] * c.width as f32, v[1] * c.height as f32);
        let (o, d, t) = c.sample_ray(fx, fy, Vec2::new(v[2], v[3]));
        let (mo, md, mt) = (
            Vec3::new(v[4], v[5], v[6]),
            Vec3::new(v[7], v[8], v[9]),
            v[10],
        );
        let e = Errors {
            origin: (o - mo).length() / (1.0 + mo.length()),
            direction: (d - md).length(),
            maxt: (t - mt).abs() / mt,
        };
        assert!(
            e.origin < 2e-6 && e.direction < 2e-6 && e.maxt < 2e-6,
            "{line}: btfpt {o} {d} {t}: {e:?}"
        );
        worst.origin = worst.origin.max(e.origin);
        worst.direction = worst.direction.max(e.direction);
        worst.maxt = worst.maxt.max(e.maxt);
    }
    assert_eq!(cases, 6);
    println!("largest errors against Mitsuba 3.9.1: {worst:?}");
}

#[test]
fn thinlens_and_orthographic_parameters_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let load = |sensor: &str| load(&write(dir.path(), "s.xml", &scene_xml(sensor)));
    let s =
        load(r#"<sensor type="thinlens"><float name="aperture_radius" value="0.25"/></sensor>"#);
    // Mitsuba's default focus distance is the far clip plane.
    assert_eq!(
        s.camera.projection,
        Projection::ThinLens {
            aperture_radius: 0.25,
            focus_distance: 1e4
        }
    );
    let s = load(r#"<sensor type="orthographic"><float name="far_clip" value="30"/></sensor>"#);
    assert_eq!(s.camera.projection, Projection::Orthographic);
    assert_eq!(s.camera.far_clip, 30.0);
}

/// Loading `sensor` fails with a message naming the file, line 2 and containing `needle`.
fn expect_err(sensor: &str, needle: &str) {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "bad.xml", &scene_xml(sensor));
    assert_names(&load_err(&p, &[]), "bad.xml", 2, &[needle]);
}

#[test]
fn bad_sensor_parameters_are_errors() {
    let thin = |extra: &str| format!(r#"<sensor type="thinlens">{extra}</sensor>"#);
    // Mitsuba requires the aperture radius.
    expect_err(&thin(""), "aperture_radius");
    // Mitsuba accepts these but renders a mirrored lens (negative radius) or NaN / backward
    // rays (focus distance ≤ 0): refused here.
    expect_err(
        &thin(r#"<float name="aperture_radius" value="-0.1"/>"#),
        "aperture radius",
    );
    for (fd, needle) in [
        ("0", "focus distance"),
        ("-2", "focus distance"),
        ("nan", "non-finite"),
        ("inf", "non-finite"),
    ] {
        expect_err(
            &thin(&format!(
                r#"<float name="aperture_radius" value="0.1"/><float name="focus_distance" value="{fd}"/>"#
            )),
            needle,
        );
    }
    // As Mitsuba: no scale in a perspective camera's to_world, near_clip > 0, near < far.
    expect_err(
        &thin(
            r#"<float name="aperture_radius" value="0.1"/><transform name="to_world"><scale value="2"/></transform>"#,
        ),
        "scale factors",
    );
    expect_err(
        &thin(r#"<float name="aperture_radius" value="0.1"/><float name="near_clip" value="0"/>"#),
        "near_clip",
    );
    expect_err(
        r#"<sensor type="orthographic"><float name="near_clip" value="5"/><float name="far_clip" value="1"/></sensor>"#,
        "near_clip",
    );
    expect_err(
        r#"<sensor type="orthographic"><transform name="to_world"><scale x="0" y="1" z="1"/></transform></sensor>"#,
        "singular",
    );
    // The orthographic camera has no field of view (Mitsuba: an unreferenced property).
    expect_err(
        r#"<sensor type="orthographic"><float name="fov" value="30"/></sensor>"#,
        "fov",
    );
}
