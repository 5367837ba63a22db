//! The named-conductor table against Mitsuba 3.9.1 itself (`reference-images/conductor_golden.txt`,
//! made by `reference-images/conductor_materials.py` in `llvm_ad_rgb`, the variant the reference
//! images render with) and against its source: two of Mitsuba's spectral files
//! (`tests/data/ior/`) converted by our own `spectrum_list_to_srgb`.

use crate::bsdf::conductor_materials::{CONDUCTOR_MATERIALS, conductor_material};
use crate::math::cie1931::{SpectrumUse, spectrum_list_to_srgb};

const GOLDEN: &str = include_str!("../../../reference-images/conductor_golden.txt");

/// |a − b| relative to max(1, |b|): absolute for the small extinction coefficients.
fn err(a: f32, b: f32) -> f32 {
    (a - b).abs() / b.abs().max(1.0)
}

#[test]
fn table_matches_mitsuba_rgb_variants() {
    let mut seen = Vec::new();
    let mut worst = (0.0f32, String::new());
    for line in GOLDEN.lines().filter(|l| l.starts_with("material ")) {
        let f: Vec<&str> = line.split_whitespace().collect();
        let v: Vec<f32> = f[2..8].iter().map(|x| x.parse().unwrap()).collect();
        let m = conductor_material(f[1]).unwrap_or_else(|| panic!("{} not in the table", f[1]));
        for (ours, mitsuba) in m.eta.iter().chain(&m.k).zip(&v) {
            let e = err(*ours, *mitsuba);
            if e > worst.0 {
                worst = (e, line.to_string());
            }
        }
        seen.push(f[1]);
    }
    assert!(worst.0 <= 1e-4, "off by {}: {}", worst.0, worst.1);
    // Every name Mitsuba ships, and nothing else.
    let ours: Vec<&str> = CONDUCTOR_MATERIALS.iter().map(|m| m.name).collect();
    assert_eq!(ours, seen);
    assert_eq!(ours.len(), 71);
    assert!(conductor_material("none").is_none() && conductor_material("au").is_none());
}

/// Mitsuba's `.spd` reading: a wavelength (nm) and a value per line, `#` comments.
fn spd(text: &str) -> (Vec<f64>, Vec<f64>) {
    text.lines()
        .filter(|l| !l.trim_start().starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let mut it = l.split_whitespace().map(|x| x.parse::<f64>().unwrap());
            (it.next().unwrap(), it.next().unwrap())
        })
        .unzip()
}

#[test]
fn table_is_the_spectral_data_without_d65() {
    let files = [
        (
            "Au",
            include_str!("../../../tests/data/ior/Au.eta.spd"),
            include_str!("../../../tests/data/ior/Au.k.spd"),
        ),
        // Out of gamut: the red of both eta and k is clipped at 0.
        (
            "AlSb",
            include_str!("../../../tests/data/ior/AlSb.eta.spd"),
            include_str!("../../../tests/data/ior/AlSb.k.spd"),
        ),
    ];
    for (name, eta_file, k_file) in files {
        let m = conductor_material(name).unwrap();
        for (file, want) in [(eta_file, m.eta), (k_file, m.k)] {
            let (w, v) = spd(file);
            let (ours, _) = spectrum_list_to_srgb(&w, &v, SpectrumUse::Emission);
            for c in 0..3 {
                assert!(
                    err(ours[c], want[c]) <= 1e-5,
                    "{name}: {ours:?} vs {want:?}"
                );
            }
            // Mitsuba's D65-weighted conversion (`Unbounded`) would be another colour.
            let (d65, _) = spectrum_list_to_srgb(&w, &v, SpectrumUse::Unbounded);
            assert!((0..3).any(|c| err(d65[c], want[c]) > 1e-3), "{name}");
        }
    }
}
