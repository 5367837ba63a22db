//! Per-pixel and per-block z-tests of a test render against a reference with known variance.

use super::check_same_size;
use super::normal::sidak_threshold;
use crate::io::RgbImage;
use crate::{Error, Result};
use serde::Serialize;

/// Number of worst cells kept in [`ZTest::worst`].
const WORST: usize = 8;

/// Standard deviation, in units of one f32 ulp of the larger of test and reference, added to
/// every cell with a nonzero variance: two renders that differ only by float rounding (a merge
/// of partial renders, another summation order) are equal within the test.
pub const ROUNDING_ULPS: f64 = 4.0;

/// The variance floor of [`ROUNDING_ULPS`] for a cell whose values are `t` and `r`.
pub fn rounding_variance(t: f64, r: f64) -> f64 {
    let s = ROUNDING_ULPS * f64::from(f32::EPSILON) * 0.5 * t.abs().max(r.abs());
    s * s
}

/// One of the most deviating cells (pixel or block) of a z-test.
#[derive(Clone, Debug, Serialize)]
pub struct Outlier {
    /// Cell column and row (pixel = cell · block).
    pub x: usize,
    pub y: usize,
    pub channel: usize,
    /// z, or ±∞ for a zero-variance channel that differs, NaN for a non-finite test value.
    pub z: f64,
    pub test: f64,
    pub reference: f64,
    /// Standard deviation of (test − reference) predicted from the variance.
    pub sigma: f64,
}

/// The result of a z-test over cells (pixels, or b×b block means) and the 3 channels.
#[derive(Clone, Debug, Serialize)]
pub struct ZTest {
    /// Block side in pixels (1 = per-pixel test).
    pub block: usize,
    pub cells_x: usize,
    pub cells_y: usize,
    /// cells_x · cells_y.
    pub cells: usize,
    /// Family-wise significance level.
    pub alpha: f64,
    /// Two-sided |z| threshold, Šidák-corrected over cells · 3 tests.
    pub threshold: f64,
    /// Cells with at least one failing channel (|z| over threshold, zero-variance mismatch, or
    /// non-finite test value).
    pub failing: usize,
    /// Channels whose variance is 0 but whose values differ by more than 1e-5 relative.
    pub exact_mismatches: usize,
    /// Non-finite channel values in the test image.
    pub nonfinite: usize,
    /// Largest finite |z|.
    pub max_abs_z: f64,
    /// Mean of z over all cells and channels (z = 0 where the variance is 0); ≈ N(0, 1/(3·cells))
    /// for an unbiased test image whose variance is predicted correctly.
    pub mean_z: f64,
    /// 1/sqrt(3·cells): the standard error of `mean_z` for an unbiased image.
    pub mean_z_stderr: f64,
    /// Variance of z (≈ 1 when the predicted variance fits the test's).
    pub var_z: f64,
    /// The most deviating cells, worst first.
    pub worst: Vec<Outlier>,
    /// z per cell and channel, row-major like [`RgbImage::data`] (0 where the variance is 0).
    #[serde(skip)]
    pub z: Vec<f32>,
}

impl ZTest {
    /// True when no cell fails.
    pub fn passed(&self) -> bool {
        self.failing == 0
    }

    /// The first `n` outliers as "(x, y, c) z=…" (pixel coordinates).
    pub fn worst_summary(&self, n: usize) -> String {
        let v: Vec<String> = self
            .worst
            .iter()
            .take(n)
            .map(|o| {
                format!(
                    "px ({}, {}) ch {} z {:+.2} (test {:.4e}, ref {:.4e})",
                    o.x * self.block,
                    o.y * self.block,
                    o.channel,
                    o.z,
                    o.test,
                    o.reference
                )
            })
            .collect();
        if v.is_empty() {
            "-".into()
        } else {
            v.join("; ")
        }
    }

    /// One line: what failed and the z statistics.
    pub fn summary(&self) -> String {
        let what = if self.block == 1 {
            "pixels".to_string()
        } else {
            format!("{b}×{b} blocks", b = self.block)
        };
        format!(
            "z-test on {} {what}: {} failing (|z| > {:.3}, α = {} Šidák){}{}, max |z| {:.2}, mean z {:+.4} (± {:.4} if unbiased), var(z) {:.3}",
            self.cells,
            self.failing,
            self.threshold,
            self.alpha,
            if self.exact_mismatches > 0 {
                format!(", {} zero-variance mismatches", self.exact_mismatches)
            } else {
                String::new()
            },
            if self.nonfinite > 0 {
                format!(", {} non-finite values", self.nonfinite)
            } else {
                String::new()
            },
            self.max_abs_z,
            self.mean_z,
            self.mean_z_stderr,
            self.var_z
        )
    }
}

