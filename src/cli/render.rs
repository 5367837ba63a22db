//! `btfpt render`: render a scene (or a crop window / sample range of it) to EXR + PNG preview,
//! with progress, checkpoints every `--checkpoint-interval` seconds and on Ctrl-C, and `--resume`.

use anyhow::{Context, bail};
use btfpt::render::film::{RenderSettings, RenderState};
use btfpt::render::partial::{PartialMeta, write_partial_exr};
use btfpt::render::{RenderScene, checkpoint};
use clap::Args;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Arguments of `btfpt render`.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file (Mitsuba 3 XML or glTF).
    pub scene: PathBuf,
    /// Output EXR (a PNG preview is written next to it); default: the scene name with .exr.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Samples per pixel (overrides the scene's sampler); renders samples 0..spp.
    #[arg(long)]
    pub spp: Option<u32>,
    /// Render only sample indices a..b (for splitting one image over machines; see `merge`).
    #[arg(long, value_name = "A..B", conflicts_with = "spp")]
    pub spp_range: Option<String>,
    /// Seed of the random streams.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Render only the window x,y,w,h of the film (pixels).
    #[arg(long, value_name = "X,Y,W,H")]
    pub crop: Option<String>,
    /// Override a scene `<default>` parameter, e.g. -D spp=64 (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    pub defines: Vec<String>,
    /// Also write the per-pixel variance of the mean to this EXR.
    #[arg(long, value_name = "VAR.EXR")]
    pub variance: Option<PathBuf>,
    /// Continue from the checkpoint of an interrupted render with the same options.
    #[arg(long)]
    pub resume: bool,
    /// Seconds between checkpoints.
    #[arg(long, default_value_t = 60.0)]
    pub checkpoint_interval: f64,
    /// Render every BTF material with this model instead of the scene's (raw data or a fitted
    /// model of the same material, found next to the scene's file: S, S.btfc, S.plmc, S.lm.plmc…).
    #[arg(long, value_name = "MODEL", value_parser = ["raw", "lm", "plm", "plmc"])]
    pub btf_model: Option<String>,
}

fn parse_range(s: &str) -> anyhow::Result<(u32, u32)> {
    let (a, b) = s
        .split_once("..")
        .with_context(|| format!("--spp-range '{s}': expected A..B"))?;
    let a: u32 = a
        .trim()
        .parse()
        .with_context(|| format!("--spp-range '{s}': bad start"))?;
    let b: u32 = b
        .trim()
        .parse()
        .with_context(|| format!("--spp-range '{s}': bad end"))?;
    if a >= b {
        bail!("--spp-range '{s}': the range is empty");
    }
    Ok((a, b))
}

