//! `btfpt check SUITE`: renders every case of a regression suite, compares each with its
//! reference by the calibrated test (docs/model.md), prints one line per case, writes a static
//! HTML report and a JUnit XML file, and fails when any case fails. `--update NAME…` renders new
//! references for the named cases instead of checking them.

mod report;
mod suite;

use anyhow::{Context, bail};
use btfpt::io::{RgbImage, read_image};
use btfpt::metrics::{self, Comparison, Criteria, NoiseModel, TestNoise};
use btfpt::render::RenderScene;
use btfpt::render::driver::{self, DriverOptions};
use btfpt::render::film::{RenderSettings, RenderState};
use clap::Args;
use std::path::{Path, PathBuf};
use std::time::Instant;
pub use suite::Case;

/// Arguments of `btfpt check`.
#[derive(Args, Debug)]
pub struct CheckArgs {
    /// A suite: a TOML file of `[[case]]` tables, or a folder of such files.
    pub suite: PathBuf,
    /// Folder for index.html, junit.xml and the images of every case.
    #[arg(long, default_value = "report")]
    pub report: PathBuf,
    /// Write new references (EXR, its per-sample variance and variance of the mean) for these
    /// cases, rendered at their `reference_spp`, instead of checking them.
    #[arg(long, value_name = "CASE", num_args = 1..)]
    pub update: Vec<String>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// A finished render: its mean and its own variance of the mean.
pub struct Rendered {
    pub mean: RgbImage,
    pub variance: RgbImage,
    pub seconds: f64,
}

/// What became of one case.
pub struct Outcome {
    pub case: Case,
    pub seconds: f64,
    pub result: Result<Checked, String>,
}

/// A case that was rendered and compared.
pub struct Checked {
    pub test: RgbImage,
    pub reference: RgbImage,
    pub comparison: Comparison,
    pub failures: Vec<String>,
}

/// Renders `scene` at samples 0..spp with `seed` as `btfpt render` does (packet integrator
/// unless the scene needs the scalar one), on `pool`, with a progress bar labelled `label`.
fn render_case(
    scene_path: &Path,
    defines: &[(String, String)],
    spp: u32,
    seed: u64,
    pool: &rayon::ThreadPool,
    label: &str,
) -> anyhow::Result<Rendered> {
    let start = Instant::now();
    let options = btfpt::scene::LoadOptions {
        defines: defines.to_vec(),
        btf_model: None,
        synth_cache: btfpt::btf::synth::disk_cache::default_cache_dir(),
    };
    let scene = btfpt::scene::load(scene_path, &options)?;
    let crop = scene
        .camera
        .crop
        .unwrap_or([0, 0, scene.camera.width, scene.camera.height]);
    let settings = RenderSettings {
        width: scene.camera.width,
        height: scene.camera.height,
        crop,
        spp_begin: 0,
        spp_end: spp,
        seed,
    };
    settings.validate()?;
    // The packet integrator (the default; scenes with `direct` render with the scalar one).
    let rs = RenderScene::new(scene)?;
    let mut state = RenderState::with_filter(settings, rs.scene.camera.filter)?;
    let pb = indicatif::ProgressBar::new(state.samples_total());
    pb.set_style(
        indicatif::ProgressStyle::with_template("{prefix:20} {bar:40} {percent:>3}% ETA {eta}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    pb.set_prefix(label.to_string());
    let interrupt = super::interrupt::stop_flag();
    let opts = DriverOptions {
        threads: Some(pool.current_num_threads()),
        checkpoint: None,
    };
    let outcome = driver::render(&rs, &mut state, &opts, &interrupt, &|n, _| pb.inc(n))?;
    if outcome == driver::Outcome::Interrupted {
        pb.finish_and_clear();
        bail!("interrupted");
    }
    pb.finish_and_clear();
    Ok(Rendered {
        mean: state.mean_image(),
        variance: state.variance_image()?,
        seconds: start.elapsed().as_secs_f64(),
    })
}

fn load(path: &Path, what: &str, case: &Case) -> anyhow::Result<RgbImage> {
    let img = read_image(path).with_context(|| {
        format!(
            "{}: case '{}': cannot read the {what}",
            case.file.display(),
            case.name
        )
    })?;
    if let Some((x, y, c)) = metrics::first_nonfinite(&img) {
        bail!(
            "{}: the {what} has a non-finite value at pixel ({x}, {y}) channel {c}",
            path.display()
        );
    }
    Ok(img)
}

/// Compares a rendered case with its reference by the calibrated test.
fn compare_case(case: &Case, r: Rendered) -> anyhow::Result<Checked> {
    let reference = load(&case.reference, "reference", case)?;
    let sample_var = match &case.sample_variance {
        Some(p) => Some(load(p, "sample variance", case)?),
        None => None,
    };
    let ref_var = match &case.variance {
        Some(p) => Some(load(p, "variance", case)?),
        None => None,
    };
    for (img, what) in [
        (Some(&reference), "reference"),
        (sample_var.as_ref(), "sample variance"),
        (ref_var.as_ref(), "variance"),
    ] {
        if let Some(img) = img
            && (img.width, img.height) != (r.mean.width, r.mean.height)
        {
            bail!(
                "case '{}': the render is {}×{} but the {what} is {}×{} (spp, defines or the scene changed?)",
                case.name,
                r.mean.width,
                r.mean.height,
                img.width,
                img.height
            );
        }
    }
    let noise = NoiseModel {
        test: Some(match &sample_var {
            Some(s) => TestNoise::Predicted {
                sample_var: s,
                spp: case.spp,
            },
            None => TestNoise::Estimated(&r.variance),
        }),
        reference: ref_var.as_ref(),
    };
    let comparison = Comparison::calibrated(&r.mean, &reference, &noise, &case.calibration)?;
    let failures = comparison.failures(&Criteria {
        max_relmse: case.max_relmse,
        ..Default::default()
    });
    Ok(Checked {
        test: r.mean,
        reference,
        comparison,
        failures,
    })
}

/// Writes the reference files of `case` from a render at its `reference_spp`.
fn write_reference(case: &Case, r: &Rendered) -> anyhow::Result<Vec<PathBuf>> {
    let sample_var_path = case
        .sample_variance
        .clone()
        .unwrap_or_else(|| suite::beside(&case.reference, "_sample_var"));
    let var_path = case
        .variance
        .clone()
        .unwrap_or_else(|| suite::beside(&case.reference, "_var"));
    let mut sample_var = r.variance.clone();
    let n = case.reference_spp as f32;
    sample_var.data.iter_mut().for_each(|v| *v *= n);
    btfpt::io::write_exr(&case.reference, &r.mean)?;
    btfpt::io::write_exr(&sample_var_path, &sample_var)?;
    btfpt::io::write_exr(&var_path, &r.variance)?;
    Ok(vec![case.reference.clone(), sample_var_path, var_path])
}

/// Fails unless every input of the cases exists (before any render starts).
fn check_inputs(cases: &[Case], update: &[String]) -> anyhow::Result<()> {
    for u in update {
        if !cases.iter().any(|c| &c.name == u) {
            let names: Vec<&str> = cases.iter().map(|c| c.name.as_str()).collect();
            bail!(
                "--update {u}: no such case (the suite has {})",
                names.join(", ")
            );
        }
    }
    // References that an updated case writes before the others are checked.
    let written: Vec<&PathBuf> = cases
        .iter()
        .filter(|c| update.contains(&c.name))
        .map(|c| &c.reference)
        .collect();
    for c in cases {
        let at = format!("{}: case '{}'", c.file.display(), c.name);
        if !c.scene.is_file() {
            bail!("{at}: scene file {} not found", c.scene.display());
        }
        if update.contains(&c.name) {
            for p in [&c.reference]
                .into_iter()
                .chain(c.sample_variance.as_ref())
                .chain(c.variance.as_ref())
            {
                super::output::check_file(p).with_context(|| at.clone())?;
            }
        } else if !c.reference.is_file() && !written.contains(&&c.reference) {
            bail!(
                "{at}: reference {} not found (write it with --update {})",
                c.reference.display(),
                c.name
            );
        }
    }
    Ok(())
}

/// Runs `btfpt check`.
pub fn run(args: CheckArgs) -> anyhow::Result<()> {
    let cases = suite::load(&args.suite)?;
    check_inputs(&cases, &args.update)?;
    super::output::check_folder(&args.report)?;
    if let Some(t) = args.threads
        && (t == 0 || t > 4096)
    {
        bail!("--threads {t}: must be in 1..=4096");
    }
    let pool = {
        let mut b = rayon::ThreadPoolBuilder::new();
        if let Some(t) = args.threads {
            b = b.num_threads(t);
        }
        b.build().context("cannot start the worker threads")?
    };
    let width = cases.iter().map(|c| c.name.len()).max().unwrap_or(4);
    let mut outcomes = Vec::new();
    // Updated cases first, so the others may check against the references they write.
    let (mut cases, rest): (Vec<Case>, Vec<Case>) = cases
        .into_iter()
        .partition(|c| args.update.contains(&c.name));
    cases.extend(rest);
    for case in cases {
        let updating = args.update.contains(&case.name);
        let spp = if updating {
            case.reference_spp
        } else {
            case.spp
        };
        let rendered = render_case(
            &case.scene,
            &case.defines,
            spp,
            case.seed,
            &pool,
            &case.name,
        )
        .with_context(|| format!("{}: case '{}'", case.file.display(), case.name));
        if updating {
            let r = rendered?;
            let written = write_reference(&case, &r)?;
            println!(
                "UPDATED {:width$}  {} spp, {:.1} s: wrote {}",
                case.name,
                spp,
                r.seconds,
                written
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
            continue;
        }
        let seconds = rendered.as_ref().map(|r| r.seconds).unwrap_or(0.0);
        let result = rendered
            .and_then(|r| compare_case(&case, r))
            .map_err(|e| format!("{e:#}"));
        println!("{}", report::line(&case, seconds, &result, width));
        outcomes.push(Outcome {
            case,
            seconds,
            result,
        });
    }
    if outcomes.is_empty() {
        return Ok(());
    }
    report::write(&args.report, &args.suite, &outcomes)?;
    let failed: Vec<&str> = outcomes
        .iter()
        .filter(|o| !matches!(&o.result, Ok(c) if c.failures.is_empty()))
        .map(|o| o.case.name.as_str())
        .collect();
    println!(
        "report: {} and {}",
        args.report.join("index.html").display(),
        args.report.join("junit.xml").display()
    );
    if failed.is_empty() {
        println!("all {} cases passed", outcomes.len());
        Ok(())
    } else {
        bail!(
            "{} of {} cases failed: {}",
            failed.len(),
            outcomes.len(),
            failed.join(", ")
        )
    }
}
