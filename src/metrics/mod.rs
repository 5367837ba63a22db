//! Image metrics for validating renders against a reference: MAE, RMSE, relMSE, mean luminance
//! ratio, per-pixel and per-block z-tests with the reference's variance, and false-colour
//! difference images. The same code backs `btfpt compare` and the image regression tests.
//!
//! The z-test follows `reference-images/compare.py`: for a test render at n spp against a
//! high-spp reference, z = (test − ref) / sqrt(sample_var_ref / n + var_ref) per pixel and channel,
//! two-sided, Šidák-corrected at α over pixels · 3 tests. Channels whose variance is 0 (directly
//! seen emitters, background) must agree to 1e-5 relative instead.

pub mod calibrated;
pub mod compare_files;
pub mod diff;
pub mod normal;
pub mod ztest;

pub use calibrated::{Calibration, NoiseModel, TestNoise, Verdict, verdict};
pub use diff::{relative_diff_image, with_legend, z_diff_image};
pub use ztest::{Outlier, ZTest, block_mean, predicted_variance, z_test};

use crate::io::RgbImage;
use crate::math::Vec3;
use crate::math::color::luminance;
use crate::{Error, Result};
use serde::Serialize;

/// True unless `v ≤ max` (so NaN exceeds every bound).
fn exceeds(v: f64, max: f64) -> bool {
    v.is_nan() || v > max
}

/// The ε in relMSE = mean((t − r)² / (r² + ε)), as `compare.py` (keeps dark pixels from dominating).
pub const RELMSE_EPS: f64 = 1e-2;

/// Fails unless `a` and `b` have the same size; `what` names the two images in the message.
pub fn check_same_size(a: &RgbImage, b: &RgbImage, what: &str) -> Result<()> {
    if a.width != b.width || a.height != b.height || a.data.len() != b.data.len() {
        return Err(Error::Invalid(format!(
            "{what}: image sizes differ ({}×{} vs {}×{})",
            a.width, a.height, b.width, b.height
        )));
    }
    Ok(())
}

/// The first non-finite value as (column, row, channel), if any.
pub fn first_nonfinite(img: &RgbImage) -> Option<(usize, usize, usize)> {
    let i = img.data.iter().position(|v| !v.is_finite())?;
    let p = i / 3;
    Some((p % img.width.max(1), p / img.width.max(1), i % 3))
}

/// Mean absolute difference over all pixels and channels (radiance units).
pub fn mae(test: &RgbImage, reference: &RgbImage) -> Result<f64> {
    check_same_size(test, reference, "MAE")?;
    let s: f64 = test
        .data
        .iter()
        .zip(&reference.data)
        .map(|(&t, &r)| (t as f64 - r as f64).abs())
        .sum();
    Ok(s / test.data.len().max(1) as f64)
}

/// Root mean squared difference over all pixels and channels (radiance units).
pub fn rmse(test: &RgbImage, reference: &RgbImage) -> Result<f64> {
    check_same_size(test, reference, "RMSE")?;
    let s: f64 = test
        .data
        .iter()
        .zip(&reference.data)
        .map(|(&t, &r)| (t as f64 - r as f64).powi(2))
        .sum();
    Ok((s / test.data.len().max(1) as f64).sqrt())
}

/// Relative MSE, mean((t − r)² / (r² + [`RELMSE_EPS`])) over all pixels and channels (unitless).
pub fn relmse(test: &RgbImage, reference: &RgbImage) -> Result<f64> {
    check_same_size(test, reference, "relMSE")?;
    let s: f64 = test
        .data
        .iter()
        .zip(&reference.data)
        .map(|(&t, &r)| {
            let (t, r) = (t as f64, r as f64);
            (t - r).powi(2) / (r * r + RELMSE_EPS)
        })
        .sum();
    Ok(s / test.data.len().max(1) as f64)
}

/// Mean Rec.709 luminance of `img` (radiance units).
pub fn mean_luminance(img: &RgbImage) -> f64 {
    let s: f64 = img
        .data
        .chunks_exact(3)
        .map(|p| luminance(Vec3::new(p[0], p[1], p[2])) as f64)
        .sum();
    s / (img.width * img.height).max(1) as f64
}

/// Mean luminance of `test` over that of `reference` (1 = same overall brightness; NaN when the
/// reference is black).
pub fn mean_luminance_ratio(test: &RgbImage, reference: &RgbImage) -> Result<f64> {
    check_same_size(test, reference, "mean luminance ratio")?;
    let r = mean_luminance(reference);
    Ok(if r > 0.0 {
        mean_luminance(test) / r
    } else {
        f64::NAN
    })
}

