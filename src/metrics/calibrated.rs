//! The calibrated verdict of `btfpt compare` and `btfpt check`: z-tests of a render against a
//! reference at several block scales whose false-alarm rate over the whole image is held at α.
//!
//! - Noise: the test image's variance of its mean is *predicted* from the reference's per-sample
//!   variance (`sample_var / spp`, the per-sample variance floored as Mitsuba's render tests
//!   floor it) when the reference has one; otherwise it is the test render's own *estimate*.
//!   The reference's variance of its mean is added when known, and every cell gets an f32
//!   rounding floor ([`super::ztest::rounding_variance`]).
//! - Heavy tails: a rare bright path (a caustic) makes the mean of a few hundred samples far from
//!   normal, on one side only. With a predicted variance it pushes z up (a firefly), never down
//!   (the samples are ≥ 0); with an estimated variance a block that missed the path gets a tiny
//!   variance and a large negative z, while a firefly inflates its own variance estimate. So blocks
//!   smaller than [`Calibration::two_sided_block`] (16 px) test only the tail their noise model
//!   bounds (darker with a predicted variance, brighter with an estimated one); larger blocks,
//!   which hold enough samples for the normal approximation, test both. An estimated variance
//!   needs more samples for its darker tail ([`Calibration::two_sided_block_estimated`], 32 px):
//!   a 16 px block that missed a light's rarest paths underestimates its mean *and* its variance.
//! - Family: each block scale (b×b block means, Šidák-corrected over its cells × 3 channels)
//!   and one global bias test ([`BiasTest`]) share α equally (Bonferroni), so under the null
//!   hypothesis with normal cell means the image fails with probability ≤ α. docs/model.md
//!   gives the measured false-alarm rate and power.

use super::normal::normal_isf;
use super::ztest::{ZTest, z_test_with_tolerance};
use super::{check_same_size, ztest::check_variance};
use crate::io::RgbImage;
use crate::{Error, Result};
use serde::Serialize;

/// Relative tolerance of a cell whose *estimated* variance is 0 (its few samples all agreed,
/// e.g. a directly seen environment map texel, while the reference averaged several).
pub const ESTIMATED_ZERO_TOLERANCE: f64 = 1e-2;

/// Where the variance of the test image's mean comes from.
#[derive(Clone, Copy, Debug)]
pub enum TestNoise<'a> {
    /// Predicted from the reference's per-sample variance and the test's samples per pixel.
    Predicted { sample_var: &'a RgbImage, spp: u32 },
    /// The test render's own estimate of its variance of the mean (`render --variance`).
    Estimated(&'a RgbImage),
}

/// The noise of both images: the test's (if known) and the reference's variance of its mean.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoiseModel<'a> {
    pub test: Option<TestNoise<'a>>,
    pub reference: Option<&'a RgbImage>,
}

/// Settings of the calibrated test.
#[derive(Clone, Debug, Serialize)]
pub struct Calibration {
    /// Probability that a correct render fails (family-wise over all scales and the bias test).
    pub alpha: f64,
    /// Block sides of the scales in the verdict, in pixels (1 = per pixel); sides larger than
    /// the image are dropped.
    pub scales: Vec<usize>,
    /// Least per-sample variance assumed where the reference's is nonzero (radiance², as the
    /// 1e-4 of Mitsuba's render tests).
    pub sample_variance_floor: f64,
    /// Smallest block side whose test is two-sided when the test's variance is predicted from
    /// the reference (see the module docs on heavy tails).
    pub two_sided_block: usize,
    /// The same when the test's variance is its own estimate: a block that missed the rare
    /// bright paths also underestimates its variance, so the darker tail needs more samples.
    pub two_sided_block_estimated: usize,
}

impl Default for Calibration {
    fn default() -> Self {
        Calibration {
            alpha: 0.01,
            scales: vec![4, 8, 16, 32],
            sample_variance_floor: 1e-4,
            two_sided_block: 16,
            two_sided_block_estimated: 32,
        }
    }
}

/// Which side of a z-test fails a cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Tails {
    /// |z| over the threshold.
    Both,
    /// z below −threshold (the test darker).
    Lower,
    /// z over +threshold (the test brighter).
    Upper,
}

impl Tails {
    fn words(self) -> &'static str {
        match self {
            Tails::Both => "both tails",
            Tails::Lower => "test darker only",
            Tails::Upper => "test brighter only",
        }
    }
}