/// Means over b×b blocks; partial blocks at the right and bottom edges are dropped (as
/// `calibrate.py`).
pub fn block_mean(img: &RgbImage, b: usize) -> RgbImage {
    let b = b.max(1);
    let (w, h) = (img.width / b, img.height / b);
    let mut out = RgbImage::new(w, h);
    let inv = 1.0 / (b * b) as f64;
    for by in 0..h {
        for bx in 0..w {
            let mut acc = [0.0f64; 3];
            for y in by * b..(by + 1) * b {
                for x in bx * b..(bx + 1) * b {
                    let p = img.get(x, y);
                    for c in 0..3 {
                        acc[c] += p[c] as f64;
                    }
                }
            }
            out.set(bx, by, acc.map(|a| (a * inv) as f32));
        }
    }
    out
}

/// Fails unless every variance in `v` is finite and ≥ 0; `what` names the image.
pub(crate) fn check_variance(v: &RgbImage, what: &str) -> Result<()> {
    if let Some(i) = v.data.iter().position(|x| !(x.is_finite() && *x >= 0.0)) {
        let p = i / 3;
        return Err(Error::Invalid(format!(
            "{what}: invalid variance {} at pixel ({}, {}) channel {} (must be finite and ≥ 0)",
            v.data[i],
            p % v.width.max(1),
            p / v.width.max(1),
            i % 3
        )));
    }
    Ok(())
}

/// The variance of (test − reference) per pixel and channel: the test render's variance of the
/// mean predicted from the reference's per-sample variance, `sample_var / spp`, plus the
/// reference's own variance of the mean `ref_var`. At least one of the two must be given.
pub fn predicted_variance(
    sample_var: Option<&RgbImage>,
    spp: u32,
    ref_var: Option<&RgbImage>,
) -> Result<RgbImage> {
    let mut out = match (sample_var, ref_var) {
        (Some(s), _) => RgbImage::new(s.width, s.height),
        (None, Some(r)) => RgbImage::new(r.width, r.height),
        (None, None) => {
            return Err(Error::Invalid(
                "the z-test needs a sample variance (with spp) or a variance of the mean".into(),
            ));
        }
    };
    if let Some(s) = sample_var {
        if spp == 0 {
            return Err(Error::Invalid(
                "the test render's spp must be at least 1".into(),
            ));
        }
        check_variance(s, "sample variance")?;
        for (o, v) in out.data.iter_mut().zip(&s.data) {
            *o += v / spp as f32;
        }
    }
    if let Some(r) = ref_var {
        check_same_size(&out, r, "sample variance vs variance of the mean")?;
        check_variance(r, "variance of the mean")?;
        for (o, v) in out.data.iter_mut().zip(&r.data) {
            *o += v;
        }
    }
    Ok(out)
}

/// Sort key of an outlier: |z|, with NaN (non-finite test value) ranked like ∞.
fn rank(o: &Outlier) -> f64 {
    if o.z.is_nan() {
        f64::INFINITY
    } else {
        o.z.abs()
    }
}

/// z-test of `test` against `reference` on b×b block means (`block` = 1: per pixel). `variance`
/// is the variance of (test − reference) per pixel and channel ([`predicted_variance`]); pixels
/// are independent, so a block mean's variance is the mean pixel variance / b²; a cell with a
/// nonzero variance also gets the f32 rounding floor [`rounding_variance`]. Cells fail when a
/// channel's |z| exceeds the Šidák threshold at family-wise level `alpha` over cells · 3, when a
/// zero-variance channel differs by more than 1e-5 relative (floor 1e-3), or when the test value is
/// not finite.
pub fn z_test(
    test: &RgbImage,
    reference: &RgbImage,
    variance: &RgbImage,
    block: usize,
    alpha: f64,
) -> Result<ZTest> {
    z_test_with_tolerance(test, reference, variance, block, alpha, 1e-5)
}

