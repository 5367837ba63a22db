//! `pplastic` against Mitsuba 3.9.1's own plugin in its unpolarized variant
//! (`pplastic_golden.txt`), its sampling against its pdf (chi-square), and a white furnace:
//! importance-sampled albedo equals the uniformly sampled one and stays ≤ 1.

use super::super::golden::{check_golden, checker, texels};
use super::{albedo_two_ways, chi2_sampler, chi2_whole_sampler_ok};
use crate::bsdf::*;
use crate::math::Pcg32;
use crate::math::frame::from_spherical;

const GOLDEN: &str = include_str!("../../../reference-images/pplastic_golden.txt");

/// Mitsuba's `ext_ior` default, "air": the relative IOR is int_ior / this.
const AIR: f32 = 1.00028;

/// Chi-square tests in this file (the Šidák family).
const CHI2_TESTS: usize = 5 * 3;

fn c(r: f32, g: f32, b: f32) -> Texture {
    Texture::Constant(Spectrum::new(r, g, b))
}

fn u(v: f32) -> Texture {
    Texture::uniform(v)
}

/// The configurations of `pplastic_golden.py`, by name.
fn config(name: &str) -> Bsdf {
    let beckmann = MicrofacetType::Beckmann;
    Bsdf::PPlastic(match name {
        "pplastic_default" => {
            PPlastic::new(u(0.5), None, u(1.49 / AIR), beckmann, u(0.1), u(0.1), true)
        }
        "pplastic_ggx_specular" => PPlastic::new(
            c(0.1, 0.5, 0.8),
            Some(c(0.9, 0.7, 0.5)),
            u(1.7 / 1.1),
            MicrofacetType::Ggx,
            u(0.3),
            u(0.3),
            true,
        ),
        "pplastic_aniso_eta" => PPlastic::new(
            c(0.6, 0.3, 0.2),
            None,
            u(1.33),
            beckmann,
            u(0.05),
            u(0.4),
            true,
        ),
        "pplastic_beckmann_all_normals" => PPlastic::new(
            u(0.5),
            None,
            u(1.5046 / AIR),
            beckmann,
            u(0.2),
            u(0.2),
            false,
        ),
        "pplastic_textured" => {
            let rough = texels(
                |i, j| 0.15 + 0.6 * ((2 * i + j) % 5) as f64 / 5.0,
                [1.0, 0.9, 1.1],
            );
            PPlastic::new(
                texels(
                    |i, j| 0.2 + 0.6 * ((i + 2 * j) % 4) as f64 / 4.0,
                    [1.0, 0.7, 0.4],
                ),
                Some(checker(0.4, 0.9)),
                checker(1.3, 1.8),
                beckmann,
                rough.clone(),
                rough,
                true,
            )
        }
        other => panic!("golden file names an unknown configuration {other}"),
    })
}

#[test]
fn pplastic_matches_mitsuba3_plugin() {
    let (n_config, n_eval, n_sample) = check_golden(GOLDEN, config);
    assert!(n_config == 5 && n_eval >= 150 && n_sample >= 120);
}

const NAMES: [&str; 5] = [
    "pplastic_default",
    "pplastic_ggx_specular",
    "pplastic_aniso_eta",
    "pplastic_beckmann_all_normals",
    "pplastic_textured",
];

#[test]
fn chi2_pplastic() {
    let mut n = 0;
    let mut failures = Vec::new();
    for name in NAMES {
        let mut b = config(name);
        // The default α = 0.1 is sharper than the chi-square bins integrate well.
        if let Bsdf::PPlastic(p) = &mut b
            && name == "pplastic_default"
        {
            p.alpha_u = u(0.25);
            p.alpha_v = u(0.25);
        }
        for theta in [0.3f32, 0.9, 1.35] {
            n += 1;
            let wi = from_spherical(theta, 0.9);
            let r = chi2_sampler(&b, wi, 400_000, CHI2_TESTS, Pcg32::new(91, 5));
            if chi2_whole_sampler_ok(&r, 400_000) {
                println!("{name} θ_i = {theta}: {}", r.message);
            } else {
                failures.push(format!("{name} θ_i = {theta}: {}", r.message));
            }
        }
    }
    assert_eq!(n, CHI2_TESTS);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn furnace_importance_and_uniform_estimates_agree() {
    // With a white base and no specular tint the coating's reflection plus the twice-transmitted
    // diffuse base cannot exceed 1 (single scattering only).
    for name in NAMES {
        let mut b = config(name);
        if let Bsdf::PPlastic(p) = &mut b {
            *p = PPlastic::new(
                u(1.0),
                None,
                p.eta.clone(),
                p.distribution,
                p.alpha_u.clone(),
                p.alpha_v.clone(),
                p.sample_visible,
            );
        }
        for (k, &theta) in [0.3f32, 1.1, 1.45].iter().enumerate() {
            let wi = from_spherical(theta, 1.3);
            let ((mi, si_), (mu, su)) =
                albedo_two_ways(&b, wi, 150_000, Pcg32::new(17 + k as u64, 3), 1);
            let tol = 4.0 * (si_ * si_ + su * su).sqrt() + 1e-4;
            assert!(
                (mi - mu).abs() <= tol,
                "{name} θ_i = {theta}: importance {mi} ± {si_} vs uniform {mu} ± {su}"
            );
            assert!(
                mi <= 1.0 + 3.0 * si_,
                "{name} θ_i = {theta}: albedo {mi} > 1"
            );
        }
    }
}
