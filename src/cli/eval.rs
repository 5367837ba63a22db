//! `btfpt eval mat.plmc --against DATA`: the paper's Table 1–2 for LM, PLM, PLM-C and per-view PCA.

use anyhow::Context;
use btfpt::btf::{self, format};
use btfpt::fit::evaluate::{self, EvalReport};
use btfpt::fit::pipeline::FitOptions;
use std::path::PathBuf;

/// Evaluate a .plmc model (and refits of the other models) against the measured data.
#[derive(clap::Args, Debug)]
pub struct EvalArgs {
    /// The model file.
    pub model: PathBuf,
    /// The measured BTF the model was fitted to.
    #[arg(long)]
    pub against: PathBuf,
    /// Write the table as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write a per-view MAE plot (PNG) here: LM blue, PLM green, PLM-C red, PCA grey; grid 0.01.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// PCA components per view (default: matched to each view's PLM-C size).
    #[arg(long)]
    pub pca_k: Option<usize>,
    /// K-means features for a PLM-C refit (when the file is not PLM-C).
    #[arg(long, default_value_t = 20)]
    pub features: usize,
    /// Clusters for a PLM-C refit (when the file is not PLM-C).
    #[arg(long, default_value_t = 256)]
    pub clusters: usize,
    /// Seed for a PLM-C refit.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

/// Prints the table.
pub fn print_table(r: &EvalReport) {
    println!(
        "{:<6} {:>9} {:>11} {:>9} {:>12} {:>9}",
        "model", "MAE", "MAE linear", "RMSE", "bytes", "ratio"
    );
    for name in ["lm", "plm", "plmc", "pca"] {
        if let Some(m) = r.models.get(name) {
            let src = if name == r.from_file {
                " (file)"
            } else if name == "pca" {
                " (baseline)"
            } else {
                " (refit)"
            };
            println!(
                "{:<6} {:>9.4} {:>11.4} {:>9.4} {:>12} {:>8.1}{}",
                name, m.mae, m.mae_linear, m.rmse, m.bytes, m.ratio, src
            );
        }
    }
    println!(
        "raw (8-bit RGB): {} bytes; MAE/RMSE in the data's stored encoding, per view then mean",
        r.raw_bytes
    );
}

/// Runs `btfpt eval`.
pub fn run(args: EvalArgs) -> anyhow::Result<()> {
    let model = format::read(&args.model)?;
    let file_bytes = std::fs::metadata(&args.model)
        .with_context(|| format!("reading size of {}", args.model.display()))?
        .len() as usize;
    let source = btf::open(&args.against)?;
    let opts = FitOptions {
        clusters: args.clusters,
        features: args.features,
        seed: args.seed,
        ..FitOptions::default()
    };
    let (_mp, bars) = super::fit::stage_bars(source.views().len(), &["eval"]);
    let report = evaluate::evaluate(&*source, &model, file_bytes, &opts, args.pca_k, &|_| {
        bars[0].inc(1)
    })?;
    bars[0].finish();
    print_table(&report);
    if let Some(p) = &args.json {
        let text = serde_json::to_string_pretty(&report)?;
        btfpt::io::write_atomic(p, |w| {
            w.write_all(text.as_bytes())
                .map_err(|e| btfpt::Error::io(p, e))
        })?;
    }
    if let Some(p) = &args.plot {
        btfpt::fit::plot::per_view_mae(p, &report)?;
    }
    Ok(())
}
