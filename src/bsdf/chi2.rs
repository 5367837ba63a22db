//! Chi-square goodness-of-fit test of a direction sampler against its claimed pdf, in the style of
//! Mitsuba 3's `chi2.py` and pbrt-v4's `bsdfs_test`: the sphere is binned over (cos θ, φ), the
//! observed histogram of samples is compared with the expected counts N·∫_bin pdf dω, bins with
//! low expectation are pooled, and the hypothesis "the samples follow the pdf" is rejected at
//! significance α with a Šidák correction over the number of tests in a suite.
//!
//! Reused by every sampled model (BSDFs here, the BTF material later): it only needs closures.

use crate::math::{Pcg32, Vec3};

/// Settings of one chi-square test.
#[derive(Clone, Debug)]
pub(crate) struct Chi2Test {
    /// Bins in cos θ over [−1, 1] (even, so that the horizon is a bin edge).
    pub cos_theta_res: usize,
    /// Bins in φ over [0, 2π).
    pub phi_res: usize,
    /// Number of sampling attempts (failed attempts count: they are missing probability mass).
    pub sample_count: usize,
    /// Sub-cells per bin and axis for the pdf integral (each integrated by 4-point Gauss–Legendre).
    pub sub: usize,
    /// Bins expecting fewer samples than this are pooled (the χ² approximation needs ~5).
    pub min_expected: f64,
    /// Family-wise significance level.
    pub significance: f64,
    /// Number of tests in the family (Šidák correction).
    pub test_count: usize,
    /// Seed of the sampler's random numbers.
    pub seed: u64,
}

impl Default for Chi2Test {
    fn default() -> Self {
        Chi2Test {
            cos_theta_res: 40,
            phi_res: 80,
            sample_count: 1_000_000,
            sub: 4,
            min_expected: 5.0,
            significance: 0.01,
            test_count: 1,
            seed: 0x5eed,
        }
    }
}

/// Outcome of [`Chi2Test::run`].
#[derive(Clone, Debug)]
pub(crate) struct Chi2Outcome {
    /// χ² statistic over the pooled cells.
    pub chi2: f64,
    /// Degrees of freedom (pooled cells − 1).
    pub dof: usize,
    /// Probability of a statistic at least this large if the pdf is right.
    pub p_value: f64,
    /// Per-test significance after the Šidák correction.
    pub alpha: f64,
    /// ∫ pdf over the sphere (≤ 1; < 1 when sampling can fail).
    pub pdf_integral: f64,
    /// Fraction of attempts that produced a direction.
    pub accepted: f64,
    /// False if the hypothesis is rejected or the inputs are invalid; `message` says why.
    pub passed: bool,
    /// Human-readable summary (printed by callers on failure).
    pub message: String,
}

const GL4_X: [f64; 4] = [
    -0.861_136_311_594_052_6,
    -0.339_981_043_584_856_3,
    0.339_981_043_584_856_3,
    0.861_136_311_594_052_6,
];
const GL4_W: [f64; 4] = [
    0.347_854_845_137_453_9,
    0.652_145_154_862_546_1,
    0.652_145_154_862_546_1,
    0.347_854_845_137_453_9,
];

impl Chi2Test {
    fn bin_of(&self, v: Vec3) -> Option<usize> {
        if !v.is_finite() {
            return None;
        }
        let z = v.z.clamp(-1.0, 1.0) as f64;
        let i =
            (((z + 1.0) * 0.5 * self.cos_theta_res as f64) as usize).min(self.cos_theta_res - 1);
        let mut phi = (v.y as f64).atan2(v.x as f64);
        if phi < 0.0 {
            phi += 2.0 * std::f64::consts::PI;
        }
        let j = ((phi / (2.0 * std::f64::consts::PI) * self.phi_res as f64) as usize)
            .min(self.phi_res - 1);
        Some(i * self.phi_res + j)
    }

