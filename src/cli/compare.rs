//! `btfpt compare`: error metrics and the z-test of a render against a reference (e.g. the
//! committed Mitsuba references, or another btfpt render); exit code 0 on pass or when no bound
//! was checked (then it says "no statistical test run", never PASS).

use anyhow::{Context, bail};
use btfpt::io::{RgbImage, read_image};
use btfpt::metrics::{self, Comparison, Criteria};
use clap::Args;
use std::path::{Path, PathBuf};

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

/// `dir/stem{suffix}.exr` for `dir/stem.exr`.
fn beside(reference: &Path, suffix: &str) -> PathBuf {
    let stem = reference
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    reference.with_file_name(format!("{stem}{suffix}.exr"))
}

fn load(path: &Path, what: &str) -> anyhow::Result<RgbImage> {
    let img = read_image(path).with_context(|| format!("cannot read the {what}"))?;
    if let Some((x, y, c)) = metrics::first_nonfinite(&img) {
        bail!(
            "{}: the {what} has a non-finite value at pixel ({x}, {y}) channel {c}",
            path.display()
        );
    }
    Ok(img)
}

fn same_size(a: &RgbImage, b: &RgbImage, pa: &Path, pb: &Path) -> anyhow::Result<()> {
    if a.width != b.width || a.height != b.height {
        bail!(
            "image sizes differ: {} is {}×{}, {} is {}×{}",
            pa.display(),
            a.width,
            a.height,
            pb.display(),
            b.width,
            b.height
        );
    }
    Ok(())
}

/// Runs `btfpt compare`.
pub fn run(args: CompareArgs) -> anyhow::Result<()> {
    super::output::optional_image_file(
        args.diff.as_ref(),
        &[super::output::ImageFile::Png],
        "--diff",
    )?;
    super::output::check_optional_file(args.json.as_ref())?;
    if !(args.alpha > 0.0 && args.alpha < 1.0) {
        bail!("--alpha {}: must be in (0, 1)", args.alpha);
    }
    if args.block == 0 {
        bail!("--block must be at least 1");
    }
    if args.spp == Some(0) {
        bail!("--spp must be at least 1");
    }
    for (name, v) in [
        ("--max-abs-mean-z", args.max_abs_mean_z),
        ("--max-relmse", args.max_relmse),
    ] {
        if let Some(v) = v
            && (v.is_nan() || v < 0.0)
        {
            bail!("{name} {v}: must be a non-negative number");
        }
    }
    let test = load(&args.test, "test image")?;
    let reference = load(&args.reference, "reference")?;
    same_size(&test, &reference, &args.test, &args.reference)?;

    // Variance inputs: explicit, or found beside the reference when --spp is given.
    let sample_var_path = match (&args.sample_variance, args.spp) {
        (Some(p), _) => Some(p.clone()),
        (None, Some(_)) => {
            let p = beside(&args.reference, "_sample_var");
            if !p.is_file() {
                bail!(
                    "--spp given but no --sample-variance, and {} does not exist (only the \
                     Mitsuba pipeline writes it; for a btfpt render give its own variance with \
                     --test-variance TEST_VAR.EXR from `btfpt render --variance` instead of --spp)",
                    p.display()
                );
            }
            Some(p)
        }
        (None, None) => None,
    };
    let var_path = match &args.variance {
        Some(p) => Some(p.clone()),
        None if args.spp.is_some() => Some(beside(&args.reference, "_var")).filter(|p| p.is_file()),
        None => None,
    };
    let mut inputs = Vec::new();
    let sample_var = match &sample_var_path {
        Some(p) => {
            let v = load(p, "sample variance")?;
            same_size(&v, &reference, p, &args.reference)?;
            inputs.push(format!(
                "sample variance {} / {} spp",
                p.display(),
                args.spp.unwrap_or(1)
            ));
            Some(v)
        }
        None => None,
    };
    let ref_var = match &var_path {
        Some(p) => {
            let v = load(p, "variance")?;
            same_size(&v, &reference, p, &args.reference)?;
            inputs.push(format!("variance of the reference mean {}", p.display()));
            Some(v)
        }
        None => None,
    };
    let test_var = match &args.test_variance {
        Some(p) => {
            let v = load(p, "test variance")?;
            same_size(&v, &test, p, &args.test)?;
            inputs.push(format!("variance of the test mean {}", p.display()));
            Some(v)
        }
        None => None,
    };
    let mut terms = Vec::new();
    if sample_var.is_some() || ref_var.is_some() {
        terms.push(metrics::predicted_variance(
            sample_var.as_ref(),
            args.spp.unwrap_or(1),
            ref_var.as_ref(),
        )?);
    }
    if let Some(t) = &test_var {
        // Validated (finite, ≥ 0) like the other variance inputs.
        terms.push(metrics::predicted_variance(None, 1, Some(t))?);
    }
    let variance = terms.into_iter().reduce(|mut a, b| {
        a.data.iter_mut().zip(&b.data).for_each(|(x, y)| *x += y);
        a
    });
    if args.block > test.width.min(test.height) {
        bail!(
            "--block {} is larger than the {}×{} image",
            args.block,
            test.width,
            test.height
        );
    }
    let cmp = Comparison::new(&test, &reference, variance.as_ref(), args.block, args.alpha)?;
    let criteria = Criteria {
        max_failing_pixels: args.max_failing_pixels.or(variance.as_ref().map(|_| 0)),
        max_failing_blocks: args.max_failing_blocks,
        max_abs_mean_z: args.max_abs_mean_z,
        max_relmse: args.max_relmse,
    };
    let failures = cmp.failures(&criteria);

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
                metrics::relative_diff_image(&test, &reference, 0.1)?,
                "10%".to_string(),
                "relative luminance difference (Y_t − Y_r)/(Y_r + 0.01), full colour at ±10 %"
                    .to_string(),
            ),
        };
        super::output::write_image(p, &metrics::with_legend(&img, &label))?;
        println!(
            "{}: {scale}; white = equal, blue = test darker, red = brighter, cyan/magenta \
             beyond the scale, yellow = non-finite; the scale is drawn under the image",
            p.display()
        );
    }
    // A bound was checked at all (a z-test, or the relMSE bound)?
    let tested = cmp.pixel_test.is_some()
        || criteria.max_relmse.is_some()
        || criteria.max_failing_blocks.is_some()
        || criteria.max_abs_mean_z.is_some();
    let verdict = if !failures.is_empty() {
        "FAILED"
    } else if cmp.pixel_test.is_some() {
        "PASS"
    } else if tested {
        "PASS (relMSE bound only; no statistical test run)"
    } else {
        "no statistical test run (no variance given: nothing was tested, the figures above are \
         for information; give --variance and --test-variance, or --spp with the reference's \
         sample variance, for the z-test)"
    };
    if let Some(p) = &args.json {
        let doc = serde_json::json!({
            "test": args.test,
            "reference": args.reference,
            "sample_variance": sample_var_path,
            "variance": var_path,
            "spp": args.spp,
            "test_variance": args.test_variance,
            "comparison": cmp,
            "statistical_test": cmp.pixel_test.is_some(),
            "passed": if tested { Some(failures.is_empty()) } else { None },
            "failures": failures,
        });
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
