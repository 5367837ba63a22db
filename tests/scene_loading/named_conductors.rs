//! Mitsuba's named conductors (`<string name="material" value="Au"/>`) read from scene files:
//! every name in `conductor` and `roughconductor` reflects as Mitsuba 3.9.1's own plugins do
//! (`reference-images/conductor_golden.txt`), the default is the ideal mirror, and the bad
//! inputs fail naming the file, the line and the element.

use crate::fixtures::{assert_names, load, load_err};
use btfpt::bsdf::{Bsdf, Texture};
use btfpt::geometry::SurfaceInteraction;
use btfpt::math::{Spectrum, Vec2, Vec3};
use btfpt::scene::Scene;
use std::path::{Path, PathBuf};

/// Mitsuba 3.9.1's values (`reference-images/conductor_materials.py`).
const GOLDEN: &str = include_str!("../../reference-images/conductor_golden.txt");

const SENSOR: &str = r#"
    <sensor type="perspective">
        <float name="fov" value="45"/>
        <film type="hdrfilm"><rfilter type="box"/></film>
    </sensor>"#;

fn write(dir: &Path, body: &str) -> PathBuf {
    let p = dir.join("metals.xml");
    let text = format!("<scene version=\"3.0.0\">\n{SENSOR}\n{body}\n</scene>\n");
    std::fs::write(&p, text).unwrap();
    p
}

/// The BSDF of the `i`-th shape.
fn bsdf(s: &Scene, i: usize) -> &Bsdf {
    &s.bsdfs[s.meshes[i].bsdf as usize]
}

/// Within 1e-4 relative, or NaN where Mitsuba gives NaN (eta = k = 0 at normal incidence).
fn agrees(ours: Spectrum, mitsuba: Spectrum) -> bool {
    (0..3).all(|c| {
        let (a, b) = (ours[c], mitsuba[c]);
        (a.is_nan() && b.is_nan()) || (a - b).abs() <= 1e-4 * a.abs().max(b.abs()) + 1e-6
    })
}

fn v3(f: &[&str]) -> Vec3 {
    Vec3::new(
        f[0].parse().unwrap(),
        f[1].parse().unwrap(),
        f[2].parse().unwrap(),
    )
}

#[test]
fn every_named_conductor_reflects_as_in_mitsuba() {
    let dir = tempfile::tempdir().unwrap();
    let mut scenes = std::collections::HashMap::new();
    let mut failures = Vec::new();
    let mut n = 0;
    for line in GOLDEN.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        if f[0] == "material" {
            continue;
        }
        let name = f[1];
        let s = scenes.entry(name.to_string()).or_insert_with(|| {
            load(&write(
                dir.path(),
                &format!(
                    r#"<shape type="sphere"><bsdf type="conductor"><string name="material" value="{name}"/></bsdf></shape>
<shape type="sphere"><bsdf type="roughconductor"><string name="material" value="{name}"/><float name="alpha" value="0.2"/></bsdf></shape>"#
                ),
            ))
        });
        let (ours, want) = match f[0] {
            "conductor" => {
                let c: f32 = f[2].parse().unwrap();
                let wi = Vec3::new((1.0 - c * c).sqrt(), 0.0, c);
                let si = SurfaceInteraction::for_tests(wi, Vec2::new(0.3, 0.6));
                let (_, w) = bsdf(s, 0).sample(&si, 0.5, Vec2::splat(0.5)).unwrap();
                (w, v3(&f[3..6]))
            }
            "roughconductor" => {
                let si = SurfaceInteraction::for_tests(v3(&f[2..5]), Vec2::new(0.3, 0.6));
                (bsdf(s, 1).eval(&si, v3(&f[5..8])), v3(&f[8..11]))
            }
            other => panic!("unknown record {other}"),
        };
        if !agrees(ours, want) {
            failures.push(format!("{line}: ours {ours}"));
        }
        n += 1;
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert_eq!((scenes.len(), n), (71, 71 * 4));
}

/// Mitsuba 3.9.1's default (no `material`, no `eta`/`k`) is `none`, the ideal mirror, in both
/// plugins; explicit eta/k with `material="none"` are used as given.
#[test]
fn default_conductor_is_the_ideal_mirror() {
    let dir = tempfile::tempdir().unwrap();
    let s = load(&write(
        dir.path(),
        r#"<shape type="sphere"><bsdf type="conductor"/></shape>
<shape type="sphere"><bsdf type="roughconductor"/></shape>
<shape type="sphere"><bsdf type="conductor"><string name="material" value="none"/><float name="eta" value="0.5"/></bsdf></shape>"#,
    ));
    let ior = |i: usize| match bsdf(&s, i) {
        Bsdf::Conductor(c) => (c.eta.clone(), c.k.clone()),
        Bsdf::RoughConductor(c) => (c.eta.clone(), c.k.clone()),
        b => panic!("{b:?}"),
    };
    for i in 0..3 {
        let (Texture::Constant(eta), Texture::Constant(k)) = ior(i) else {
            panic!("{:?}", ior(i));
        };
        let want_eta = if i == 2 { Vec3::splat(0.5) } else { Vec3::ZERO };
        assert_eq!((eta, k), (want_eta, Vec3::ONE), "shape {i}");
    }
}

/// Asserts that loading fails naming the file, `line`, the element and containing `needles`.
fn expect_err(p: &Path, line: u32, needles: &[&str]) {
    assert_names(&load_err(p, &[]), "metals.xml", line, needles);
}

#[test]
fn bad_conductor_materials_are_errors_naming_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The scene's line 7 is the <shape>, 8 the <bsdf>, 9 its first property.
    for (plugin, name) in [
        ("conductor", "Unobtainium"),
        ("roughconductor", "Gold"),
        // Case-sensitive, as Mitsuba's file lookup.
        ("conductor", "au"),
    ] {
        let p = write(
            d,
            &format!(
                "<shape type=\"sphere\">\n<bsdf type=\"{plugin}\">\n<string name=\"material\" value=\"{name}\"/>\n</bsdf></shape>"
            ),
        );
        let msg = format!("unknown conductor material \"{name}\"");
        let element = format!("bsdf \"{plugin}\"");
        expect_err(
            &p,
            9,
            &[
                &msg,
                &element,
                "valid: none, Ag, Al,",
                "Au",
                "a-C",
                "d-C_palik",
            ],
        );
    }
    // eta or k beside a named material: Mitsuba throws (eta) or leaves k unreferenced.
    for prop in ["eta", "k"] {
        let p = write(
            d,
            &format!(
                "<shape type=\"sphere\">\n<bsdf type=\"roughconductor\">\n<string name=\"material\" value=\"Cu\"/>\n<float name=\"{prop}\" value=\"2\"/>\n</bsdf></shape>"
            ),
        );
        expect_err(
            &p,
            8,
            &["either (eta, k) or material", "bsdf \"roughconductor\""],
        );
    }
    // An empty name is not `none`.
    let p = write(
        d,
        "<shape type=\"sphere\"><bsdf type=\"conductor\"><string name=\"material\" value=\"\"/></bsdf></shape>",
    );
    expect_err(&p, 7, &["unknown conductor material \"\""]);
}