/// Everything `btfpt compare` reports about a test image against a reference.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    pub width: usize,
    pub height: usize,
    pub mae: f64,
    pub rmse: f64,
    pub relmse: f64,
    pub mean_luminance_ratio: f64,
    /// Per-pixel z-test (present when a variance was given).
    pub pixel_test: Option<ZTest>,
    /// The same test on b×b block means (present when a variance was given).
    pub block_test: Option<ZTest>,
    /// The calibrated verdict (present when made by [`Comparison::calibrated`]).
    pub calibrated: Option<Verdict>,
}

/// Pass/fail bounds on a [`Comparison`]; `None` = not checked.
#[derive(Clone, Copy, Debug, Default)]
pub struct Criteria {
    /// Most pixels allowed to fail the per-pixel z-test.
    pub max_failing_pixels: Option<usize>,
    /// Most blocks allowed to fail the block z-test.
    pub max_failing_blocks: Option<usize>,
    /// Bound on |mean z| of the per-pixel test (a global bias detector).
    pub max_abs_mean_z: Option<f64>,
    /// Bound on relMSE.
    pub max_relmse: Option<f64>,
}

impl Comparison {
    /// Compares `test` with `reference`; `variance` is the variance of (test − reference) per pixel
    /// and channel (see [`predicted_variance`]); `block` is the side of the block test.
    pub fn new(
        test: &RgbImage,
        reference: &RgbImage,
        variance: Option<&RgbImage>,
        block: usize,
        alpha: f64,
    ) -> Result<Comparison> {
        check_same_size(test, reference, "test vs reference")?;
        let (pixel_test, block_test) = match variance {
            Some(v) => (
                Some(z_test(test, reference, v, 1, alpha)?),
                Some(z_test(test, reference, v, block, alpha)?),
            ),
            None => (None, None),
        };
        Ok(Comparison {
            width: test.width,
            height: test.height,
            mae: mae(test, reference)?,
            rmse: rmse(test, reference)?,
            relmse: relmse(test, reference)?,
            mean_luminance_ratio: mean_luminance_ratio(test, reference)?,
            pixel_test,
            block_test,
            calibrated: None,
        })
    }

    /// Compares `test` with `reference` and makes the calibrated verdict under `noise`;
    /// `pixel_test` is the verdict's per-pixel test and `block_test` its 4×4 (or finest) scale.
    pub fn calibrated(
        test: &RgbImage,
        reference: &RgbImage,
        noise: &NoiseModel,
        cal: &Calibration,
    ) -> Result<Comparison> {
        let mut c = Comparison::new(test, reference, None, 1, cal.alpha)?;
        let v = verdict(test, reference, noise, cal)?;
        c.pixel_test = Some(v.pixel_test().clone());
        c.block_test = v
            .scales
            .iter()
            .find(|s| s.test.block == 4)
            .or_else(|| v.scales.get(1))
            .map(|s| s.test.clone());
        c.calibrated = Some(v);
        Ok(c)
    }

    /// The reasons the comparison fails `c` (empty = pass). A bound that needs a z-test fails
    /// when no variance was given.
    pub fn failures(&self, c: &Criteria) -> Vec<String> {
        let mut out = Vec::new();
        let need = |t: &Option<ZTest>, what: &str, out: &mut Vec<String>| {
            if t.is_none() {
                out.push(format!("{what} needs a variance image, none given"));
            }
        };
        if let Some(max) = c.max_failing_pixels {
            need(&self.pixel_test, "the per-pixel z-test", &mut out);
            if let Some(t) = &self.pixel_test
                && t.failing > max
            {
                out.push(format!(
                    "{} of {} pixels fail the z-test (|z| > {:.2}; allowed {max}); worst {}",
                    t.failing,
                    t.cells,
                    t.threshold,
                    t.worst_summary(3)
                ));
            }
        }
        if let Some(max) = c.max_failing_blocks {
            need(&self.block_test, "the block z-test", &mut out);
            if let Some(t) = &self.block_test
                && t.failing > max
            {
                out.push(format!(
                    "{} of {} {b}×{b} blocks fail the z-test (|z| > {:.2}; allowed {max}); worst {}",
                    t.failing,
                    t.cells,
                    t.threshold,
                    t.worst_summary(3),
                    b = t.block
                ));
            }
        }
        if let Some(max) = c.max_abs_mean_z {
            need(&self.pixel_test, "the mean-z bound", &mut out);
            if let Some(t) = &self.pixel_test
                && exceeds(t.mean_z.abs(), max)
            {
                out.push(format!(
                    "mean z {:+.4} (± {:.4} if unbiased) is outside ±{max}: a global bias",
                    t.mean_z, t.mean_z_stderr
                ));
            }
        }
        if let Some(v) = &self.calibrated {
            out.extend(v.failures.iter().cloned());
        }
        if let Some(max) = c.max_relmse
            && exceeds(self.relmse, max)
        {
            out.push(format!("relMSE {:.3e} exceeds {max:.3e}", self.relmse));
        }
        out
    }