/// One block scale of the verdict.
#[derive(Clone, Debug, Serialize)]
pub struct ScaleTest {
    /// True when this scale's failures fail the image.
    pub in_verdict: bool,
    /// The side(s) of the test that count.
    pub tails: Tails,
    /// Cells failing on the counted side(s), plus zero-variance mismatches and non-finite values.
    pub failing_counted: usize,
    /// Why a scale is not in the verdict (shown for information only).
    pub note: Option<String>,
    #[serde(flatten)]
    pub test: ZTest,
}

/// The global bias test: a one-sample t-test over pixels of u = mean over channels of
/// w·(test − reference), with weights w fixed before the test image is seen and independent of
/// the pixel's own reference error (1/σ of the predicted noise of its 8 neighbours, see
/// `neighbour_weights`, or uniform when the test's noise is its own estimate), so
/// E[u] = 0 for a correct render whatever the noise's shape, and the standard error is measured
/// from the spread of u over the image (channels of one path are correlated).
#[derive(Clone, Debug, Serialize)]
pub struct BiasTest {
    /// "1/sigma of the 8 neighbours" or "uniform" (the plain mean difference).
    pub weights: &'static str,
    /// Pixels averaged.
    pub pixels: usize,
    /// Mean of u (in units of σ for the 1/σ weights, radiance for "uniform").
    pub mean: f64,
    /// Standard error of the mean of u, from the sample standard deviation of u.
    pub stderr: f64,
    /// mean / stderr.
    pub z: f64,
    /// Two-sided threshold on |z| at this test's share of α.
    pub threshold: f64,
    pub failed: bool,
}

/// The calibrated verdict and every figure behind it.
#[derive(Clone, Debug, Serialize)]
pub struct Verdict {
    /// Where the test's variance came from, in words.
    pub noise: String,
    /// True when the test's variance is its own low-spp estimate (fine scales not in the verdict).
    pub estimated: bool,
    pub alpha: f64,
    /// Tests sharing α (the scales in the verdict and the bias test).
    pub tests_in_verdict: usize,
    /// α / tests_in_verdict.
    pub alpha_per_test: f64,
    pub sample_variance_floor: f64,
    pub rounding_ulps: f64,
    /// The per-pixel test first, then the block scales from fine to coarse.
    pub scales: Vec<ScaleTest>,
    pub bias: BiasTest,
    pub passed: bool,
    /// One sentence per failed test.
    pub failures: Vec<String>,
}

impl Verdict {
    /// The per-pixel test (always computed, for the z-map and the worst pixels).
    pub fn pixel_test(&self) -> &ZTest {
        &self.scales[0].test
    }

    /// A few lines: one per scale and the bias test, then PASS or FAILED.
    pub fn report(&self) -> String {
        let mut s = format!(
            "calibrated test ({}): α = {} over {} tests (α {:.2e} each)",
            self.noise, self.alpha, self.tests_in_verdict, self.alpha_per_test
        );
        for sc in &self.scales {
            s.push_str("\n  ");
            s.push_str(&sc.test.summary());
            match &sc.note {
                Some(n) => s.push_str(&format!(" [not in the verdict: {n}]")),
                None => s.push_str(&format!(
                    " [verdict: {}, {} failing]",
                    sc.tails.words(),
                    sc.failing_counted
                )),
            }
        }
        let b = &self.bias;
        s.push_str(&format!(
            "\n  global bias ({} weights, {} pixels): mean {:+.3e} ± {:.3e} = {:+.2} standard errors (|·| ≤ {:.2} to pass)",
            b.weights, b.pixels, b.mean, b.stderr, b.z, b.threshold
        ));
        s
    }
}

