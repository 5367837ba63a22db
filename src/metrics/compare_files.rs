//! `btfpt compare` as a library call: a test image against a reference, with the variance inputs
//! (`--variance`, `--sample-variance` with `--spp`, `--test-variance`) turned into the noise model
//! of the calibrated test, the optional explicit bounds, the verdict, the difference image, and
//! [`CompareOutcome::json`], the document `compare --json` writes. The CLI and the Python module
//! both call [`compare_files`], so their figures are the same.

use super::calibrated::{Calibration, NoiseModel, TestNoise, pixel_variance};
use super::{Comparison, Criteria, first_nonfinite, relative_diff_image, z_diff_image};
use crate::io::{RgbImage, read_image};
use crate::{Error, Result};
use std::path::{Path, PathBuf};

/// The inputs and options of one comparison (the `btfpt compare` arguments and their defaults).
#[derive(Clone, Debug)]
pub struct CompareFiles {
    /// The image under test.
    pub test: PathBuf,
    /// The reference image.
    pub reference: PathBuf,
    /// The reference's variance of its mean (default with `spp`: REF_var.exr if it exists).
    pub variance: Option<PathBuf>,
    /// The reference's per-sample variance (with `spp`; default REF_sample_var.exr).
    pub sample_variance: Option<PathBuf>,
    /// Samples per pixel of the test render.
    pub spp: Option<u32>,
    /// The test image's own variance of its mean.
    pub test_variance: Option<PathBuf>,
    /// Probability that a correct render fails the calibrated test.
    pub alpha: f64,
    /// Block sides of the calibrated test's scales, in pixels.
    pub scales: Vec<usize>,
    /// Least per-sample variance assumed where the reference's is nonzero (radiance²).
    pub sample_variance_floor: f64,
    /// Side in pixels of the blocks counted by `max_failing_blocks`.
    pub block: usize,
    /// Explicit bounds (`None` = not checked).
    pub max_failing_pixels: Option<usize>,
    pub max_failing_blocks: Option<usize>,
    pub max_abs_mean_z: Option<f64>,
    pub max_relmse: Option<f64>,
}

impl CompareFiles {
    /// `test` against `reference` with the CLI's defaults and no variance input.
    pub fn new(test: impl Into<PathBuf>, reference: impl Into<PathBuf>) -> Self {
        let cal = Calibration::default();
        CompareFiles {
            test: test.into(),
            reference: reference.into(),
            variance: None,
            sample_variance: None,
            spp: None,
            test_variance: None,
            alpha: cal.alpha,
            scales: cal.scales,
            sample_variance_floor: cal.sample_variance_floor,
            block: 4,
            max_failing_pixels: None,
            max_failing_blocks: None,
            max_abs_mean_z: None,
            max_relmse: None,
        }
    }
}

/// What a comparison found.
pub struct CompareOutcome {
    pub test: RgbImage,
    pub reference: RgbImage,
    pub comparison: Comparison,
    pub criteria: Criteria,
    /// The calibrated test's settings, when a variance was given.
    pub calibration: Option<Calibration>,
    /// One sentence per failed criterion.
    pub failures: Vec<String>,
    /// A bound was checked at all (a z-test, or a bound given).
    pub tested: bool,
    /// The variance inputs used, in words.
    pub inputs: Vec<String>,
    /// The sample-variance and reference-variance files used.
    pub sample_variance: Option<PathBuf>,
    pub variance: Option<PathBuf>,
}

/// A false-colour difference image with its legend label and a sentence saying its scale.
pub struct DiffImage {
    pub image: RgbImage,
    pub label: String,
    pub scale: String,
}

/// `dir/stem{suffix}.exr` for `dir/stem.exr`.
fn beside(reference: &Path, suffix: &str) -> PathBuf {
    let stem = reference
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    reference.with_file_name(format!("{stem}{suffix}.exr"))
}

fn load(path: &Path, what: &str) -> Result<RgbImage> {
    let img =
        read_image(path).map_err(|e| Error::Invalid(format!("cannot read the {what}: {e}")))?;
    if let Some((x, y, c)) = first_nonfinite(&img) {
        return Err(Error::format(
            path,
            format!("the {what} has a non-finite value at pixel ({x}, {y}) channel {c}"),
        ));
    }
    Ok(img)
}