    /// A few human-readable lines.
    pub fn report(&self) -> String {
        let mut s = format!(
            "{}×{}: MAE {:.4e}, RMSE {:.4e}, relMSE {:.4e}, mean luminance ratio {:.5}",
            self.width, self.height, self.mae, self.rmse, self.relmse, self.mean_luminance_ratio
        );
        if let Some(v) = &self.calibrated {
            s.push('\n');
            s.push_str(&v.report());
            return s;
        }
        for t in [&self.pixel_test, &self.block_test].into_iter().flatten() {
            s.push('\n');
            s.push_str(&t.summary());
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(w: usize, h: usize, f: impl Fn(usize) -> f32) -> RgbImage {
        RgbImage {
            width: w,
            height: h,
            data: (0..3 * w * h).map(f).collect(),
        }
    }

    #[test]
    fn error_metrics_by_hand() {
        let r = img(2, 1, |i| [1.0, 2.0, 3.0, 0.0, 0.0, 0.0][i]);
        let t = img(2, 1, |i| [2.0, 2.0, 1.0, 0.0, 0.5, 0.0][i]);
        assert!((mae(&t, &r).unwrap() - 3.5 / 6.0).abs() < 1e-12);
        assert!((rmse(&t, &r).unwrap() - (5.25f64 / 6.0).sqrt()).abs() < 1e-12);
        let want = (1.0 / 1.01 + 4.0 / 9.01 + 0.25 / 0.01) / 6.0;
        assert!((relmse(&t, &r).unwrap() - want).abs() < 1e-9);
        assert_eq!(mae(&r, &r).unwrap(), 0.0);
        assert_eq!(relmse(&r, &r).unwrap(), 0.0);
    }

    #[test]
    fn luminance_ratio_detects_a_scale() {
        let r = img(4, 3, |i| 0.1 + (i % 7) as f32 * 0.05);
        let t = img(4, 3, |i| 1.02 * (0.1 + (i % 7) as f32 * 0.05));
        let q = mean_luminance_ratio(&t, &r).unwrap();
        assert!((q - 1.02).abs() < 1e-6, "{q}");
        assert!(
            mean_luminance_ratio(&t, &img(4, 3, |_| 0.0))
                .unwrap()
                .is_nan()
        );
        // Pure green has luminance 0.71516.
        let g = img(1, 1, |i| if i == 1 { 1.0 } else { 0.0 });
        assert!((mean_luminance(&g) - 0.71516).abs() < 1e-6);
    }

    #[test]
    fn size_mismatch_and_nonfinite_are_reported() {
        let a = img(2, 2, |_| 1.0);
        let b = img(2, 3, |_| 1.0);
        let e = mae(&a, &b).unwrap_err().to_string();
        assert!(e.contains("2×2 vs 2×3"), "{e}");
        assert!(Comparison::new(&a, &b, None, 4, 0.01).is_err());
        let mut c = img(3, 2, |_| 1.0);
        assert_eq!(first_nonfinite(&c), None);
        c.data[3 * 4 + 2] = f32::NAN;
        assert_eq!(first_nonfinite(&c), Some((1, 1, 2)));
    }

    #[test]
    fn criteria_pass_and_fail() {
        let r = img(8, 8, |i| 0.5 + 0.01 * (i % 5) as f32);
        let v = img(8, 8, |_| 1e-4);
        let same = Comparison::new(&r, &r, Some(&v), 4, 0.01).unwrap();
        let strict = Criteria {
            max_failing_pixels: Some(0),
            max_failing_blocks: Some(0),
            max_abs_mean_z: Some(0.1),
            max_relmse: Some(1e-6),
        };
        assert!(same.failures(&strict).is_empty());
        // +0.02 everywhere: z = 2 per pixel (passes per pixel), 8 per 4×4 block, mean z 2.
        let t = img(8, 8, |i| r.data[i] + 0.02);
        let c = Comparison::new(&t, &r, Some(&v), 4, 0.01).unwrap();
        let f = c.failures(&strict);
        assert_eq!(f.len(), 3, "{f:?}");
        assert!(f[0].contains("4 of 4 4×4 blocks"), "{f:?}");
        assert!(f[1].contains("mean z +2.0000"), "{f:?}");
        assert!(f[2].contains("relMSE"), "{f:?}");
        // Without a variance, z bounds cannot be checked and say so.
        let nov = Comparison::new(&t, &r, None, 4, 0.01).unwrap();
        let f = nov.failures(&Criteria {
            max_failing_pixels: Some(0),
            ..Default::default()
        });
        assert!(f[0].contains("needs a variance"), "{f:?}");
        assert!(nov.report().contains("relMSE"));
    }
}
