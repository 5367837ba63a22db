//! Chi-square tests of the three microfacet BSDFs with the Beckmann distribution (Mitsuba's
//! default): visible and non-visible normal sampling, isotropic and anisotropic roughness, both
//! sides of the rough dielectric. The sampled directions must follow `pdf`, and samples may
//! fail only as often as the pdf's missing mass says.

use crate::bsdf::*;
use crate::math::Pcg32;

/// Number of chi-square tests in this file (the Šidák family).
const CHI2_TESTS: usize = 16 + 6 + 16;

const B: MicrofacetType = MicrofacetType::Beckmann;

fn c(v: f32) -> Texture {
    Texture::Constant(Spectrum::splat(v))
}

fn conductor(alpha_u: f32, alpha_v: f32, vis: bool) -> Bsdf {
    Bsdf::RoughConductor(RoughConductor {
        distribution: B,
        alpha_u: Texture::uniform(alpha_u),
        alpha_v: Texture::uniform(alpha_v),
        eta: Texture::Constant(Spectrum::new(0.143, 0.374, 1.442)),
        k: Texture::Constant(Spectrum::new(3.983, 2.385, 1.603)),
        specular_reflectance: c(1.0),
        sample_visible: vis,
    })
}

fn plastic(alpha: f32, nonlinear: bool, vis: bool) -> Bsdf {
    Bsdf::RoughPlastic(RoughPlastic::new(
        B,
        alpha,
        1.49,
        Texture::Constant(Spectrum::new(0.2, 0.5, 0.8)),
        c(1.0),
        nonlinear,
        vis,
    ))
}

fn dielectric(alpha_u: f32, alpha_v: f32, eta: f32, vis: bool) -> Bsdf {
    Bsdf::RoughDielectric(RoughDielectric {
        distribution: B,
        alpha_u: c(alpha_u),
        alpha_v: c(alpha_v),
        eta,
        specular_reflectance: c(1.0),
        specular_transmittance: c(1.0),
        sample_visible: vis,
    })
}

/// [`super::chi2_cases`] in this file's family of tests.
fn chi2_cases(name: &str, cases: &[Bsdf], thetas: &[f32]) {
    super::chi2_cases(name, cases, thetas, CHI2_TESTS, Pcg32::new(91, 5));
}

#[test]
fn chi2_beckmann_roughconductor() {
    chi2_cases(
        "roughconductor",
        &[
            conductor(0.1, 0.1, true),
            conductor(0.5, 0.1, true),
            conductor(0.3, 0.3, false),
            conductor(0.08, 0.4, false),
        ],
        &[0.0, 0.6, 1.3, 1.52],
    );
}

#[test]
fn chi2_beckmann_roughplastic() {
    chi2_cases(
        "roughplastic",
        &[plastic(0.15, false, true), plastic(0.5, true, false)],
        &[0.1, 0.9, 1.45],
    );
}

#[test]
fn chi2_beckmann_roughdielectric() {
    chi2_cases(
        "roughdielectric",
        &[
            dielectric(0.2, 0.2, 1.5, true),
            dielectric(0.5, 0.15, 1.33, true),
            dielectric(0.3, 0.3, 1.5, false),
            dielectric(0.1, 0.4, 1.7, false),
        ],
        &[0.2, 1.2, 2.0, 2.9],
    );
}

/// The roughplastic tables for Beckmann against a midpoint integration over half vectors,
/// independent of the visible-normal quadrature that builds them.
#[test]
fn beckmann_roughplastic_transmittance_matches_direct_integration() {
    let (alpha, eta) = (0.3f32, 1.5f32);
    let rp = RoughPlastic::new(B, alpha, eta, c(1.0), c(1.0), false, true);
    let d = microfacet::Microfacet::new(B, alpha, alpha, true);
    let n = 500;
    let (dz, dphi) = (1.0 / n as f64, 2.0 * std::f64::consts::PI / (2 * n) as f64);
    for cos_i in [0.15f32, 0.5, 0.95] {
        let wi = Vec3::new((1.0 - cos_i * cos_i).sqrt(), 0.0, cos_i);
        let mut t = 0.0f64;
        for i in 0..n {
            let z = (i as f64 + 0.5) * dz;
            for j in 0..2 * n {
                let phi = (j as f64 + 0.5) * dphi;
                let r = (1.0 - z * z).sqrt();
                let m = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
                let dwi = d.smith_g1(wi, m) * wi.dot(m).max(0.0) * d.eval(m) / cos_i;
                if dwi == 0.0 {
                    continue;
                }
                let fr = fresnel::fresnel_dielectric(wi.dot(m), eta);
                let wo = fresnel::refract_about(wi, m, fr.cos_theta_t, fr.eta_ti);
                if wo.z < 0.0 {
                    t += (dwi * (1.0 - fr.r) * d.smith_g1(wo, m)) as f64 * dz * dphi;
                }
            }
        }
        let tab = rp.transmittance(cos_i);
        assert!(
            (tab as f64 - t).abs() < 3e-3,
            "cos {cos_i}: table {tab} vs {t}"
        );
    }
}