    /// ∫ pdf dω per bin (dω = d cos θ dφ), by Gauss–Legendre on `sub`² sub-cells per bin.
    fn integrate_pdf(&self, pdf: &impl Fn(Vec3) -> f32) -> Result<Vec<f64>, String> {
        let (nz, np, sub) = (self.cos_theta_res, self.phi_res, self.sub.max(1));
        let dz = 2.0 / (nz * sub) as f64;
        let dphi = 2.0 * std::f64::consts::PI / (np * sub) as f64;
        let mut out = vec![0.0; nz * np];
        for i in 0..nz * sub {
            let z0 = -1.0 + i as f64 * dz;
            for (xz, wz) in GL4_X.iter().zip(GL4_W) {
                let z = z0 + 0.5 * dz * (1.0 + xz);
                let r = (1.0 - z * z).max(0.0).sqrt();
                for j in 0..np * sub {
                    let phi0 = j as f64 * dphi;
                    let mut acc = 0.0;
                    for (xp, wp) in GL4_X.iter().zip(GL4_W) {
                        let phi = phi0 + 0.5 * dphi * (1.0 + xp);
                        let v = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
                        let p = pdf(v) as f64;
                        if !p.is_finite() || p < 0.0 {
                            return Err(format!("pdf({v}) = {p} is not a finite density"));
                        }
                        acc += wp * p;
                    }
                    out[(i / sub) * np + j / sub] += wz * acc * 0.25 * dz * dphi;
                }
            }
        }
        Ok(out)
    }

    /// Draws `sample_count` directions from `sample(u1, u2)` and tests them against `pdf`.
    pub fn run(
        &self,
        mut sample: impl FnMut(f32, f32) -> Option<Vec3>,
        pdf: impl Fn(Vec3) -> f32,
    ) -> Chi2Outcome {
        let alpha = 1.0 - (1.0 - self.significance).powf(1.0 / self.test_count.max(1) as f64);
        let fail = |message: String| Chi2Outcome {
            chi2: f64::NAN,
            dof: 0,
            p_value: 0.0,
            alpha,
            pdf_integral: f64::NAN,
            accepted: f64::NAN,
            passed: false,
            message,
        };
        let n_bins = self.cos_theta_res * self.phi_res;
        let mut observed = vec![0u64; n_bins];
        let mut rng = Pcg32::new(self.seed, 0x0c42);
        let mut accepted = 0usize;
        for _ in 0..self.sample_count {
            let (u1, u2) = (rng.next_f32(), rng.next_f32());
            if let Some(v) = sample(u1, u2) {
                if !v.is_finite() || (v.length() - 1.0).abs() > 1e-3 {
                    return fail(format!("sampler returned a non-unit direction {v}"));
                }
                if let Some(b) = self.bin_of(v) {
                    observed[b] += 1;
                    accepted += 1;
                }
            }
        }
        let integral = match self.integrate_pdf(&pdf) {
            Ok(v) => v,
            Err(e) => return fail(e),
        };
        let pdf_integral: f64 = integral.iter().sum();
        let n = self.sample_count as f64;
        let expected: Vec<f64> = integral.iter().map(|p| p * n).collect();

        let mut message = String::new();
        if pdf_integral > 1.0 + 1e-2 {
            message = format!("pdf integrates to {pdf_integral:.5} > 1");
        }
        // Pool cells in order of increasing expectation until each pooled cell expects enough.
        let mut order: Vec<usize> = (0..n_bins).collect();
        order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
        let mut cells: Vec<(f64, f64)> = Vec::with_capacity(n_bins);
        let (mut pool_obs, mut pool_exp) = (0.0, 0.0);
        for &b in &order {
            let (o, e) = (observed[b] as f64, expected[b]);
            if e == 0.0 && o > 0.0 {
                message = format!(
                    "{o} samples in bin (cos θ #{}, φ #{}) where the pdf integrates to 0",
                    b / self.phi_res,
                    b % self.phi_res
                );
                break;
            }
            if e < self.min_expected || pool_exp > 0.0 {
                pool_obs += o;
                pool_exp += e;
                if pool_exp >= self.min_expected {
                    cells.push((pool_obs, pool_exp));
                    pool_obs = 0.0;
                    pool_exp = 0.0;
                }
            } else {
                cells.push((o, e));
            }
        }
        if pool_exp > 0.0 || pool_obs > 0.0 {
            match cells.last_mut() {
                Some(last) => {
                    last.0 += pool_obs;
                    last.1 += pool_exp;
                }
                None => cells.push((pool_obs, pool_exp)),
            }
        }
        let chi2: f64 = cells
            .iter()
            .map(|&(o, e)| if e > 0.0 { (o - e) * (o - e) / e } else { o })
            .sum();
        let dof = cells.len().saturating_sub(1);
        let p_value = if dof == 0 {
            1.0
        } else {
            gamma_q(0.5 * dof as f64, 0.5 * chi2)
        };
        let passed = message.is_empty() && p_value >= alpha;
        if message.is_empty() {
            message = format!(
                "chi2 = {chi2:.1}, dof = {dof}, p = {p_value:.3e} (alpha = {alpha:.2e}), \
                 pdf integral = {pdf_integral:.5}, accepted = {:.5}",
                accepted as f64 / n
            );
        }
        Chi2Outcome {
            chi2,
            dof,
            p_value,
            alpha,
            pdf_integral,
            accepted: accepted as f64 / n,
            passed,
            message,
        }
    }
}

