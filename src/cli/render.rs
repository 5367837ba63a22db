//! `btfpt render`: render a scene (or a crop window / sample range of it) to EXR + PNG preview,
//! with progress, checkpoints every `--checkpoint-interval` seconds and on Ctrl-C, SIGTERM or
//! SIGHUP (a scheduler's time limit or preemption), and `--resume`.

use anyhow::{Context, bail};
use btfpt::render::driver::{self, Checkpointing, DriverOptions, Outcome};
use btfpt::render::film::{RenderSettings, RenderState};
use btfpt::render::packet::PacketOptions;
use btfpt::render::partial::{
    PartialMeta, inputs_fingerprint, scene_fingerprint, write_partial_exr, write_partial_exr_with,
};
use btfpt::render::{IntegratorKind, RenderScene, checkpoint};
use clap::Args;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
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
    /// Render only band I of N equal bands of rows (0-based; rows H·I/N..H·(I+1)/N of the
    /// scene's window), so N machines split one image without knowing its size; `merge` joins
    /// the bands byte-identically to a one-machine render.
    #[arg(long, value_name = "I/N", conflicts_with = "crop")]
    pub band: Option<String>,
    /// Override a scene `<default>` parameter, e.g. -D spp=64 (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    pub defines: Vec<String>,
    /// Also write the per-pixel variance of the mean to this EXR (named `.exr`).
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
    /// Integrator: `packet` (the default: a per-thread pool of paths shaded 16 lanes at a time
    /// in SoA kernels, with lane refill) or `scalar` (one path per thread at a time; the test
    /// oracle). Both give the same image bits; scenes with Mitsuba's `direct` integrator always
    /// render with the scalar one [default: packet]
    #[arg(long, value_parser = ["scalar", "packet"])]
    pub integrator: Option<String>,
    /// Packet integrator: paths in flight per thread (rounded up to a multiple of 16).
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub packet_pool: u32,
    /// Packet integrator: refill finished lanes at once (`on`) or only when their whole 16-lane
    /// packet has finished (`off`, for measuring what refill buys).
    #[arg(long, default_value = "on", value_parser = ["on", "off"])]
    pub packet_refill: String,
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

