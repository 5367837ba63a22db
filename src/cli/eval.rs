//! `btfpt eval mat.plmc --against DATA`: the paper's Table 1–2 for LM, PLM, PLM-C and per-view PCA.

use btfpt::fit::eval_file::evaluate_file;
use btfpt::fit::evaluate::EvalReport;
use btfpt::fit::pipeline::FitOptions;
use btfpt::model::codec;
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

/// Says so when the model was fitted to data of another encoding than `--against` holds (a model
/// fitted to 8-bit sRGB images against EXR data, or the reverse): its errors then mix two
/// encodings and are no measure of the fit.
fn warn_encoding_mismatch(
    args: &EvalArgs,
    model: &btfpt::model::PlmcModel,
    data: btfpt::btf::StoredEncoding,
) {
    use btfpt::btf::StoredEncoding;
    use btfpt::model::ValueSpace;
    let fitted_to = match model.space {
        ValueSpace::Srgb => "8-bit sRGB-encoded data (e.g. PNG/JPEG images)",
        ValueSpace::Linear => "linear float data (e.g. EXR images, .btf, synth:)",
    };
    let against = match data {
        StoredEncoding::Srgb8 => "8-bit sRGB-encoded images",
        StoredEncoding::Linear => "linear floats",
    };
    let same = matches!(
        (model.space, data),
        (ValueSpace::Srgb, StoredEncoding::Srgb8) | (ValueSpace::Linear, StoredEncoding::Linear)
    );
    if !same {
        eprintln!(
            "warning: {} was fitted to {fitted_to}, but {} holds {against}: the errors below \
             compare two encodings (MAE/RMSE in the stored encoding of {}), not the fit; \
             evaluate against the data the model was fitted to",
            args.model.display(),
            args.against.display(),
            args.against.display()
        );
    }
}

/// Runs `btfpt eval`.
pub fn run(args: EvalArgs) -> anyhow::Result<()> {
    super::output::check_optional_file(args.json.as_ref())?;
    super::output::optional_image_file(
        args.plot.as_ref(),
        &[super::output::ImageFile::Png],
        "--plot",
    )?;
    let against = super::btf_input::resolve(&args.against)?;
    let opts = FitOptions {
        clusters: args.clusters,
        features: args.features,
        seed: args.seed,
        ..FitOptions::default()
    };
    let views = codec::read_header(&args.model)?.views.len();
    let (_mp, bars) = super::fit::stage_bars(views, &["eval"]);
    let e = evaluate_file(&args.model, &against, &opts, args.pca_k, &|_| {
        bars[0].inc(1)
    })?;
    bars[0].finish();
    warn_encoding_mismatch(&args, &e.model, e.data_encoding);
    let (model, report, seam) = (&e.model, &e.report, &e.seams);
    print_table(report);
    println!(
        "seam ratio (wrap-around / inside neighbour differences): model {:.3}, data {:.3}{}",
        seam.seam_ratio,
        seam.seam_ratio_data,
        seam.seam_ratio_crop
            .map_or(String::new(), |c| format!(", plain crop {c:.3}"))
    );
    if let (Some(s), Some(r)) = (&e.stitch, seam.region_mae) {
        println!(
            "tiles: {}×{} × {} of the {}×{} sample; file {}; the tiles stand in for the sample's \
             8-bit raw data at 1:{:.1}; MAE of tile 0 vs its original region {:.4}",
            s.tile_w,
            s.tile_h,
            s.count,
            s.sample_w,
            s.sample_h,
            super::figures::compression(model, e.file_bytes as u64),
            e.sample_raw as f64 / e.file_bytes.max(1) as f64,
            r
        );
    }
    if let Some(p) = &args.json {
        let text = serde_json::to_string_pretty(&e.json()?)?;
        btfpt::io::write_atomic(p, |w| {
            w.write_all(text.as_bytes())
                .map_err(|e| btfpt::Error::io(p, e))
        })?;
    }
    if let Some(p) = &args.plot {
        btfpt::fit::plot::per_view_mae(p, report)?;
    }
    Ok(())
}
