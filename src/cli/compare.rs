//! `btfpt compare`: error metrics and the z-test of a render against a reference (e.g. the
//! committed Mitsuba references, or another btfpt render); exit code 0 on pass or when no bound
//! was checked (then it says "no statistical test run", never PASS).

use anyhow::bail;
use btfpt::metrics::compare_files::{CompareFiles, compare_files};
use btfpt::metrics::{self};
use clap::Args;
use std::path::PathBuf;

/// Arguments of `btfpt compare`.
#[derive(Args, Debug)]
pub struct CompareArgs {
    /// The image under test (EXR, or PNG/JPEG decoded to linear).
    pub test: PathBuf,
    /// The reference image.
    pub reference: PathBuf,
    /// The reference's per-pixel variance of its mean (default with --spp: REF_var.exr if it exists).
    #[arg(long, value_name = "REF_VAR.EXR")]
    pub variance: Option<PathBuf>,
    /// The reference's per-sample variance; with --spp predicts the test's variance of the mean
    /// (default with --spp: REF_sample_var.exr).
    #[arg(long, value_name = "REF_SAMPLE_VAR.EXR", requires = "spp")]
    pub sample_variance: Option<PathBuf>,
    /// Samples per pixel of the test render.
    #[arg(long)]
    pub spp: Option<u32>,
    /// The test image's own variance of its mean (`btfpt render --variance`); added to the
    /// reference's. With `--variance REF_VAR.EXR` of the other render this tests btfpt against
    /// btfpt; with a Mitsuba reference's `_var.exr`, btfpt against Mitsuba.
    #[arg(long, value_name = "TEST_VAR.EXR", conflicts_with_all = ["sample_variance", "spp"])]
    pub test_variance: Option<PathBuf>,
    /// Family-wise significance level of the z-tests (Šidák-corrected over pixels · 3).
    #[arg(long, default_value_t = 0.01)]
    pub alpha: f64,
    /// Side in pixels of the blocks of the block z-test.
    #[arg(long, default_value_t = 4)]
    pub block: usize,
    /// Fail when more pixels than this fail the per-pixel z-test (default 0 when a variance is known).
    #[arg(long)]
    pub max_failing_pixels: Option<usize>,
    /// Fail when more blocks than this fail the block z-test.
    #[arg(long)]
    pub max_failing_blocks: Option<usize>,
    /// Fail when |mean z| exceeds this (global bias).
    #[arg(long)]
    pub max_abs_mean_z: Option<f64>,
    /// Fail when relMSE exceeds this.
    #[arg(long)]
    pub max_relmse: Option<f64>,
    /// Write a false-colour difference PNG with its scale drawn underneath: signed z if a
    /// variance is known (full blue/red at the failure threshold), else the relative luminance
    /// difference (full colour at ±10 %); white = equal, blue = test darker, red = brighter,
    /// cyan/magenta beyond the scale, yellow = non-finite.
    #[arg(long, value_name = "DIFF.PNG")]
    pub diff: Option<PathBuf>,
    /// Write all figures as JSON.
    #[arg(long, value_name = "OUT.JSON")]
    pub json: Option<PathBuf>,
}

/// Runs `btfpt compare`.
pub fn run(args: CompareArgs) -> anyhow::Result<()> {
    super::output::check_optional_file(args.diff.as_ref())?;
    super::output::check_optional_file(args.json.as_ref())?;
    let files = CompareFiles {
        test: args.test.clone(),
        reference: args.reference.clone(),
        variance: args.variance.clone(),
        sample_variance: args.sample_variance.clone(),
        spp: args.spp,
        test_variance: args.test_variance.clone(),
        alpha: args.alpha,
        block: args.block,
        max_failing_pixels: args.max_failing_pixels,
        max_failing_blocks: args.max_failing_blocks,
        max_abs_mean_z: args.max_abs_mean_z,
        max_relmse: args.max_relmse,
    };
    let o = compare_files(&files)?;
    let (cmp, failures, inputs) = (&o.comparison, &o.failures, &o.inputs);
    let (test, reference) = (&o.test, &o.reference);
    println!(
        "{} vs {}{}",
        args.test.display(),
        args.reference.display(),
        if inputs.is_empty() {
            " (no variance: no z-test)".to_string()
        } else {
            format!(" ({})", inputs.join(", "))
        }
    );
    println!("{}", cmp.report());

    if let Some(p) = &args.diff {
        let (img, label, scale) = match &cmp.pixel_test {
            Some(z) => (
                metrics::z_diff_image(z),
                format!("{:.2}Z", z.threshold),
                format!(
                    "z, full colour at |z| = {:.2} (the failure threshold)",
                    z.threshold
                ),
            ),
            None => (
                metrics::relative_diff_image(test, reference, 0.1)?,
                "10%".to_string(),
                "relative luminance difference (Y_t − Y_r)/(Y_r + 0.01), full colour at ±10 %"
                    .to_string(),
            ),
        };
        btfpt::io::write_png_srgb(p, &metrics::with_legend(&img, &label))?;
        println!(
            "{}: {scale}; white = equal, blue = test darker, red = brighter, cyan/magenta \
             beyond the scale, yellow = non-finite; the scale is drawn under the image",
            p.display()
        );
    }
    let verdict = o.verdict();
    if let Some(p) = &args.json {
        let doc = o.json(&files);
        let text = serde_json::to_string_pretty(&doc)?;
        btfpt::io::write_atomic(p, |w| {
            w.write_all(text.as_bytes())
                .map_err(|e| btfpt::Error::io(p, e))
        })?;
    }
    if failures.is_empty() {
        println!("{verdict}");
        Ok(())
    } else {
        bail!("comparison FAILED:\n  {}", failures.join("\n  "))
    }
}