/// The per-pixel variance of (test − reference) under `noise` (before the rounding floor).
pub fn pixel_variance(noise: &NoiseModel, sample_variance_floor: f64) -> Result<RgbImage> {
    let base = match (noise.test, noise.reference) {
        (Some(TestNoise::Predicted { sample_var, .. }), _) => sample_var,
        (Some(TestNoise::Estimated(v)), _) => v,
        (None, Some(r)) => r,
        (None, None) => {
            return Err(Error::Invalid(
                "the calibrated test needs a variance: the reference's per-sample variance with \
                 the test's spp, the test's own variance, or the reference's variance of its mean"
                    .into(),
            ));
        }
    };
    let mut out = RgbImage::new(base.width, base.height);
    match noise.test {
        Some(TestNoise::Predicted { sample_var, spp }) => {
            if spp == 0 {
                return Err(Error::Invalid(
                    "the test render's spp must be at least 1".into(),
                ));
            }
            check_variance(sample_var, "sample variance")?;
            let floor = sample_variance_floor.max(0.0) as f32;
            for (o, &v) in out.data.iter_mut().zip(&sample_var.data) {
                *o = if v > 0.0 {
                    v.max(floor) / spp as f32
                } else {
                    0.0
                };
            }
        }
        Some(TestNoise::Estimated(v)) => {
            check_variance(v, "test variance")?;
            out.data.copy_from_slice(&v.data);
        }
        None => {}
    }
    if let Some(r) = noise.reference {
        check_same_size(&out, r, "test variance vs reference variance")?;
        check_variance(r, "reference variance")?;
        for (o, v) in out.data.iter_mut().zip(&r.data) {
            *o += v;
        }
    }
    Ok(out)
}

/// Cells of `t` that fail on `tails`: |z| or signed z over the threshold, or a channel without a
/// finite z (zero-variance mismatch, non-finite test value), which always fails.
fn failing_cells(t: &ZTest, tails: Tails) -> usize {
    let bad = |z: f32| {
        let z = z as f64;
        match tails {
            Tails::Both => z.abs() > t.threshold,
            Tails::Lower => z < -t.threshold,
            Tails::Upper => z > t.threshold,
        }
    };
    let by_z =
        t.z.chunks_exact(3)
            .filter(|c| c.iter().any(|&z| bad(z)))
            .count();
    by_z + t.exact_mismatches + t.nonfinite
}

/// Per pixel and channel, the weight of the bias test's mean: 1/σ of the mean of `var` (plus the
/// reference's f32 rounding) over the pixel's 8 neighbours inside the image, 0 where that mean
/// variance is 0. The pixel's own variance is left out on purpose: a reference's variance is
/// estimated from the same samples as its mean, and for right-skewed samples (every path-traced
/// pixel) the two rise and fall together, so 1/σ̂ of the pixel itself weighs the pixels whose
/// reference came out low more than those whose reference came out high, and the weighted mean
/// difference of a correct render is biased upward (docs/model.md). A neighbour's samples are not
/// the pixel's when each sample lands in one pixel (the box filter, as the per-sample variance
/// assumes), so these weights are independent of the pixel's own reference error.
fn neighbour_weights(var: &RgbImage, reference: &RgbImage) -> Vec<f64> {
    let (w, h) = (var.width, var.height);
    let mut out = vec![0.0; 3 * w * h];
    for y in 0..h {
        for x in 0..w {
            for c in 0..3 {
                let (mut sum, mut rounding, mut n) = (0.0, 0.0, 0usize);
                for ny in y.saturating_sub(1)..(y + 2).min(h) {
                    for nx in x.saturating_sub(1)..(x + 2).min(w) {
                        if (nx, ny) == (x, y) {
                            continue;
                        }
                        let i = 3 * (ny * w + nx) + c;
                        let r = reference.data[i] as f64;
                        sum += var.data[i] as f64;
                        rounding += super::ztest::rounding_variance(r, r);
                        n += 1;
                    }
                }
                if n > 0 && sum > 0.0 {
                    out[3 * (y * w + x) + c] = (n as f64 / (sum + rounding)).sqrt();
                }
            }
        }
    }
    out
}

/// The bias test's statistic (threshold and verdict are set by the caller).
fn bias_test(test: &RgbImage, reference: &RgbImage, var: &RgbImage, relative: bool) -> BiasTest {
    let n = (test.width * test.height).max(1);
    let weights = if relative {
        vec![1.0; 3 * n]
    } else {
        neighbour_weights(var, reference)
    };
    let mut u = Vec::with_capacity(n);
    // The mean of u that float rounding alone can make (a floor under its standard error).
    let mut rounding = 0.0;
    for p in 0..n {
        let mut acc = 0.0;
        for c in 0..3 {
            let i = 3 * p + c;
            let (t, r) = (test.data[i] as f64, reference.data[i] as f64);
            if !t.is_finite() {
                continue;
            }
            let w = weights[i];
            acc += w * (t - r);
            rounding += w * super::ztest::rounding_variance(t, r).sqrt() / 3.0;
        }
        u.push(acc / 3.0);
    }
    let m = u.len().max(1) as f64;
    let mean = u.iter().sum::<f64>() / m;
    let var_u = u.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (m - 1.0).max(1.0);
    let rounding = rounding / m;
    let stderr = (var_u / m + rounding * rounding).sqrt();
    let z = if stderr > 0.0 {
        mean / stderr
    } else if mean == 0.0 {
        0.0
    } else {
        f64::INFINITY.copysign(mean)
    };
    BiasTest {
        weights: if relative {
            "uniform"
        } else {
            "1/sigma of the 8 neighbours"
        },
        pixels: u.len(),
        mean,
        stderr,
        z,
        threshold: f64::INFINITY,
        failed: false,
    }
}