fn parse_crop(s: &str) -> anyhow::Result<[u32; 4]> {
    let v: Vec<u32> = s
        .split(',')
        .map(|p| p.trim().parse::<u32>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--crop '{s}': expected four non-negative integers x,y,w,h"))?;
    if v.len() != 4 {
        bail!("--crop '{s}': expected four numbers x,y,w,h");
    }
    Ok([v[0], v[1], v[2], v[3]])
}

fn parse_defines(d: &[String]) -> anyhow::Result<Vec<(String, String)>> {
    d.iter()
        .map(|s| {
            let (k, v) = s
                .split_once('=')
                .with_context(|| format!("-D '{s}': expected NAME=VALUE"))?;
            if k.is_empty() {
                bail!("-D '{s}': empty name");
            }
            Ok((k.to_string(), v.to_string()))
        })
        .collect()
}

/// Fails early (before rendering) if `path` cannot be created.
fn check_writable(path: &Path) -> anyhow::Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        bail!(
            "{}: output directory {} does not exist",
            path.display(),
            dir.display()
        );
    }
    let probe = btfpt::io::atomic::temp_path(path);
    std::fs::write(&probe, b"")
        .with_context(|| format!("{}: output is not writable", path.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

fn with_suffix(path: &Path, suffix: &str) -> PathBuf {
    let mut s = path.as_os_str().to_os_string();
    s.push(suffix);
    PathBuf::from(s)
}

/// Identifies scene content and options, so a checkpoint is never resumed into another render.
fn fingerprint(scene: &Path, defines: &[(String, String)], s: &RenderSettings) -> u64 {
    let mut h = crc32fast::Hasher::new();
    if let Ok(bytes) = std::fs::read(scene) {
        h.update(&bytes);
    }
    h.update(format!("{defines:?}{s:?}").as_bytes());
    let a = h.finalize() as u64;
    let b = crc32fast::hash(format!("{s:?}{}", scene.display()).as_bytes()) as u64;
    (a << 32) | b
}

/// Runs `btfpt render`.
pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    // Argument errors first, before the (possibly slow) scene load.
    let defines = parse_defines(&args.defines)?;
    let range = args.spp_range.as_deref().map(parse_range).transpose()?;
    let crop_arg = args.crop.as_deref().map(parse_crop).transpose()?;
    if !args.scene.is_file() {
        bail!("{}: scene file not found", args.scene.display());
    }
    let load_options = btfpt::scene::LoadOptions {
        defines: defines.clone(),
        btf_model: args
            .btf_model
            .as_deref()
            .map(btfpt::model::BtfModel::parse)
            .transpose()?,
    };
    let scene = btfpt::scene::load(&args.scene, &load_options)?;
    if scene.meshes.is_empty() && scene.emitters.is_empty() {
        bail!(
            "{}: the scene is empty (no shapes and no emitters), the image would be black",
            args.scene.display()
        );
    }
    let out = args
        .output
        .clone()
        .unwrap_or_else(|| args.scene.with_extension("exr"));
    if out
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        != Some("exr".into())
    {
        bail!("{}: the output must be an .exr file", out.display());
    }
    let (spp_begin, spp_end) = match (range, args.spp) {
        (Some(r), _) => r,
        (None, Some(n)) => (0, n),
        (None, None) => (0, scene.spp),
    };
    if spp_end == 0 {
        bail!("sample count must be at least 1");
    }
    let crop = match crop_arg {
        Some(c) => c,
        None => scene
            .camera
            .crop
            .unwrap_or([0, 0, scene.camera.width, scene.camera.height]),
    };
    let settings = RenderSettings {
        width: scene.camera.width,
        height: scene.camera.height,
        crop,
        spp_begin,
        spp_end,
        seed: args.seed,
    };
    settings.validate()?;
    if let Some(t) = args.threads
        && (t == 0 || t > 4096)
    {
        bail!("--threads {t}: must be in 1..=4096");
    }
    if args.checkpoint_interval.is_nan() || args.checkpoint_interval <= 0.0 {
        bail!("--checkpoint-interval must be positive");
    }
    check_writable(&out)?;
    let png = out.with_extension("png");
    check_writable(&png)?;
    if let Some(v) = &args.variance {
        check_writable(v)?;
        if settings.spp() < 2 {
            bail!("--variance needs at least 2 samples per pixel");
        }
    }
    let ckpt = with_suffix(&out, ".ckpt");
    // The BTF model override changes the image: a checkpoint of another model must not resume.
    let mut fp_defines = defines.clone();
    if let Some(m) = &args.btf_model {
        fp_defines.push(("--btf-model".into(), m.clone()));
    }
    let fp = fingerprint(&args.scene, &fp_defines, &settings);

    for u in &scene.btf_uses {
        eprintln!("btf: {} ({})", u.file.display(), u.model);
    }
    let rs = RenderScene::new(scene)?;
    eprintln!("{}", rs.summary());
    let [cx, cy, cw, ch] = crop;
    eprintln!(
        "rendering window {cx},{cy},{cw}×{ch}, samples {spp_begin}..{spp_end}, seed {} → {}",
        args.seed,
        out.display()
    );

    let mut state = if args.resume {
        let s = checkpoint::load_filtered(&ckpt, &settings, &rs.scene.camera.filter, fp)?;
        eprintln!(
            "resuming from {} ({:.1}% done)",
            ckpt.display(),
            100.0 * s.samples_done() as f64 / s.samples_total() as f64
        );
        s
    } else {
        if ckpt.exists() {
            eprintln!(
                "note: {} exists and will be overwritten (use --resume to continue it)",
                ckpt.display()
            );
        }
        RenderState::with_filter(settings, rs.scene.camera.filter)?
    };

    let interrupt = Arc::new(AtomicBool::new(false));
    {
        let flag = interrupt.clone();
        if let Err(e) = ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst)) {
            eprintln!(
                "warning: cannot install the Ctrl-C handler ({e}); no checkpoint on interrupt"
            );
        }
    }
    let pool = {
        let mut b = rayon::ThreadPoolBuilder::new();
        if let Some(t) = args.threads {
            b = b.num_threads(t);
        }
        b.build().context("cannot start the worker threads")?
    };

    let pb = indicatif::ProgressBar::new(state.samples_total());
    pb.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {percent:>3}% {human_pos}/{human_len} pixel-samples, {elapsed} elapsed, ETA {eta} {msg}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    pb.set_position(state.samples_done());
    let rays = AtomicU64::new(0);
    let start = Instant::now();
    let cpu_start = process_cpu_seconds();
    let mut last_ckpt = Instant::now();
    let interval = Duration::from_secs_f64(args.checkpoint_interval);
    // Passes are sized to take ~1/4 of the checkpoint interval (at most 15 s).
    let target = (interval.as_secs_f64() / 4.0).min(15.0);
    let mut k = 1u32;
    while !state.is_complete() && !interrupt.load(Ordering::SeqCst) {
        let t0 = Instant::now();
        let before = state.samples_done();
        pool.install(|| {
            state.run_pass(&rs, k, &interrupt, &|n, r| {
                pb.inc(n);
                let total = rays.fetch_add(r, Ordering::Relaxed) + r;
                let secs = start.elapsed().as_secs_f64().max(1e-3);
                pb.set_message(format!("{:.1} Mrays/s", total as f64 / secs * 1e-6));
            })
        });
        let dt = t0.elapsed().as_secs_f64().max(1e-3);
        let frac = (state.samples_done() - before) as f64 / state.samples_total().max(1) as f64;
        let per_spp = dt / (frac * settings.spp() as f64).max(1e-9);
        k = ((target / per_spp) as u32).clamp(1, 1 << 16);
        if last_ckpt.elapsed() >= interval && !state.is_complete() {
            checkpoint::save(&ckpt, &state, fp)?;
            last_ckpt = Instant::now();
        }
    }
    pb.finish_and_clear();
    if !state.is_complete() {
        checkpoint::save(&ckpt, &state, fp)?;
        bail!(
            "interrupted at {:.1}%; checkpoint written to {} (continue with --resume)",
            100.0 * state.samples_done() as f64 / state.samples_total() as f64,
            ckpt.display()
        );
    }
    let secs = start.elapsed().as_secs_f64();
    let cpu = match (cpu_start, process_cpu_seconds()) {
        (Some(a), Some(b)) => format!(" (cpu {:.2} s)", b - a),
        _ => String::new(),
    };
    let img = state.mean_image();
    let meta = PartialMeta {
        width: settings.width,
        height: settings.height,
        crop,
        spp_begin,
        spp_end,
        seed: args.seed,
    };
    write_partial_exr(&out, &img, &meta)?;
    btfpt::io::write_png_srgb(&png, &img)?;
    if let Some(v) = &args.variance {
        let var = state.variance_image()?;
        write_partial_exr(v, &var, &meta)?;
    }
    if ckpt.exists() {
        let _ = std::fs::remove_file(&ckpt);
    }
    let invalid = state.invalid_samples();
    eprintln!(
        "done in {secs:.2} s{cpu}: {:.2} Mrays/s, {} rays{}; wrote {} and {}",
        state.rays() as f64 / secs.max(1e-9) * 1e-6,
        state.rays(),
        if invalid > 0 {
            format!(", {invalid} NaN/Inf samples discarded (counted as 0)")
        } else {
            String::new()
        },
        out.display(),
        png.display()
    );
    Ok(())
}

/// User + system CPU seconds of this process so far (all threads), for comparing the render's
/// own cost with other renderers on a loaded machine; None if getrusage fails.
fn process_cpu_seconds() -> Option<f64> {
    let mut ru = std::mem::MaybeUninit::<libc::rusage>::zeroed();
    // SAFETY: getrusage writes a complete rusage into the valid, writable pointer it is given.
    let rc = unsafe { libc::getrusage(libc::RUSAGE_SELF, ru.as_mut_ptr()) };
    if rc != 0 {
        return None;
    }
    // SAFETY: rc == 0 means the struct was filled in (and it started zeroed anyway).
    let ru = unsafe { ru.assume_init() };
    let tv = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    Some(tv(ru.ru_utime) + tv(ru.ru_stime))
}
