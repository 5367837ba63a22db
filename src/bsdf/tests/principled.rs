//! The principled BSDFs (`principled`, `principledthin`) against Mitsuba 3.9.1's own plugin (`principled_golden.txt`), its
//! sampling against its pdf (chi-square), and a white furnace: importance-sampled albedo equals
//! the uniformly sampled one and stays ≤ 1 where the model conserves energy.

use super::super::golden::{check_golden, checker, texels};
use super::{albedo_two_ways, chi2_sampler, chi2_whole_sampler_ok};
use crate::bsdf::*;
use crate::math::Pcg32;
use crate::math::frame::from_spherical;

const GOLDEN: &str = include_str!("../../../reference-images/principled_golden.txt");

/// Chi-square tests in this file (the Šidák family).
const CHI2_TESTS: usize = 6 * 4 + 3 * 4;

fn c(r: f32, g: f32, b: f32) -> Texture {
    Texture::Constant(Spectrum::new(r, g, b))
}

fn u(v: f32) -> Texture {
    Texture::uniform(v)
}

/// Mitsuba's `specular` → relative IOR.
fn eta_of_specular(s: f32) -> f32 {
    2.0 / (1.0 - (0.08 * s).sqrt()) - 1.0
}

/// Mitsuba's defaults: base colour and roughness 0.5, specular 0.5, every other weight 0.
fn default() -> Principled {
    Principled {
        base_color: u(0.5),
        roughness: u(0.5),
        anisotropic: u(0.0),
        metallic: u(0.0),
        spec_trans: u(0.0),
        spec_tint: u(0.0),
        sheen: u(0.0),
        sheen_tint: u(0.0),
        flatness: u(0.0),
        clearcoat: u(0.0),
        clearcoat_gloss: u(0.0),
        eta: eta_of_specular(0.5),
        has_spec_trans: false,
        diffuse_rate: 1.0,
        specular_rate: 1.0,
        clearcoat_rate: 1.0,
    }
}

/// Mitsuba's `principledthin` defaults.
fn thin_default() -> PrincipledThin {
    PrincipledThin {
        base_color: u(0.5),
        roughness: u(0.5),
        anisotropic: u(0.0),
        spec_trans: u(0.0),
        spec_tint: u(0.0),
        sheen: u(0.0),
        sheen_tint: u(0.0),
        flatness: u(0.0),
        diff_trans: u(0.0),
        eta: u(1.5),
        has_spec_trans: false,
        has_diff_trans: false,
        rates: [1.0; 4],
    }
}

/// The thin configurations of `principled_golden.py`.
fn thin_config(name: &str) -> Bsdf {
    let d = thin_default();
    Bsdf::PrincipledThin(match name {
        "principledthin_default" => d,
        "principledthin_all" => PrincipledThin {
            base_color: c(0.7, 0.4, 0.2),
            roughness: u(0.35),
            anisotropic: u(0.4),
            spec_trans: u(0.6),
            eta: u(1.4),
            spec_tint: u(0.5),
            sheen: u(0.5),
            sheen_tint: u(0.6),
            flatness: u(0.3),
            diff_trans: u(0.8),
            has_spec_trans: true,
            has_diff_trans: true,
            rates: [1.5, 0.7, 2.0, 0.5],
        },
        "principledthin_textured" => PrincipledThin {
            base_color: texels(
                |i, j| 0.2 + 0.6 * ((i + 2 * j) % 4) as f64 / 4.0,
                [1.0, 0.7, 0.4],
            ),
            roughness: texels(
                |i, j| 0.15 + 0.6 * ((2 * i + j) % 5) as f64 / 5.0,
                [1.0, 0.9, 1.1],
            ),
            spec_trans: checker(0.3, 0.8),
            eta: checker(1.2, 1.6),
            diff_trans: u(1.4),
            has_spec_trans: true,
            has_diff_trans: true,
            ..d
        },
        other => panic!("golden file names an unknown configuration {other}"),
    })
}