fn same_size(a: &RgbImage, b: &RgbImage, pa: &Path, pb: &Path) -> Result<()> {
    if a.width != b.width || a.height != b.height {
        return Err(Error::Invalid(format!(
            "image sizes differ: {} is {}×{}, {} is {}×{}",
            pa.display(),
            a.width,
            a.height,
            pb.display(),
            b.width,
            b.height
        )));
    }
    Ok(())
}

fn check_options(a: &CompareFiles) -> Result<()> {
    let bad = |m: String| Err(Error::Invalid(m));
    if !(a.alpha > 0.0 && a.alpha < 1.0) {
        return bad(format!("--alpha {}: must be in (0, 1)", a.alpha));
    }
    if a.block == 0 {
        return bad("--block must be at least 1".into());
    }
    if a.spp == Some(0) {
        return bad("--spp must be at least 1".into());
    }
    if a.test_variance.is_some() && (a.spp.is_some() || a.sample_variance.is_some()) {
        return bad("--test-variance cannot be used with --spp or --sample-variance".into());
    }
    if a.sample_variance.is_some() && a.spp.is_none() {
        return bad("--sample-variance needs --spp".into());
    }
    for (name, v) in [
        ("--max-abs-mean-z", a.max_abs_mean_z),
        ("--max-relmse", a.max_relmse),
    ] {
        if let Some(v) = v
            && (v.is_nan() || v < 0.0)
        {
            return bad(format!("{name} {v}: must be a non-negative number"));
        }
    }
    Ok(())
}

/// Compares the files of `a` (see the module doc).
pub fn compare_files(a: &CompareFiles) -> Result<CompareOutcome> {
    let bad = |m: String| Err(Error::Invalid(m));
    check_options(a)?;
    let test = load(&a.test, "test image")?;
    let reference = load(&a.reference, "reference")?;
    same_size(&test, &reference, &a.test, &a.reference)?;

    // Variance inputs: explicit, or found beside the reference when --spp is given.
    let sample_var_path = match (&a.sample_variance, a.spp) {
        (Some(p), _) => Some(p.clone()),
        (None, Some(_)) => {
            let p = beside(&a.reference, "_sample_var");
            if !p.is_file() {
                return bad(format!(
                    "--spp given but no --sample-variance, and {} does not exist (only the \
                     Mitsuba pipeline writes it; for a btfpt render give its own variance with \
                     --test-variance TEST_VAR.EXR from `btfpt render --variance` instead of --spp)",
                    p.display()
                ));
            }
            Some(p)
        }
        (None, None) => None,
    };
    let var_path = match &a.variance {
        Some(p) => Some(p.clone()),
        None if a.spp.is_some() => Some(beside(&a.reference, "_var")).filter(|p| p.is_file()),
        None => None,
    };
    let mut inputs = Vec::new();
    let sample_var = match &sample_var_path {
        Some(p) => {
            let v = load(p, "sample variance")?;
            same_size(&v, &reference, p, &a.reference)?;
            inputs.push(format!(
                "sample variance {} / {} spp",
                p.display(),
                a.spp.unwrap_or(1)
            ));
            Some(v)
        }
        None => None,
    };
    let ref_var = match &var_path {
        Some(p) => {
            let v = load(p, "variance")?;
            same_size(&v, &reference, p, &a.reference)?;
            inputs.push(format!("variance of the reference mean {}", p.display()));
            Some(v)
        }
        None => None,
    };
    let test_var = match &a.test_variance {
        Some(p) => {
            let v = load(p, "test variance")?;
            same_size(&v, &test, p, &a.test)?;
            inputs.push(format!("variance of the test mean {}", p.display()));
            Some(v)
        }
        None => None,
    };
    if a.block > test.width.min(test.height) {
        return bad(format!(
            "--block {} is larger than the {}×{} image",
            a.block, test.width, test.height
        ));
    }
    if a.scales.contains(&0) {
        return bad("--scales: block sides must be at least 1".into());
    }
    if a.sample_variance_floor.is_nan() || a.sample_variance_floor < 0.0 {
        return bad("--sample-variance-floor must be a non-negative number".into());
    }
    let noise = NoiseModel {
        test: match (&sample_var, &test_var) {
            (Some(s), _) => Some(TestNoise::Predicted {
                sample_var: s,
                spp: a.spp.unwrap_or(1),
            }),
            (None, Some(t)) => Some(TestNoise::Estimated(t)),
            (None, None) => None,
        },
        reference: ref_var.as_ref(),
    };
    let has_variance = noise.test.is_some() || noise.reference.is_some();
    let cal = Calibration {
        alpha: a.alpha,
        scales: a.scales.clone(),
        sample_variance_floor: a.sample_variance_floor,
        ..Default::default()
    };
    let mut comparison = if has_variance {
        Comparison::calibrated(&test, &reference, &noise, &cal)?
    } else {
        Comparison::new(&test, &reference, None, a.block, a.alpha)?
    };
    if has_variance && (a.max_failing_pixels.is_some() || a.max_failing_blocks.is_some()) {
        // The explicit bounds count failures at Šidák α over one scale.
        let var = pixel_variance(&noise, a.sample_variance_floor)?;
        let single = Comparison::new(&test, &reference, Some(&var), a.block, a.alpha)?;
        comparison.pixel_test = single.pixel_test;
        comparison.block_test = single.block_test;
    }
    let criteria = Criteria {
        max_failing_pixels: a.max_failing_pixels,
        max_failing_blocks: a.max_failing_blocks,
        max_abs_mean_z: a.max_abs_mean_z,
        max_relmse: a.max_relmse,
    };
    let failures = comparison.failures(&criteria);
    let tested = comparison.pixel_test.is_some()
        || criteria.max_relmse.is_some()
        || criteria.max_failing_blocks.is_some()
        || criteria.max_abs_mean_z.is_some();
    Ok(CompareOutcome {
        test,
        reference,
        comparison,
        criteria,
        calibration: has_variance.then_some(cal),
        failures,
        tested,
        inputs,
        sample_variance: sample_var_path,
        variance: var_path,
    })
}