/// The calibrated verdict of `test` against `reference` under `noise` (see the module docs).
pub fn verdict(
    test: &RgbImage,
    reference: &RgbImage,
    noise: &NoiseModel,
    cal: &Calibration,
) -> Result<Verdict> {
    check_same_size(test, reference, "test vs reference")?;
    if !(cal.alpha > 0.0 && cal.alpha < 1.0) {
        return Err(Error::Invalid(format!(
            "alpha {} must be in (0, 1)",
            cal.alpha
        )));
    }
    let var = pixel_variance(noise, cal.sample_variance_floor)?;
    check_same_size(test, &var, "test vs variance")?;
    let estimated = matches!(noise.test, Some(TestNoise::Estimated(_)));
    let side = test.width.min(test.height).max(1);
    let mut sides: Vec<usize> = cal
        .scales
        .iter()
        .copied()
        .filter(|&b| b >= 1 && b <= side)
        .collect();
    if sides.is_empty() {
        sides.push(side);
    }
    sides.sort_unstable();
    sides.dedup();
    let tests = sides.len() + 1;
    // A zero variance estimated from the test's own few samples says only that they agreed.
    let zero_var_tol = if estimated {
        ESTIMATED_ZERO_TOLERANCE
    } else {
        1e-5
    };
    let a = cal.alpha / tests as f64;
    let mut all = sides.clone();
    if !all.contains(&1) {
        all.insert(0, 1);
    }
    let mut scales = Vec::with_capacity(all.len());
    for &b in &all {
        let in_verdict = sides.contains(&b);
        let two_sided = if estimated {
            cal.two_sided_block_estimated
        } else {
            cal.two_sided_block
        };
        let tails = if b >= two_sided.min(side) {
            Tails::Both
        } else if estimated {
            Tails::Upper
        } else {
            Tails::Lower
        };
        let t = z_test_with_tolerance(test, reference, &var, b, a, zero_var_tol)?;
        scales.push(ScaleTest {
            in_verdict,
            tails,
            failing_counted: failing_cells(&t, tails),
            note: (!in_verdict).then(|| "not one of the verdict's scales".to_string()),
            test: t,
        });
    }
    let mut bias = bias_test(test, reference, &var, estimated);
    bias.threshold = normal_isf(0.5 * a);
    bias.failed = !(bias.z.abs() <= bias.threshold);
    let mut failures = Vec::new();
    for s in scales
        .iter()
        .filter(|s| s.in_verdict && s.failing_counted > 0)
    {
        let t = &s.test;
        let what = if t.block == 1 {
            "pixels".to_string()
        } else {
            format!("{b}×{b} blocks", b = t.block)
        };
        failures.push(format!(
            "{} of {} {what} fail the z-test ({}, threshold {:.2}); worst {}",
            s.failing_counted,
            t.cells,
            s.tails.words(),
            t.threshold,
            t.worst_summary(3)
        ));
    }
    if bias.failed {
        failures.push(format!(
            "global bias: the weighted mean difference is {:+.1} standard errors (limit ±{:.2}; mean luminance ratio {:.5})",
            bias.z,
            bias.threshold,
            super::mean_luminance_ratio(test, reference)?
        ));
    }
    let noise_words = match noise.test {
        Some(TestNoise::Predicted { spp, .. }) => {
            format!("test variance predicted from the reference's per-sample variance at {spp} spp")
        }
        Some(TestNoise::Estimated(_)) => "test variance estimated by the test render".to_string(),
        None => "reference variance only".to_string(),
    } + if noise.reference.is_some() {
        " + the reference's variance of its mean"
    } else {
        ""
    };
    Ok(Verdict {
        noise: noise_words,
        estimated,
        alpha: cal.alpha,
        tests_in_verdict: tests,
        alpha_per_test: a,
        sample_variance_floor: cal.sample_variance_floor,
        rounding_ulps: super::ztest::ROUNDING_ULPS,
        scales,
        bias,
        passed: failures.is_empty(),
        failures,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Pcg32;

    fn gauss(rng: &mut Pcg32) -> f64 {
        let (u1, u2) = (rng.next_f32().max(1e-7) as f64, rng.next_f32() as f64);
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    fn flat(w: usize, h: usize, v: f32) -> RgbImage {
        RgbImage {
            width: w,
            height: h,
            data: vec![v; 3 * w * h],
        }
    }

    /// A per-sample distribution with a known mean and variance.
    #[derive(Clone, Copy)]
    enum Samples {
        /// N(mean, sd²).
        Gauss { mean: f64, sd: f64 },
        /// `v` with probability `p`, else `base` (a caustic: rare bright paths).
        Rare { base: f64, v: f64, p: f64 },
        /// `v` with probability `p`, else N(`base`, `sd`²): rarer paths over a noisy background.
        NoisyRare { base: f64, sd: f64, v: f64, p: f64 },
    }

    impl Samples {
        fn mean(self) -> f64 {
            match self {
                Samples::Gauss { mean, .. } => mean,
                Samples::Rare { base, v, p } => base + p * (v - base),
                Samples::NoisyRare { base, v, p, .. } => base + p * (v - base),
            }
        }
        fn var(self) -> f64 {
            match self {
                Samples::Gauss { sd, .. } => sd * sd,
                Samples::Rare { base, v, p } => p * (1.0 - p) * (v - base) * (v - base),
                Samples::NoisyRare { base, sd, v, p } => {
                    (1.0 - p) * sd * sd + p * (1.0 - p) * (v - base) * (v - base)
                }
            }
        }
        fn draw(self, rng: &mut Pcg32) -> f64 {
            match self {
                Samples::Gauss { mean, sd } => mean + sd * gauss(rng),
                Samples::Rare { base, v, p } => {
                    if (rng.next_f32() as f64) < p {
                        v
                    } else {
                        base
                    }
                }
                Samples::NoisyRare { base, sd, v, p } => {
                    if (rng.next_f32() as f64) < p {
                        v
                    } else {
                        base + sd * gauss(rng)
                    }
                }
            }
        }
    }

    /// A test render of `spp` samples per pixel scaled by `gain`: its mean and its own estimate
    /// of the variance of its mean.
    fn render(
        w: usize,
        h: usize,
        s: Samples,
        spp: u32,
        gain: f64,
        rng: &mut Pcg32,
    ) -> (RgbImage, RgbImage) {
        let (mut m, mut v) = (flat(w, h, 0.0), flat(w, h, 0.0));
        for i in 0..3 * w * h {
            let (mut a, mut a2) = (0.0, 0.0);
            for _ in 0..spp {
                let x = gain * s.draw(rng);
                a += x;
                a2 += x * x;
            }
            let n = spp as f64;
            let mean = a / n;
            m.data[i] = mean as f32;
            v.data[i] = ((a2 / n - mean * mean).max(0.0) * n / (n - 1.0) / n) as f32;
        }
        (m, v)
    }

    /// Fraction of `trials` renders of `s` (scaled by `gain`) that fail against the exact mean.
    fn failure_rate(s: Samples, gain: f64, estimated: bool, cal: &Calibration, seed: u64) -> f64 {
        let (w, h, spp, trials) = (32, 32, 64, 60);
        let reference = flat(w, h, s.mean() as f32);
        let sample_var = flat(w, h, s.var() as f32);
        let mut rng = Pcg32::new(seed, 7);
        let mut failed = 0;
        for _ in 0..trials {
            let (t, tv) = render(w, h, s, spp, gain, &mut rng);
            let noise = NoiseModel {
                test: Some(if estimated {
                    TestNoise::Estimated(&tv)
                } else {
                    TestNoise::Predicted {
                        sample_var: &sample_var,
                        spp,
                    }
                }),
                reference: None,
            };
            failed += !verdict(&t, &reference, &noise, cal).unwrap().passed as usize;
        }
        failed as f64 / trials as f64
    }

    fn at(alpha: f64, scales: &[usize]) -> Calibration {
        Calibration {
            alpha,
            scales: scales.to_vec(),
            sample_variance_floor: 0.0,
            ..Default::default()
        }
    }

    #[test]
    fn gaussian_noise_fails_near_the_nominal_rate() {
        // At α = 0.2 over 60 renders: about 12 false alarms expected (Bonferroni over the scales
        // makes the rate a little lower); 3..=20 holds with probability > 99.9 %.
        let g = Samples::Gauss { mean: 0.5, sd: 0.2 };
        for scales in [&[1usize, 4, 8, 16][..], &[4, 8, 16, 32]] {
            let r = failure_rate(g, 1.0, false, &at(0.2, scales), 11);
            assert!((0.05..=0.34).contains(&r), "scales {scales:?}: rate {r}");
        }
    }

    /// 1 sample in 200 is 100× brighter: at 64 spp most pixels saw none, a few saw one.
    const RARE: Samples = Samples::Rare {
        base: 0.1,
        v: 10.0,
        p: 0.005,
    };

    #[test]
    fn rare_bright_samples_fail_two_sided_fine_scales_but_not_the_verdict() {
        for estimated in [false, true] {
            // Both tails on every scale, single pixels included: most correct renders fail.
            let naive = Calibration {
                two_sided_block: 1,
                two_sided_block_estimated: 1,
                ..at(0.01, &[1, 4, 8, 16, 32])
            };
            let r = failure_rate(RARE, 1.0, estimated, &naive, 12);
            assert!(r > 0.5, "estimated {estimated}: two-sided rate {r}");
            // Each fine scale on the tail its noise bounds: at most α plus sampling error.
            let tails = at(0.01, &[1, 4, 8, 16, 32]);
            let r = failure_rate(RARE, 1.0, estimated, &tails, 13);
            assert!(r <= 0.05, "estimated {estimated}: rate {r}");
        }
    }

    #[test]
    fn an_estimated_variance_tests_the_darker_tail_only_on_blocks_with_enough_samples() {
        // 1 sample in 3,300 carries 8 % of the mean: a 16×16 block (16 k samples at 64 spp)
        // sees about 5 such paths, and one that saw 0 or 1 underestimates both its mean and its
        // variance (z well below −3); 32×32 blocks see about 20.
        let s = Samples::NoisyRare {
            base: 0.1,
            sd: 0.05,
            v: 30.0,
            p: 3e-4,
        };
        let old = Calibration {
            two_sided_block_estimated: 16,
            ..at(0.01, &[4, 8, 16, 32])
        };
        let r = failure_rate(s, 1.0, true, &old, 21);
        assert!(r > 0.15, "two-sided 16 px blocks: rate {r}");
        let r = failure_rate(s, 1.0, true, &Calibration::default(), 22);
        assert!(r <= 0.05, "default: rate {r}");
        // With the reference's per-sample variance the same render passes as well.
        let r = failure_rate(s, 1.0, false, &Calibration::default(), 23);
        assert!(r <= 0.05, "predicted: rate {r}");
    }

    #[test]
    fn a_one_percent_shift_is_found() {
        // Per pixel the shift is 0.025 σ of the mean; over the 32×32 image it is 2.4 standard errors
        // per channel, found by the global bias test almost always at 2 %.
        let g = Samples::Gauss { mean: 0.5, sd: 0.5 };
        let cal = Calibration::default();
        assert_eq!(failure_rate(g, 1.02, false, &cal, 16), 1.0);
        // The rare-path pixels are 59 % noise each: a 10 % shift is ~9 standard errors.
        assert!(failure_rate(RARE, 1.1, false, &cal, 17) >= 0.95);
        assert!(failure_rate(RARE, 1.1, true, &cal, 18) >= 0.95);
        // Darker by 3 % of one 8×8 corner only: the lower tail of the fine scales finds it.
        let g = Samples::Gauss {
            mean: 0.5,
            sd: 0.05,
        };
        let (w, h) = (32, 32);
        let reference = flat(w, h, 0.5);
        let sv = flat(w, h, 0.0025);
        let mut rng = Pcg32::new(19, 7);
        for _ in 0..10 {
            let (mut t, _) = render(w, h, g, 64, 1.0, &mut rng);
            for y in 0..8 {
                for x in 0..8 {
                    let p = t.get(x, y);
                    t.set(x, y, p.map(|v| v * 0.97));
                }
            }
            let noise = NoiseModel {
                test: Some(TestNoise::Predicted {
                    sample_var: &sv,
                    spp: 64,
                }),
                reference: None,
            };
            assert!(!verdict(&t, &reference, &noise, &cal).unwrap().passed);
        }
    }

    #[test]
    fn a_reference_whose_variance_comes_from_its_own_skewed_samples_passes_correct_renders() {
        // 1 sample in 50 is 40× brighter (skewness 6.9). The reference averages 256 samples and
        // estimates its per-sample variance from the same samples: where it caught more bright
        // samples than expected, both its mean and its variance are high. Weights of 1/σ taken from
        // the pixel's own variance then favour the pixels whose reference is low, and correct
        // 64-spp renders fail the bias test (mean z ≈ +6 here).
        let s = Samples::Rare {
            base: 0.1,
            v: 4.0,
            p: 0.02,
        };
        let (w, h, n, spp, trials) = (32, 32, 256, 64, 40);
        let mut rng = Pcg32::new(23, 7);
        let (reference, var_of_mean) = render(w, h, s, n, 1.0, &mut rng);
        let mut sample_var = var_of_mean.clone();
        for v in &mut sample_var.data {
            *v *= n as f32;
        }
        let noise = NoiseModel {
            test: Some(TestNoise::Predicted {
                sample_var: &sample_var,
                spp,
            }),
            reference: Some(&var_of_mean),
        };
        let cal = Calibration::default();
        let (mut failed, mut z_sum) = (0, 0.0);
        for _ in 0..trials {
            let (t, _) = render(w, h, s, spp, 1.0, &mut rng);
            let v = verdict(&t, &reference, &noise, &cal).unwrap();
            failed += !v.passed as usize;
            z_sum += v.bias.z;
        }
        let mean_z = z_sum / trials as f64;
        // α = 0.01: 2 of 40 is already unlikely (6 %); the reference's own error moves every
        // trial's z together by about one standard error.
        assert!(
            failed <= 2,
            "{failed} of {trials} correct renders failed, mean bias z {mean_z:+.2}"
        );
        assert!(mean_z.abs() < 2.0, "mean bias z {mean_z:+.2}");
    }

    #[test]
    fn float_rounding_alone_passes() {
        let r = RgbImage {
            width: 8,
            height: 8,
            data: (0..192).map(|i| 0.05 + 0.01 * (i % 13) as f32).collect(),
        };
        let mut t = r.clone();
        for v in &mut t.data {
            *v = f32::from_bits(v.to_bits() + 1);
        }
        let tiny = flat(8, 8, 1e-18);
        let noise = NoiseModel {
            test: Some(TestNoise::Estimated(&tiny)),
            reference: Some(&tiny),
        };
        let v = verdict(&t, &r, &noise, &Calibration::default()).unwrap();
        assert!(v.passed, "{}", v.report());
        // Four ulps apart is still within 1σ of the floor; 1e-4 relative is not.
        for v in &mut t.data {
            *v *= 1.0 + 1e-4;
        }
        assert!(
            !verdict(&t, &r, &noise, &Calibration::default())
                .unwrap()
                .passed
        );
    }

    #[test]
    fn verdict_lists_scales_and_rejects_bad_input() {
        let r = flat(20, 12, 0.5);
        let sv = flat(20, 12, 0.01);
        let noise = NoiseModel {
            test: Some(TestNoise::Predicted {
                sample_var: &sv,
                spp: 16,
            }),
            reference: None,
        };
        let v = verdict(&r, &r, &noise, &Calibration::default()).unwrap();
        // 16 and 32 are larger than the 12-pixel side: dropped; the per-pixel test comes first.
        let sides: Vec<usize> = v.scales.iter().map(|s| s.test.block).collect();
        assert_eq!(sides, vec![1, 4, 8]);
        assert!(!v.scales[0].in_verdict && v.scales[1].in_verdict);
        assert_eq!(v.scales[1].tails, Tails::Lower);
        assert_eq!(v.tests_in_verdict, 3);
        assert!(v.passed && v.report().contains("global bias"));
        assert!(verdict(&r, &r, &NoiseModel::default(), &Calibration::default()).is_err());
        let bad = Calibration {
            alpha: 1.0,
            ..Default::default()
        };
        assert!(verdict(&r, &r, &noise, &bad).is_err());
        let zero = NoiseModel {
            test: Some(TestNoise::Predicted {
                sample_var: &sv,
                spp: 0,
            }),
            reference: None,
        };
        assert!(verdict(&r, &r, &zero, &Calibration::default()).is_err());
    }
}