/// The configurations of `principled_golden.py`, by name.
fn config(name: &str) -> Bsdf {
    if name.starts_with("principledthin") {
        return thin_config(name);
    }
    let d = default();
    Bsdf::Principled(match name {
        "principled_default" => d,
        "principled_sheen_coat" => Principled {
            base_color: c(0.8, 0.3, 0.2),
            roughness: u(0.3),
            metallic: u(0.2),
            spec_tint: u(0.5),
            sheen: u(0.6),
            sheen_tint: u(0.4),
            clearcoat: u(0.7),
            clearcoat_gloss: u(0.6),
            eta: eta_of_specular(0.6),
            ..d
        },
        "principled_trans_aniso" => Principled {
            base_color: c(0.9, 0.8, 0.6),
            spec_trans: u(0.7),
            roughness: u(0.25),
            eta: 1.45,
            anisotropic: u(0.5),
            metallic: u(0.1),
            clearcoat: u(0.3),
            has_spec_trans: true,
            ..d
        },
        "principled_flat_rates" => Principled {
            base_color: c(0.2, 0.5, 0.8),
            flatness: u(0.6),
            roughness: u(0.8),
            anisotropic: u(0.8),
            diffuse_rate: 0.5,
            specular_rate: 2.0,
            clearcoat_rate: 3.0,
            clearcoat: u(0.5),
            ..d
        },
        "principled_glass" => Principled {
            spec_trans: u(1.0),
            roughness: u(0.1),
            eta: 1.5,
            base_color: c(1.0, 1.0, 1.0),
            has_spec_trans: true,
            ..d
        },
        "principled_metal" => Principled {
            metallic: u(1.0),
            roughness: u(0.35),
            base_color: c(0.95, 0.7, 0.3),
            anisotropic: u(0.3),
            ..d
        },
        "principled_eta_below_one" => Principled {
            spec_trans: u(0.5),
            eta: 0.8,
            roughness: u(0.4),
            spec_tint: u(0.7),
            sheen: u(0.3),
            has_spec_trans: true,
            ..d
        },
        "principled_textured" => Principled {
            base_color: texels(
                |i, j| 0.2 + 0.6 * ((i + 2 * j) % 4) as f64 / 4.0,
                [1.0, 0.7, 0.4],
            ),
            roughness: texels(
                |i, j| 0.15 + 0.6 * ((2 * i + j) % 5) as f64 / 5.0,
                [1.0, 0.9, 1.1],
            ),
            metallic: checker(0.1, 0.6),
            spec_trans: u(0.3),
            eta: 1.3,
            clearcoat: checker(0.2, 0.9),
            clearcoat_gloss: u(0.3),
            sheen: u(0.5),
            sheen_tint: u(0.8),
            anisotropic: u(0.2),
            flatness: u(0.4),
            spec_tint: u(0.3),
            has_spec_trans: true,
            ..d
        },
        other => panic!("golden file names an unknown configuration {other}"),
    })
}

#[test]
fn principled_matches_mitsuba3_plugin() {
    let (n_config, n_eval, n_sample) = check_golden(GOLDEN, config);
    assert!(n_config == 11 && n_eval >= 330 && n_sample >= 260);
}

/// Chi-square of the whole sampler against `pdf` at `wi` (see [`chi2_whole_sampler_ok`]).
fn chi2_ok(b: &Bsdf, wi: Vec3) -> std::result::Result<String, String> {
    let r = chi2_sampler(b, wi, 400_000, CHI2_TESTS, Pcg32::new(91, 5));
    if chi2_whole_sampler_ok(&r, 400_000) {
        Ok(r.message)
    } else {
        Err(r.message)
    }
}

#[test]
fn chi2_principled() {
    // Front-side only for the opaque materials (Mitsuba's pdf is non-zero on the back side of
    // a material without transmission, which it never samples); both sides with spec_trans.
    let opaque = [
        "principled_default",
        "principled_sheen_coat",
        "principled_flat_rates",
        "principled_metal",
    ];
    let cases = [
        (opaque[0], &[0.3f32, 1.2][..]),
        (opaque[1], &[0.5, 1.4][..]),
        (opaque[2], &[0.2, 1.0][..]),
        (opaque[3], &[0.7, 1.3][..]),
        ("principled_trans_aniso", &[0.4, 1.2, 2.1, 2.8][..]),
        ("principled_glass", &[0.3, 1.1, 2.0, 2.9][..]),
        ("principled_eta_below_one", &[0.5, 1.3, 2.2, 2.7][..]),
        ("principled_textured", &[0.6, 1.4, 2.4, 2.9][..]),
        ("principledthin_default", &[0.4, 1.3, 2.0, 2.8][..]),
        ("principledthin_all", &[0.2, 1.1, 1.9, 2.9][..]),
        ("principledthin_textured", &[0.7, 1.4, 2.3, 2.6][..]),
    ];
    let mut n = 0;
    let mut failures = Vec::new();
    for (name, thetas) in cases {
        let mut b = config(name);
        // The golden glass (α = 0.01) is sharper than the chi-square bins can integrate.
        if let Bsdf::Principled(p) = &mut b
            && name == "principled_glass"
        {
            p.roughness = u(0.35);
        }
        for &theta in thetas {
            n += 1;
            match chi2_ok(&b, from_spherical(theta, 0.9)) {
                Ok(m) => println!("{name} θ_i = {theta}: {m}"),
                Err(m) => failures.push(format!("{name} θ_i = {theta}: {m}")),
            }
        }
    }
    assert_eq!(n, CHI2_TESTS);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn furnace_importance_and_uniform_estimates_agree() {
    // A white principled dielectric (glass) and a white metal lose energy only to single
    // scattering; every configuration's importance and uniform estimates agree.
    let bounded = ["principled_glass", "principled_metal"];
    let names = [
        "principled_default",
        "principled_sheen_coat",
        "principled_trans_aniso",
        "principled_glass",
        "principled_metal",
        "principled_textured",
        "principledthin_all",
        "principledthin_textured",
    ];
    for name in names {
        let b = config(name);
        for (k, &theta) in [0.3f32, 1.1, 1.45].iter().enumerate() {
            let wi = from_spherical(theta, 1.3);
            let ((mi, si_), (mu, su)) =
                albedo_two_ways(&b, wi, 150_000, Pcg32::new(17 + k as u64, 3), 1);
            let tol = 4.0 * (si_ * si_ + su * su).sqrt() + 1e-4;
            assert!(
                (mi - mu).abs() <= tol,
                "{name} θ_i = {theta}: importance {mi} ± {si_} vs uniform {mu} ± {su}"
            );
            if bounded.contains(&name) {
                assert!(
                    mi <= 1.0 + 3.0 * si_,
                    "{name} θ_i = {theta}: albedo {mi} > 1"
                );
            }
        }
    }
}