impl CompareOutcome {
    /// The verdict line `btfpt compare` prints.
    pub fn verdict(&self) -> &'static str {
        if !self.failures.is_empty() {
            "FAILED"
        } else if self.comparison.pixel_test.is_some() {
            "PASS"
        } else if self.tested {
            "PASS (relMSE bound only; no statistical test run)"
        } else {
            "no statistical test run (no variance given: nothing was tested, the figures above are \
             for information; give --variance and --test-variance, or --spp with the reference's \
             sample variance, for the z-test)"
        }
    }

    /// The false-colour difference image `compare --diff` writes: signed z of the calibrated
    /// per-pixel test when a variance is known, else the relative luminance difference.
    pub fn diff_image(&self) -> Result<DiffImage> {
        let cmp = &self.comparison;
        let zmap = cmp
            .calibrated
            .as_ref()
            .map(|v| v.pixel_test())
            .or(cmp.pixel_test.as_ref());
        Ok(match zmap {
            Some(z) => DiffImage {
                image: z_diff_image(z),
                label: format!("{:.2}Z", z.threshold),
                scale: format!(
                    "z, full colour at |z| = {:.2} (the failure threshold)",
                    z.threshold
                ),
            },
            None => DiffImage {
                image: relative_diff_image(&self.test, &self.reference, 0.1)?,
                label: "10%".to_string(),
                scale: "relative luminance difference (Y_t − Y_r)/(Y_r + 0.01), full colour at \
                        ±10 %"
                    .to_string(),
            },
        })
    }

    /// The document `btfpt compare --json` writes for the inputs `a`.
    pub fn json(&self, a: &CompareFiles) -> serde_json::Value {
        serde_json::json!({
            "test": a.test,
            "reference": a.reference,
            "sample_variance": self.sample_variance,
            "variance": self.variance,
            "spp": a.spp,
            "test_variance": a.test_variance,
            "comparison": self.comparison,
            "statistical_test": self.comparison.pixel_test.is_some(),
            "calibration": self.calibration,
            "passed": if self.tested { Some(self.failures.is_empty()) } else { None },
            "failures": self.failures,
        })
    }
}
