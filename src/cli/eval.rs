//! `btfpt eval mat.plmc --against DATA`: the paper's Table 1–2 for LM, PLM, PLM-C and per-view PCA.

use anyhow::Context;
use btfpt::btf;
use btfpt::btf::tiling;
use btfpt::fit::evaluate::{self, EvalReport};
use btfpt::fit::pipeline::FitOptions;
use btfpt::fit::report::{raw_bytes, view_error};
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

/// Seam and tile figures of a model: wrap-around seam ratios of the model's reconstruction, of the
/// data it was fitted to and of a naive crop, and for tiled models the tile's error against the
/// original region it came from.
#[derive(Debug, serde::Serialize)]
pub struct SeamReport {
    /// Seam ratio of the model's images (all views and lights).
    pub seam_ratio: f64,
    /// Seam ratio of the fitted data (the stitched tiles, or the whole sample).
    pub seam_ratio_data: f64,
    /// Seam ratio of a plain crop of the tile size at the template's origin (tiled models).
    pub seam_ratio_crop: Option<f64>,
    /// MAE (stored encoding) of the model's tile 0 against the sample region at the template
    /// origin, mean over views (tiled models).
    pub region_mae: Option<f64>,
}

/// Seam statistics and the region error, one pass over the views.
fn seams(
    data: &dyn btf::BtfSource,
    model: &btfpt::model::PlmcModel,
    stitch: Option<&tiling::Stitch>,
) -> anyhow::Result<SeamReport> {
    use rayon::prelude::*;
    let enc = data.encoding();
    let (tw, th) = stitch.map_or((model.width, model.height), |s| (s.tile_w, s.tile_h));
    let crop = stitch.map(|s| tiling::Stitch::crop(s.sample_w, s.sample_h, s.origin, tw, th));
    let n_in = data.width() * data.height() * 3;
    let n_model = model.width * model.height * 3;
    let n_tile = tw * th * 3;
    type PerView = ([tiling::SeamStats; 3], f64);
    let per_view: Vec<PerView> = (0..data.views().len())
        .into_par_iter()
        .map(|v| -> anyhow::Result<PerView> {
            let full = data.load_view(v)?;
            let mut recon = Vec::new();
            model.reconstruct_view(v, &mut recon);
            let mut st = [tiling::SeamStats::default(); 3];
            let (mut tiled, mut cropped) = (vec![0.0; n_model], vec![0.0; n_tile]);
            let mut region = 0.0;
            for (l, img) in full.chunks_exact(n_in).enumerate() {
                let rec = &recon[l * n_model..(l + 1) * n_model];
                st[0].add_image(rec, model.width, th, enc);
                match (stitch, &crop) {
                    (Some(s), Some(c)) => {
                        s.apply(img, &mut tiled);
                        st[1].add_image(&tiled, tw, th, enc);
                        c.apply(img, &mut cropped);
                        st[2].add_image(&cropped, tw, th, enc);
                        region += view_error(&cropped, &rec[..n_tile], enc).mae;
                    }
                    _ => st[1].add_image(img, tw, th, enc),
                }
            }
            Ok((st, region / (full.len() / n_in).max(1) as f64))
        })
        .collect::<anyhow::Result<_>>()?;
    let mut st = [tiling::SeamStats::default(); 3];
    for (p, _) in &per_view {
        for (a, b) in st.iter_mut().zip(p) {
            a.merge(b);
        }
    }
    let region = per_view.iter().map(|p| p.1).sum::<f64>() / per_view.len().max(1) as f64;
    Ok(SeamReport {
        seam_ratio: st[0].ratio(),
        seam_ratio_data: st[1].ratio(),
        seam_ratio_crop: stitch.map(|_| st[2].ratio()),
        region_mae: stitch.map(|_| region),
    })
}

