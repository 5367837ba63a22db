//! Tests of the BSDFs through their public interfaces: physics (sampling against `pdf`, energy,
//! reciprocity), the Beckmann distribution's sampling, the batched interface against the
//! scalar code, and the named-conductor table against Mitsuba.

mod batch_vs_scalar;
mod beckmann_sampling;
mod btf_clusters;
mod conductor_materials;
mod physics;
mod pplastic;
mod principled;

use crate::bsdf::Bsdf;
use crate::bsdf::chi2::{Chi2Outcome, Chi2Test};
use crate::geometry::SurfaceInteraction;
use crate::math::{Pcg32, Vec2, Vec3, warp};

/// A hit in the local frame with incident direction `wi` at uv (0.3, 0.6).
fn si(wi: Vec3) -> SurfaceInteraction {
    SurfaceInteraction::for_tests(wi, Vec2::new(0.3, 0.6))
}

/// Chi-square of `b`'s whole sampler at `wi` (through its per-hit object, as the integrators
/// call it) against its `pdf`, with `samples` samples in a family of `tests` tests; the lobe
/// choices drawn from `lobe_rng`. A sample with zero weight counts as a failure, as in
/// Mitsuba's chi2 BSDF adapter.
fn chi2_sampler(b: &Bsdf, wi: Vec3, samples: usize, tests: usize, lobe_rng: Pcg32) -> Chi2Outcome {
    let si = si(wi);
    let mut lobe_rng = lobe_rng;
    let t = Chi2Test {
        sample_count: samples,
        test_count: tests,
        ..Default::default()
    };
    let at = b.at(&si);
    t.run(
        |u1, u2| {
            at.sample(&si, lobe_rng.next_f32(), Vec2::new(u1, u2))
                .filter(|(_, w)| w.max_element() > 0.0)
                .map(|(bs, _)| bs.wo)
        },
        |wo| at.pdf(&si, wo),
    )
}

/// True if `r` (from `samples` samples) passed and sampling fails only as often as the pdf's
/// missing mass says: ∫ pdf ≤ 1 and the accepted fraction equals ∫ pdf within 5 binomial σ.
fn chi2_whole_sampler_ok(r: &Chi2Outcome, samples: usize) -> bool {
    let acc_tol = 5.0 * (0.25 / samples as f64).sqrt() + 2e-3;
    r.passed && r.pdf_integral <= 1.0 + 2e-3 && (r.accepted - r.pdf_integral).abs() <= acc_tol
}

/// Chi-square of the whole sampler (400 000 samples, φ_i = 0.9) of every case at every θ_i
/// in a family of `tests` tests; each must pass [`chi2_whole_sampler_ok`]. Reports every
/// failing case at once.
fn chi2_cases(name: &str, cases: &[Bsdf], thetas: &[f32], tests: usize, lobe_rng: Pcg32) {
    const N: usize = 400_000;
    let mut failures = Vec::new();
    for (k, b) in cases.iter().enumerate() {
        for &theta in thetas {
            let wi = crate::math::frame::from_spherical(theta, 0.9);
            let r = chi2_sampler(b, wi, N, tests, lobe_rng.clone());
            if !chi2_whole_sampler_ok(&r, N) {
                failures.push(format!("{name} case {k} θ_i = {theta}: {}", r.message));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Mean and standard error.
fn mean_se(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// The white-furnace albedo ∫ eval dω_o at `wi` estimated twice from `n` draws of `rng`: by
/// the BSDF's own sampling (mean weight) and by uniform sphere sampling of `eval`; returns
/// ((mean, se) importance, (mean, se) uniform) of colour channel `channel`.
fn albedo_two_ways(
    b: &Bsdf,
    wi: Vec3,
    n: usize,
    mut rng: Pcg32,
    channel: usize,
) -> ((f64, f64), (f64, f64)) {
    let si = si(wi);
    let mut is = Vec::with_capacity(n);
    let mut un = Vec::with_capacity(n);
    for _ in 0..n {
        let s1 = rng.next_f32();
        let w = b
            .sample(&si, s1, rng.next_2d())
            .map_or(0.0, |(_, w)| w[channel] as f64);
        is.push(w);
        let wo = warp::square_to_uniform_sphere(rng.next_2d());
        un.push(b.eval(&si, wo)[channel] as f64 / warp::square_to_uniform_sphere_pdf() as f64);
    }
    (mean_se(&is), mean_se(&un))
}
