//! `btfpt fit DATA -o mat.plmc`: fits LM, PLM or PLM-C to a measured BTF, resumably.

use anyhow::Context;
use btfpt::btf;
use btfpt::btf::tiling;
use btfpt::fit::pipeline::{self, ClusterOn, FitOptions, Stage};
use btfpt::fit::view_selection::ViewSelection;
use btfpt::model::ModelKind;
use btfpt::model::codec;
use indicatif::{MultiProgress, ProgressBar, ProgressStyle};
use std::path::PathBuf;

/// Model kind on the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum KindArg {
    Lm,
    Plm,
    Plmc,
}

impl From<KindArg> for ModelKind {
    fn from(k: KindArg) -> Self {
        match k {
            KindArg::Lm => ModelKind::Lm,
            KindArg::Plm => ModelKind::Plm,
            KindArg::Plmc => ModelKind::PlmC,
        }
    }
}

/// `--cluster-on` values.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum ClusterOnArg {
    /// The texels' LM-model values (less noise-driven clusters).
    Lm,
    /// The original values (the paper's method).
    Original,
}

impl From<ClusterOnArg> for ClusterOn {
    fn from(a: ClusterOnArg) -> Self {
        match a {
            ClusterOnArg::Lm => ClusterOn::LmModel,
            ClusterOnArg::Original => ClusterOn::Original,
        }
    }
}

/// Fit a reflectance model to a measured BTF and write a .plmc file.
#[derive(clap::Args, Debug)]
pub struct FitArgs {
    /// The measured BTF (UBO2003 folder, UBO2014 .btf, .btfc cache, or a synth: source).
    pub data: PathBuf,
    /// Output model file; finished views are kept in OUTPUT.parts/ until the fit succeeds.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Model to fit.
    #[arg(long, value_enum, default_value = "plmc")]
    pub model: KindArg,
    /// Clusters per view and colour channel (PLM-C); indices are u8 up to 256, u16 above.
    #[arg(long, default_value_t = 256)]
    pub clusters: usize,
    /// Images chosen by Kullback–Leibler selection as K-means features (PLM-C).
    #[arg(long, default_value_t = 20)]
    pub features: usize,
    /// Seed of the k-means++ initialisation.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// What K-means clusters texels on (PLM-C): their LM-model values in the selected images, or
    /// the original values as in the paper.
    #[arg(long, value_enum, default_value = "lm")]
    pub cluster_on: ClusterOnArg,
    /// Rounds of model-space refinement after K-means (PLM-C): texels move to the cluster whose
    /// lobe fits them best over all lights, cluster lobes are refitted on their members; 0 keeps
    /// the paper's plain K-means clusters.
    #[arg(long, default_value_t = FitOptions::default().refine_iters)]
    pub refine_iters: usize,
    /// Cut a seamless tile of WxH texels (or N for N×N) out of the sample by minimum-error
    /// boundary cuts and fit only its texels.
    #[arg(long)]
    pub tile: Option<String>,
    /// Number of tiles (with --tile): the template plus copies whose inner area is covered by
    /// patches from other positions (all share the borders, stacked vertically in the model).
    #[arg(long, default_value_t = 1)]
    pub tiles: usize,
    /// Overlap band of the cuts in texels (with --tile; default min(W,H)/4 within 2..=16).
    #[arg(long)]
    pub overlap: Option<usize>,
    /// Keep OUTPUT.parts/ (one file per fitted view) after the model is written, e.g. to
    /// assemble the same model again later.
    #[arg(long)]
    pub keep_parts: bool,
    /// Fit only these views into OUTPUT.parts/ and do not write OUTPUT: A..B (views A to B-1), A,
    /// a comma-separated list, or I/N (part I of N equal ranges, 0-based). Once every view has a
    /// part, the same command without --views assembles the model without refitting anything
    /// (byte-identical to a one-process fit); see docs/farm.md.
    #[arg(long, value_name = "A..B|I/N")]
    pub views: Option<String>,
}

/// Progress bars for the per-view stages.
pub(crate) fn stage_bars(views: usize, labels: &[&str]) -> (MultiProgress, Vec<ProgressBar>) {
    let mp = MultiProgress::new();
    let style = ProgressStyle::with_template(
        "{prefix:>8} [{bar:40}] {pos}/{len} views {elapsed_precise} eta {eta}",
    )
    .unwrap_or_else(|_| ProgressStyle::default_bar())
    .progress_chars("=> ");
    let bars = labels
        .iter()
        .map(|l| {
            let b = mp.add(ProgressBar::new(views as u64));
            b.set_style(style.clone());
            b.set_prefix(l.to_string());
            b
        })
        .collect();
    (mp, bars)
}