fn parse_band(s: &str) -> anyhow::Result<(u32, u32)> {
    let (i, n) = s
        .split_once('/')
        .with_context(|| format!("--band '{s}': expected I/N, e.g. 0/4"))?;
    let i: u32 = i
        .trim()
        .parse()
        .with_context(|| format!("--band '{s}': bad band index"))?;
    let n: u32 = n
        .trim()
        .parse()
        .with_context(|| format!("--band '{s}': bad band count"))?;
    if n == 0 || i >= n {
        bail!("--band '{s}': the index must be in 0..{n} (0-based)");
    }
    Ok((i, n))
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
    let run_start = Instant::now();
    // Argument errors first, before the (possibly slow) scene load.
    let defines = parse_defines(&args.defines)?;
    let range = args.spp_range.as_deref().map(parse_range).transpose()?;
    let crop_arg = args.crop.as_deref().map(parse_crop).transpose()?;
    let band = args.band.as_deref().map(parse_band).transpose()?;
    if args.scene.is_dir() {
        bail!(
            "{}: is a folder; name the scene file in it (.xml, .gltf or .glb)",
            args.scene.display()
        );
    }
    if !args.scene.is_file() {
        bail!("{}: scene file not found", args.scene.display());
    }
    let out = args
        .output
        .clone()
        .unwrap_or_else(|| args.scene.with_extension("exr"));
    {
        use super::output::{ImageFile, image_file, optional_image_file};
        image_file(&out, &[ImageFile::Exr], "the render (-o)")?;
        optional_image_file(args.variance.as_ref(), &[ImageFile::Exr], "--variance")?;
    }
    let png = out.with_extension("png");
    super::output::check_file(&png)?;
    let load_options = btfpt::scene::LoadOptions {
        defines: defines.clone(),
        btf_model: args
            .btf_model
            .as_deref()
            .map(btfpt::model::BtfModel::parse)
            .transpose()?,
        synth_cache: btfpt::btf::synth::disk_cache::default_cache_dir(),
    };
    let scene = btfpt::scene::load(&args.scene, &load_options)?;
    let read_secs = run_start.elapsed().as_secs_f64();
    if scene.meshes.is_empty() && scene.emitters.is_empty() {
        bail!(
            "{}: the scene is empty (no shapes and no emitters), the image would be black",
            args.scene.display()
        );
    }
    let (spp_begin, spp_end) = match (range, args.spp) {
        (Some(r), _) => r,
        (None, Some(n)) => (0, n),
        (None, None) => (0, scene.spp),
    };
    if spp_end == 0 {
        bail!("sample count must be at least 1");
    }
    let mut crop = match crop_arg {
        Some(c) => c,
        None => scene
            .camera
            .crop
            .unwrap_or([0, 0, scene.camera.width, scene.camera.height]),
    };
    // The window a band splits: what `merge` needs all of.
    let whole = crop;
    if let Some((i, n)) = band {
        let [_, y, _, h] = crop;
        if n > h {
            bail!("--band {i}/{n}: the window has only {h} rows");
        }
        let row = |k: u32| (h as u64 * k as u64 / n as u64) as u32;
        crop[1] = y + row(i);
        crop[3] = row(i + 1) - row(i);
    }
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
        && (t == 0 || t > driver::MAX_THREADS)
    {
        bail!("--threads {t}: must be in 1..={}", driver::MAX_THREADS);
    }
    if args.checkpoint_interval.is_nan() || args.checkpoint_interval <= 0.0 {
        bail!("--checkpoint-interval must be positive");
    }
    if args.variance.is_some() && settings.spp() < 2 {
        bail!("--variance needs at least 2 samples per pixel");
    }
    let ckpt = with_suffix(&out, ".ckpt");
    // What changes the image: the BTF model override and the files the scene reads (a part
    // rendered with another BTF or mesh must not merge, a checkpoint of it must not resume).
    let mut fp_defines = defines.clone();
    if let Some(m) = &args.btf_model {
        fp_defines.push(("--btf-model".into(), m.clone()));
    }
    fp_defines.push(("inputs".into(), inputs_fingerprint(&scene.inputs)?));
    let scene_bytes = std::fs::read(&args.scene)
        .with_context(|| format!("{}: cannot read the scene file", args.scene.display()))?;
    // The integrators give the same image bits, so parts of either merge; a checkpoint holds
    // the integrator's own sums and resumes only with the same one.
    let scene_fp = scene_fingerprint(&scene_bytes, &format!("{fp_defines:?}"));
    let integrator = args.integrator.as_deref().unwrap_or("packet");
    if integrator != "scalar" {
        fp_defines.push(("--integrator".into(), integrator.to_string()));
    }
    let fp = fingerprint(&args.scene, &fp_defines, &settings);

    let scene_spp = scene.spp;
    let btf_uses = scene.btf_uses.clone();
    let mut rs = RenderScene::new(scene)?;
    rs.kind = if integrator == "scalar" {
        IntegratorKind::Scalar
    } else {
        IntegratorKind::Packet(PacketOptions {
            pool: args.packet_pool as usize,
            refill: args.packet_refill == "on",
        })
    };
    let load_secs = run_start.elapsed().as_secs_f64();
    eprintln!("{}", rs.summary());
    for b in &btf_uses {
        eprintln!(
            "  BTF {}: {} model, {}×{} texels, loaded in {:.2} s{}{}",
            b.file.display(),
            b.model,
            b.texels.0,
            b.texels.1,
            b.seconds,
            b.origin
                .as_ref()
                .map_or(String::new(), |o| format!(" ({o})")),
            b.sampling.map_or(String::new(), |t| format!(
                ", light sampling: {} table set{} ({:.2} MiB)",
                t.sets,
                if t.sets == 1 { "" } else { "s" },
                t.bytes as f64 / (1024.0 * 1024.0)
            ))
        );
    }
    let [cx, cy, cw, ch] = crop;
    eprintln!(
        "loaded in {load_secs:.2} s (reading {read_secs:.2} s, BVH {:.2} s, rest {:.2} s); rendering window {cx},{cy},{cw}×{ch}, samples {spp_begin}..{spp_end} ({} spp{}), seed {} → {}",
        rs.bvh_secs,
        (load_secs - read_secs - rs.bvh_secs).max(0.0),
        spp_end - spp_begin,
        if (spp_begin, spp_end) != (0, scene_spp) {
            format!(", the scene asks for {scene_spp}")
        } else {
            String::new()
        },
        args.seed,
        out.display()
    );

    let extra_channels = rs.scene.channels.per_sample.len();
    let mut state = if args.resume {
        let s = checkpoint::load_channels(
            &ckpt,
            &settings,
            &rs.scene.camera.filter,
            extra_channels,
            fp,
        )?;
        if args.variance.is_some() && !s.has_moments() {
            bail!(
                "{}: this render was started without --variance, so its checkpoint has no \
                 second moments to make the variance image from; resume it without --variance",
                ckpt.display()
            );
        }
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
        let s = RenderState::with_channels(settings, rs.scene.camera.filter, extra_channels)?;
        // Second moments only feed the variance image: without --variance each sample adds
        // to half the sums (a checkpoint resumes with the moments it was started with).
        if args.variance.is_some() {
            s
        } else {
            s.without_moments()
        }
    };

    let interrupt = super::interrupt::stop_flag();
    let pb = indicatif::ProgressBar::new(state.samples_total());
    pb.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {percent:>3}% {human_pos}/{human_len} pixel-samples, {elapsed} elapsed, ETA {eta} {msg}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    pb.set_position(state.samples_done());
    // Rays of this run only (a resumed render's earlier rays are in the state, not its time).
    let rays = AtomicU64::new(0);
    let start = Instant::now();
    let cpu_start = process_cpu_seconds();
    let opts = DriverOptions {
        threads: args.threads,
        checkpoint: Some(Checkpointing {
            path: ckpt.clone(),
            interval: Duration::from_secs_f64(args.checkpoint_interval),
            fingerprint: fp,
        }),
    };
    let outcome = driver::render(&rs, &mut state, &opts, &interrupt, &|n, r| {
        pb.inc(n);
        let total = rays.fetch_add(r, Ordering::Relaxed) + r;
        let secs = start.elapsed().as_secs_f64().max(1e-3);
        pb.set_message(format!("{:.1} Mrays/s", total as f64 / secs * 1e-6));
    })?;
    pb.finish_and_clear();
    if outcome == Outcome::Interrupted {
        bail!(
            "interrupted at {:.1}%; checkpoint written to {} (continue with --resume)",
            100.0 * state.samples_done() as f64 / state.samples_total() as f64,
            ckpt.display()
        );
    }
    let secs = start.elapsed().as_secs_f64();
    let total_secs = run_start.elapsed().as_secs_f64();
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
        scene: scene_fp,
        whole: Some(whole),
    };
    let extra =
        btfpt::render::channels::output_channels(&rs.scene.channels, &img, &state.extra_means());
    write_partial_exr_with(&out, &img, &extra, &meta)?;
    btfpt::io::write_png_srgb(&png, &img)?;
    if let Some(v) = &args.variance {
        let var = state.variance_image()?;
        write_partial_exr(v, &var, &meta)?;
    }
    if ckpt.exists() {
        let _ = std::fs::remove_file(&ckpt);
    }
    let invalid = state.invalid_samples();
    if let IntegratorKind::Packet(o) = rs.integrator_kind() {
        let l = rs.lanes.snapshot();
        eprintln!(
            "packet integrator (pool {}, refill {}): lane utilisation {:.1}% in traversal ({} of {} lanes), {:.1}% in shading batches, {} rounds",
            o.pool,
            if o.refill { "on" } else { "off" },
            100.0 * l.utilisation(),
            l.active,
            l.issued,
            100.0 * l.shade_utilisation(),
            l.steps
        );
    }
    eprintln!(
        "done in {total_secs:.2} s (loading {load_secs:.2} s, rendering {secs:.2} s{cpu}): {} spp, {:.2} Mrays/s, {} rays{}; wrote {} and {}",
        spp_end - spp_begin,
        rays.load(Ordering::Relaxed) as f64 / secs.max(1e-9) * 1e-6,
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