/// ln Γ(x) for x > 0 (Lanczos, g = 7, 9 terms; ~1e-15 relative).
fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection formula.
        return (std::f64::consts::PI / (std::f64::consts::PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised upper incomplete gamma Q(a, x) = Γ(a, x)/Γ(a): the χ² survival function is
/// Q(dof/2, χ²/2). Series for x < a + 1, Lentz continued fraction otherwise.
pub(crate) fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let ln_pre = a * x.ln() - x - ln_gamma(a);
    if x < a + 1.0 {
        let (mut ap, mut sum, mut del) = (a, 1.0 / a, 1.0 / a);
        for _ in 0..10_000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        (1.0 - sum * ln_pre.exp()).clamp(0.0, 1.0)
    } else {
        const TINY: f64 = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / TINY;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < TINY {
                d = TINY;
            }
            c = b + an / c;
            if c.abs() < TINY {
                c = TINY;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (ln_pre.exp() * h).clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{PI, Vec2, warp};

    #[test]
    fn chi2_survival_function_matches_known_values() {
        // Q(k/2, x/2) for χ² with k dof; references from standard tables.
        let sf = |k: f64, x: f64| gamma_q(0.5 * k, 0.5 * x);
        assert!((sf(1.0, 6.634_896_6) - 0.01).abs() < 1e-6);
        assert!((sf(2.0, 4.0) - (-2.0f64).exp()).abs() < 1e-12);
        assert!((sf(10.0, 23.209_251) - 0.01).abs() < 1e-6);
        assert!((sf(1000.0, 1106.969) - 0.01).abs() < 2e-4);
        assert!((sf(3000.0, 3000.0) - 0.4966).abs() < 1e-3);
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
    }

    fn cosine_sampler(u1: f32, u2: f32) -> Option<Vec3> {
        Some(warp::square_to_cosine_hemisphere(Vec2::new(u1, u2)))
    }

    #[test]
    fn accepts_a_correct_pdf() {
        let t = Chi2Test {
            sample_count: 200_000,
            ..Default::default()
        };
        let r = t.run(cosine_sampler, warp::square_to_cosine_hemisphere_pdf);
        assert!(r.passed, "{}", r.message);
        assert!((r.pdf_integral - 1.0).abs() < 1e-4, "{}", r.message);
        // Half the sphere is empty and pooled; the rest keeps its own cells.
        assert!(r.dof > 1000 && r.dof < 1700, "{}", r.message);
        assert!(
            r.chi2 < 2.0 * r.dof as f64 && (r.alpha - 0.01).abs() < 1e-12,
            "{}",
            r.message
        );
    }

    #[test]
    fn rejects_a_wrong_pdf() {
        let t = Chi2Test {
            sample_count: 200_000,
            ..Default::default()
        };
        // Cosine-distributed samples claimed to be uniform on the hemisphere.
        let r = t.run(cosine_sampler, warp::square_to_uniform_hemisphere_pdf);
        assert!(!r.passed, "{}", r.message);
        assert!(r.p_value < 1e-10, "{}", r.message);

        // A subtler error: a lobe sharper than claimed, cos^1.1 instead of cos (renormalised).
        let r = t.run(cosine_sampler, |v: Vec3| {
            if v.z > 0.0 {
                v.z.powf(1.1) * 3.1 / (2.0 * PI)
            } else {
                0.0
            }
        });
        assert!(!r.passed, "{}", r.message);

        // Samples where the pdf claims nothing can happen.
        let r = t.run(
            |u1, u2| Some(warp::square_to_uniform_sphere(Vec2::new(u1, u2))),
            warp::square_to_uniform_hemisphere_pdf,
        );
        assert!(!r.passed, "{}", r.message);
    }

    #[test]
    fn missing_mass_is_detected() {
        // A sampler that silently drops 2 % of its samples but claims the full pdf.
        let t = Chi2Test {
            sample_count: 400_000,
            ..Default::default()
        };
        let r = t.run(
            |u1, u2| (u1 >= 0.02).then(|| warp::square_to_cosine_hemisphere(Vec2::new(u1, u2))),
            warp::square_to_cosine_hemisphere_pdf,
        );
        assert!(!r.passed, "{}", r.message);
    }
}