/// Runs `btfpt fit`.
pub fn run(args: FitArgs) -> anyhow::Result<()> {
    super::output::check_file(&args.output)?;
    if args.tile.is_none() && (args.tiles != 1 || args.overlap.is_some()) {
        anyhow::bail!("--tiles and --overlap need --tile WxH");
    }
    let spec = match &args.tile {
        Some(t) => {
            let (width, height) = tiling::parse_size(t)?;
            Some(tiling::TileSpec {
                width,
                height,
                count: args.tiles,
                overlap: args.overlap,
            })
        }
        None => None,
    };
    let data = btf::open(&super::btf_input::resolve(&args.data)?)?;
    let stitch = match &spec {
        Some(spec) => {
            let t0 = std::time::Instant::now();
            let st = tiling::find_stitch(&*data, spec)
                .with_context(|| format!("cutting tiles out of {}", args.data.display()))?;
            println!(
                "tile: {}×{} × {} from the {}×{} sample at ({}, {}), overlap {}, cut RMS error {:.4}{} ({:.1} s)",
                st.tile_w,
                st.tile_h,
                st.count,
                st.sample_w,
                st.sample_h,
                st.origin.0,
                st.origin.1,
                st.overlap,
                st.cut_error,
                if st.patches.is_empty() {
                    String::new()
                } else {
                    format!(", inner patches from {:?}", st.patches)
                },
                t0.elapsed().as_secs_f64()
            );
            Some(st)
        }
        None => None,
    };
    let tiled = match &stitch {
        Some(st) => Some(tiling::TiledSource::new(&*data, st)?),
        None => None,
    };
    let source: &dyn btf::BtfSource = match &tiled {
        Some(t) => t,
        None => &*data,
    };
    let opts = FitOptions {
        kind: args.model.into(),
        clusters: args.clusters,
        features: args.features,
        seed: args.seed,
        cluster_on: args.cluster_on.into(),
        refine_iters: args.refine_iters,
        ..FitOptions::default()
    };
    let parts = pipeline::parts_dir(&args.output);
    let views = source.views().len();
    let selection = args
        .views
        .as_deref()
        .map(|spec| ViewSelection::parse(spec, views))
        .transpose()?;
    let labels: &[&str] = match opts.kind {
        ModelKind::Lm => &["LM", "done"],
        ModelKind::Plm => &["LM", "PLM", "done"],
        ModelKind::PlmC => &["LM", "PLM", "PLM-C", "done"],
    };
    let (_mp, bars) = stage_bars(selection.as_ref().map_or(views, |s| s.len()), labels);
    let start = std::time::Instant::now();
    let key = stitch.as_ref().map_or(0, |s| s.key());
    let stop = super::interrupt::stop_flag();
    let progress = |_, stage| {
        let i = match stage {
            Stage::Lm => 0,
            Stage::Plm => 1,
            Stage::PlmC => 2,
            Stage::Done => labels.len() - 1,
        };
        if let Some(b) = bars.get(i) {
            b.inc(1);
        }
    };
    if let Some(sel) = &selection {
        let done = pipeline::fit_views_keyed(source, &opts, key, &parts, sel, &stop, &progress)
            .with_context(|| format!("fitting views {sel} of {}", args.data.display()))?;
        bars.iter().for_each(|b| b.finish());
        println!(
            "views {sel}: {} fitted, {} already in {} ({:.1} s); {} not written",
            done.fitted,
            done.resumed,
            parts.display(),
            start.elapsed().as_secs_f64(),
            args.output.display()
        );
        if done.missing.is_empty() {
            println!(
                "all {views} views have parts: run the same command without --views to assemble {}",
                args.output.display()
            );
        } else {
            println!(
                "{} of {views} views still missing: {}",
                done.missing.len(),
                btfpt::fit::view_selection::describe(&done.missing)
            );
        }
        return Ok(());
    }
    let outcome = pipeline::fit_model_keyed(source, &opts, key, Some(&parts), &stop, &progress)
        .with_context(|| format!("fitting {}", args.data.display()))?;
    bars.iter().for_each(|b| b.finish());
    let section = stitch
        .as_ref()
        .map(codec::TileSection::from_stitch)
        .transpose()?;
    codec::write_tiled(&args.output, &outcome.model, section.as_ref())?;
    if !args.keep_parts {
        std::fs::remove_dir_all(&parts).with_context(|| format!("removing {}", parts.display()))?;
    }
    let bytes = std::fs::metadata(&args.output)
        .with_context(|| format!("reading size of {}", args.output.display()))?
        .len() as usize;
    println!(
        "{}: {} model, {} bytes ({}), fitted in {:.1} s{}",
        args.output.display(),
        opts.kind.name(),
        bytes,
        super::figures::compression(&outcome.model, bytes as u64),
        start.elapsed().as_secs_f64(),
        if outcome.resumed_views > 0 {
            format!(
                ", {} views resumed from {}",
                outcome.resumed_views,
                parts.display()
            )
        } else {
            String::new()
        }
    );
    if opts.kind == ModelKind::PlmC {
        let s = outcome.stats;
        if let Some(c) = super::figures::clusters(&outcome.model, Some(opts.clusters)) {
            println!("clusters: {c}");
        }
        println!(
            "cluster lobes: refit on members better for {}, averaged member parameters for {} (summed over views and channels), {} Lloyd iterations",
            s.refit_wins, s.average_wins, s.kmeans_iterations
        );
        if opts.refine_iters > 0 && outcome.resumed_views == 0 {
            let drop = if s.refine_error_before > 0.0 {
                100.0 * (1.0 - s.refine_error_after / s.refine_error_before)
            } else {
                0.0
            };
            println!(
                "refinement (not in the paper): {} rounds, {} texel moves, cluster-lobe L1 error -{drop:.1}%; second pass through the PLM-C mappings kept in {} of {views} views",
                s.refine_rounds, s.refine_moves, s.refine_second_kept
            );
        }
    }
    if opts.kind.has_polys() && outcome.resumed_views == 0 {
        let s = outcome.stats;
        println!(
            "mappings: histogram matching kept for {}, texel-wise regression (lower MAE) for {}",
            s.matched_polys, s.regression_polys
        );
    }
    Ok(())
}
