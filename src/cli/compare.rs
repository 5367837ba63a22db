//! `btfpt compare`: error metrics and the z-test of a render against a reference (e.g. the
//! committed Mitsuba references, or another btfpt render); exit code 0 on pass or when no bound
//! was checked (then it says "no statistical test run", never PASS).

use anyhow::bail;
use btfpt::metrics::{
    self,
    compare_files::{CompareFiles, compare_files},
};
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
    /// Probability that a correct render fails the calibrated test: shared by its block scales
    /// and the global bias test (Bonferroni), Šidák-corrected over the cells of each scale.
    #[arg(long, default_value_t = 0.01)]
    pub alpha: f64,
    /// Block sides of the calibrated test's scales (1 = per pixel; docs/model.md says why the
    /// default leaves single pixels out of the verdict).
    #[arg(long, value_delimiter = ',', default_value = "4,8,16,32")]
    pub scales: Vec<usize>,
    /// Least per-sample variance assumed where the reference's is nonzero (with --spp).
    #[arg(long, default_value_t = 1e-4)]
    pub sample_variance_floor: f64,
    /// Side in pixels of the blocks counted by --max-failing-blocks.
    #[arg(long, default_value_t = 4)]
    pub block: usize,
    /// Also fail when more pixels than this fail the per-pixel z-test (Šidák at α over pixels).
    #[arg(long)]
    pub max_failing_pixels: Option<usize>,
    /// Also fail when more blocks than this fail the --block z-test.
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
    super::output::optional_image_file(
        args.diff.as_ref(),
        &[super::output::ImageFile::Png],
        "--diff",
    )?;
    super::output::check_optional_file(args.json.as_ref())?;
    let files = CompareFiles {
        test: args.test.clone(),
        reference: args.reference.clone(),
        variance: args.variance.clone(),
        sample_variance: args.sample_variance.clone(),
        spp: args.spp,
        test_variance: args.test_variance.clone(),
        alpha: args.alpha,
        scales: args.scales.clone(),
        sample_variance_floor: args.sample_variance_floor,
        block: args.block,
        max_failing_pixels: args.max_failing_pixels,
        max_failing_blocks: args.max_failing_blocks,
        max_abs_mean_z: args.max_abs_mean_z,
        max_relmse: args.max_relmse,
    };
    let o = compare_files(&files)?;
    println!(
        "{} vs {}{}",
        args.test.display(),
        args.reference.display(),
        if o.inputs.is_empty() {
            " (no variance: no z-test)".to_string()
        } else {
            format!(" ({})", o.inputs.join(", "))
        }
    );
    println!("{}", o.comparison.report());

    if let Some(p) = &args.diff {
        let d = o.diff_image()?;
        super::output::write_image(p, &metrics::with_legend(&d.image, &d.label))?;
        println!(
            "{}: {}; white = equal, blue = test darker, red = brighter, cyan/magenta \
             beyond the scale, yellow = non-finite; the scale is drawn under the image",
            p.display(),
            d.scale
        );
    }
    if let Some(p) = &args.json {
        let text = serde_json::to_string_pretty(&o.json(&files))?;
        btfpt::io::write_atomic(p, |w| {
            w.write_all(text.as_bytes())
                .map_err(|e| btfpt::Error::io(p, e))
        })?;
    }
    if o.failures.is_empty() {
        println!("{}", o.verdict());
        Ok(())
    } else {
        bail!("comparison FAILED:\n  {}", o.failures.join("\n  "))
    }
}
