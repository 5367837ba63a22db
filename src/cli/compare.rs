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
    if args.block > test.width.min(test.height) {
        bail!(
            "--block {} is larger than the {}×{} image",
            args.block,
            test.width,
            test.height
        );
    }
    if args.scales.contains(&0) {
        bail!("--scales: block sides must be at least 1");
    }
    if args.sample_variance_floor.is_nan() || args.sample_variance_floor < 0.0 {
        bail!("--sample-variance-floor must be a non-negative number");
    }
    let noise = metrics::NoiseModel {
        test: match (&sample_var, &test_var) {
            (Some(s), _) => Some(metrics::TestNoise::Predicted {
                sample_var: s,
                spp: args.spp.unwrap_or(1),
            }),
            (None, Some(t)) => Some(metrics::TestNoise::Estimated(t)),
            (None, None) => None,
        },
        reference: ref_var.as_ref(),
    };
    let has_variance = noise.test.is_some() || noise.reference.is_some();
    let cal = metrics::Calibration {
        alpha: args.alpha,
        scales: args.scales.clone(),
        sample_variance_floor: args.sample_variance_floor,
        ..Default::default()
    };
    let mut cmp = if has_variance {
        Comparison::calibrated(&test, &reference, &noise, &cal)?
    } else {
        Comparison::new(&test, &reference, None, args.block, args.alpha)?
    };
    if has_variance && (args.max_failing_pixels.is_some() || args.max_failing_blocks.is_some()) {
        // The explicit bounds count failures at Šidák α over one scale, as before.
        let var = metrics::calibrated::pixel_variance(&noise, args.sample_variance_floor)?;
        let legacy = Comparison::new(&test, &reference, Some(&var), args.block, args.alpha)?;
        cmp.pixel_test = legacy.pixel_test;
        cmp.block_test = legacy.block_test;
    }
    let criteria = Criteria {
        max_failing_pixels: args.max_failing_pixels,
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
        let zmap = cmp
            .calibrated
            .as_ref()
            .map(|v| v.pixel_test())
            .or(cmp.pixel_test.as_ref());
        let (img, label, scale) = match zmap {
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
            "calibration": if has_variance { Some(&cal) } else { None },
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