/// Says so when the model was fitted to data of another encoding than `--against` holds (a model
/// fitted to 8-bit sRGB images against EXR data, or the reverse): its errors then mix two
/// encodings and are no measure of the fit.
fn warn_encoding_mismatch(
    args: &EvalArgs,
    model: &btfpt::model::PlmcModel,
    data: btf::StoredEncoding,
) {
    use btfpt::model::ValueSpace;
    let fitted_to = match model.space {
        ValueSpace::Srgb => "8-bit sRGB-encoded data (e.g. PNG/JPEG images)",
        ValueSpace::Linear => "linear float data (e.g. EXR images, .btf, synth:)",
    };
    let against = match data {
        btf::StoredEncoding::Srgb8 => "8-bit sRGB-encoded images",
        btf::StoredEncoding::Linear => "linear floats",
    };
    let same = matches!(
        (model.space, data),
        (ValueSpace::Srgb, btf::StoredEncoding::Srgb8)
            | (ValueSpace::Linear, btf::StoredEncoding::Linear)
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
    let (model, section) = codec::read_tiled(&args.model)?;
    let stitch = section
        .as_ref()
        .map(|t| t.stitch(&args.model))
        .transpose()?;
    let file_bytes = std::fs::metadata(&args.model)
        .with_context(|| format!("reading size of {}", args.model.display()))?
        .len() as usize;
    let data = btf::open(&super::btf_input::resolve(&args.against)?)?;
    warn_encoding_mismatch(&args, &model, data.encoding());
    let tiled = stitch
        .as_ref()
        .map(|s| tiling::TiledSource::new(&*data, s))
        .transpose()
        .with_context(|| {
            format!(
                "{} holds tiles cut from another sample than {}",
                args.model.display(),
                args.against.display()
            )
        })?;
    let source: &dyn btf::BtfSource = match &tiled {
        Some(t) => t,
        None => &*data,
    };
    let opts = FitOptions {
        clusters: args.clusters,
        features: args.features,
        seed: args.seed,
        ..FitOptions::default()
    };
    let (_mp, bars) = super::fit::stage_bars(source.views().len(), &["eval"]);
    let report = evaluate::evaluate(source, &model, file_bytes, &opts, args.pca_k, &|_| {
        bars[0].inc(1)
    })?;
    bars[0].finish();
    print_table(&report);
    let seam = seams(&*data, &model, stitch.as_ref())?;
    println!(
        "seam ratio (wrap-around / inside neighbour differences): model {:.3}, data {:.3}{}",
        seam.seam_ratio,
        seam.seam_ratio_data,
        seam.seam_ratio_crop
            .map_or(String::new(), |c| format!(", plain crop {c:.3}"))
    );
    let sample_raw = raw_bytes(
        data.views().len(),
        data.lights().len(),
        data.width() * data.height(),
    );
    if let (Some(s), Some(r)) = (&stitch, seam.region_mae) {
        println!(
            "tiles: {}×{} × {} of the {}×{} sample; file {}; the tiles stand in for the sample's \
             8-bit raw data at 1:{:.1}; MAE of tile 0 vs its original region {:.4}",
            s.tile_w,
            s.tile_h,
            s.count,
            s.sample_w,
            s.sample_h,
            super::figures::compression(&model, file_bytes as u64),
            sample_raw as f64 / file_bytes.max(1) as f64,
            r
        );
    }
    if let Some(p) = &args.json {
        let mut value = serde_json::to_value(&report)?;
        if let Some(obj) = value.as_object_mut() {
            obj.insert("seam_ratio".into(), serde_json::json!(seam.seam_ratio));
            obj.insert("seams".into(), serde_json::to_value(&seam)?);
            if let Some(s) = &stitch {
                obj.insert(
                    "tile".into(),
                    serde_json::json!({
                        "tile_w": s.tile_w,
                        "tile_h": s.tile_h,
                        "count": s.count,
                        "sample_w": s.sample_w,
                        "sample_h": s.sample_h,
                        "origin": [s.origin.0, s.origin.1],
                        "patches": s.patches,
                        "overlap": s.overlap,
                        "cut_error": s.cut_error,
                        "sample_raw_bytes": sample_raw,
                        "file_bytes": file_bytes,
                        "ratio": super::figures::ratio(&model, file_bytes as u64),
                        "ratio_vs_sample": sample_raw as f64 / file_bytes.max(1) as f64,
                        "region_mae": seam.region_mae,
                    }),
                );
            }
        }
        let text = serde_json::to_string_pretty(&value)?;
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