/// [`z_test`] with `zero_var_tol` as the relative tolerance of zero-variance cells (1e-5 when
/// the zero is known, looser when it is a low-spp estimate that may have missed the variation).
pub(crate) fn z_test_with_tolerance(
    test: &RgbImage,
    reference: &RgbImage,
    variance: &RgbImage,
    block: usize,
    alpha: f64,
    zero_var_tol: f64,
) -> Result<ZTest> {
    check_same_size(test, reference, "z-test: test vs reference")?;
    check_same_size(test, variance, "z-test: test vs variance")?;
    check_variance(variance, "z-test")?;
    if block == 0 || block > test.width.min(test.height) {
        return Err(Error::Invalid(format!(
            "z-test: block size {block} must be in 1..={}",
            test.width.min(test.height)
        )));
    }
    if !(alpha > 0.0 && alpha < 1.0) {
        return Err(Error::Invalid(format!(
            "z-test: alpha {alpha} must be in (0, 1)"
        )));
    }
    let (t, r, v) = if block == 1 {
        (test.clone(), reference.clone(), variance.clone())
    } else {
        let mut v = block_mean(variance, block);
        let inv = 1.0 / (block * block) as f32;
        v.data.iter_mut().for_each(|x| *x *= inv);
        (block_mean(test, block), block_mean(reference, block), v)
    };
    let cells = t.width * t.height;
    let tests = 3 * cells;
    let threshold = sidak_threshold(alpha, tests);
    let mut z = vec![0.0f32; tests];
    let mut failing = 0;
    let (mut exact, mut nonfinite) = (0, 0);
    let (mut sum, mut sum2, mut max_abs) = (0.0f64, 0.0f64, 0.0f64);
    let mut worst: Vec<Outlier> = Vec::new();
    for cell in 0..cells {
        let mut bad = false;
        for c in 0..3 {
            let i = 3 * cell + c;
            let (tv, rv, var) = (t.data[i] as f64, r.data[i] as f64, v.data[i] as f64);
            let sd = if var > 0.0 {
                (var + rounding_variance(tv, rv)).sqrt()
            } else {
                0.0
            };
            let (zi, fail) = if !tv.is_finite() {
                nonfinite += 1;
                (f64::NAN, true)
            } else if var <= 0.0 {
                let ok = (tv - rv).abs() <= zero_var_tol * rv.abs().max(1e-3);
                if !ok {
                    exact += 1;
                }
                (
                    if ok {
                        0.0
                    } else {
                        f64::INFINITY.copysign(tv - rv)
                    },
                    !ok,
                )
            } else {
                let zi = (tv - rv) / sd;
                (zi, zi.abs() > threshold)
            };
            bad |= fail;
            let zf = if zi.is_finite() { zi } else { 0.0 };
            z[i] = zf as f32;
            sum += zf;
            sum2 += zf * zf;
            max_abs = max_abs.max(zf.abs());
            let key = if zi.is_finite() {
                zi.abs()
            } else {
                f64::INFINITY
            };
            if key > 0.0 && (worst.len() < WORST || worst.last().is_some_and(|o| key > rank(o))) {
                let o = Outlier {
                    x: cell % t.width,
                    y: cell / t.width,
                    channel: c,
                    z: zi,
                    test: tv,
                    reference: rv,
                    sigma: sd,
                };
                let pos = worst.partition_point(|w| rank(w) >= key);
                worst.insert(pos, o);
                worst.truncate(WORST);
            }
        }
        failing += bad as usize;
    }
    let n = tests.max(1) as f64;
    let mean_z = sum / n;
    Ok(ZTest {
        block,
        cells_x: t.width,
        cells_y: t.height,
        cells,
        alpha,
        threshold,
        failing,
        exact_mismatches: exact,
        nonfinite,
        max_abs_z: max_abs,
        mean_z,
        mean_z_stderr: 1.0 / n.sqrt(),
        var_z: sum2 / n - mean_z * mean_z,
        worst,
        z,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Pcg32;

    /// A reference with a smooth gradient, and a test drawn as N(ref, σ²) per channel.
    fn noisy(w: usize, h: usize, sigma: f32, bias: f32, seed: u64) -> (RgbImage, RgbImage) {
        let mut rng = Pcg32::new(seed, 1);
        let r = RgbImage {
            width: w,
            height: h,
            data: (0..3 * w * h)
                .map(|i| 0.2 + (i % 11) as f32 * 0.03)
                .collect(),
        };
        let mut t = r.clone();
        for v in &mut t.data {
            // Box–Muller.
            let (u1, u2) = (rng.next_f32().max(1e-7), rng.next_f32());
            let g = (-2.0 * u1.ln()).sqrt() * (std::f32::consts::TAU * u2).cos();
            *v += bias + sigma * g;
        }
        (t, r)
    }

    fn var(w: usize, h: usize, v: f32) -> RgbImage {
        RgbImage {
            width: w,
            height: h,
            data: vec![v; 3 * w * h],
        }
    }

    #[test]
    fn unbiased_gaussian_noise_passes_with_unit_z_statistics() {
        let (w, h) = (64, 48);
        let (t, r) = noisy(w, h, 0.01, 0.0, 3);
        let v = var(w, h, 1e-4);
        let z = z_test(&t, &r, &v, 1, 0.01).unwrap();
        assert!(z.passed(), "{}", z.summary());
        assert_eq!(z.cells, w * h);
        // mean z ~ N(0, 1/9216): 5 σ bound; var(z) within ±5 % (its stderr is √(2/9216) ≈ 1.5 %).
        assert!(z.mean_z.abs() < 5.0 * z.mean_z_stderr, "{}", z.summary());
        assert!((z.var_z - 1.0).abs() < 0.05, "{}", z.summary());
        let b = z_test(&t, &r, &v, 4, 0.01).unwrap();
        assert!(b.passed(), "{}", b.summary());
        assert_eq!((b.cells_x, b.cells_y), (16, 12));
        // Block means of independent pixels keep unit-variance z.
        assert!((b.var_z - 1.0).abs() < 0.2, "{}", b.summary());
    }

    #[test]
    fn a_small_bias_fails_the_block_test_and_moves_mean_z() {
        let (w, h) = (64, 48);
        // Bias of σ/2: no pixel fails, but mean z moves to 0.5.
        let (t, r) = noisy(w, h, 0.01, 0.005, 4);
        let v = var(w, h, 1e-4);
        let z = z_test(&t, &r, &v, 1, 0.01).unwrap();
        assert!(z.passed(), "{}", z.summary());
        assert!(
            (z.mean_z - 0.5).abs() < 5.0 * z.mean_z_stderr,
            "{}",
            z.summary()
        );
        // Bias of 1.5σ per pixel: 6σ per 4×4 block, beyond the block threshold (≈ 4.4).
        let (t, r) = noisy(w, h, 0.01, 0.015, 5);
        let b = z_test(&t, &r, &v, 4, 0.01).unwrap();
        assert!(b.failing > b.cells / 2, "{}", b.summary());
    }

    #[test]
    fn outliers_zero_variance_and_nonfinite() {
        let (w, h) = (16, 8);
        let (mut t, r) = noisy(w, h, 0.0, 0.0, 1);
        let mut v = var(w, h, 1e-4);
        t.data[3 * (2 * w + 5) + 1] += 0.1; // z = 10 at pixel (5, 2), green
        // Zero variance at pixel (0, 0): exact match required.
        v.data[0..3].fill(0.0);
        t.data[0] = r.data[0] * 1.001;
        t.data[3 * (7 * w + 15) + 2] = f32::NAN;
        let z = z_test(&t, &r, &v, 1, 0.01).unwrap();
        assert_eq!(z.failing, 3, "{}", z.summary());
        assert_eq!(z.exact_mismatches, 1);
        assert_eq!(z.nonfinite, 1);
        assert!((z.max_abs_z - 10.0).abs() < 1e-3);
        // Worst first: NaN and ∞ before the finite z = 10.
        assert!(!z.worst[0].z.is_finite() && !z.worst[1].z.is_finite());
        assert_eq!((z.worst[2].x, z.worst[2].y, z.worst[2].channel), (5, 2, 1));
        assert!(z.summary().contains("3 failing"));
        // A matching zero-variance pixel passes.
        t.data[0] = r.data[0];
        t.data[3 * (7 * w + 15) + 2] = r.data[3 * (7 * w + 15) + 2];
        t.data[3 * (2 * w + 5) + 1] -= 0.1;
        assert!(z_test(&t, &r, &v, 1, 0.01).unwrap().passed());
    }

    #[test]
    fn block_mean_drops_partial_blocks() {
        let img = RgbImage {
            width: 5,
            height: 3,
            data: (0..45).map(|i| (i / 3) as f32).collect(),
        };
        let b = block_mean(&img, 2);
        assert_eq!((b.width, b.height), (2, 1));
        // Block (0, 0) holds pixels 0, 1, 5, 6.
        assert_eq!(b.get(0, 0), [3.0; 3]);
        assert_eq!(b.get(1, 0), [5.0; 3]);
    }

    #[test]
    fn predicted_variance_adds_both_terms_and_rejects_bad_input() {
        let s = var(2, 2, 0.64);
        let r = var(2, 2, 0.01);
        let p = predicted_variance(Some(&s), 64, Some(&r)).unwrap();
        assert!(p.data.iter().all(|&x| (x - 0.02).abs() < 1e-7));
        assert!(predicted_variance(None, 1, None).is_err());
        assert!(predicted_variance(Some(&s), 0, None).is_err());
        assert!(predicted_variance(Some(&s), 4, Some(&var(3, 2, 0.0))).is_err());
        let mut neg = s.clone();
        neg.data[5] = -1.0;
        let e = predicted_variance(Some(&neg), 4, None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("pixel (1, 0) channel 2"), "{e}");
        let t = var(2, 2, 0.0);
        assert!(z_test(&t, &t, &p, 3, 0.01).is_err());
        assert!(z_test(&t, &t, &p, 1, 1.5).is_err());
    }
}
