//! `btfpt eval` as a library call: a model file evaluated against the measured data it was
//! fitted to, with the paper's error table ([`evaluate`]), the seam figures of its images, and
//! for tiled models the tile's figures; [`FileEvaluation::json`] is the document `eval --json`
//! writes (the CLI and the Python module both use it).

use super::evaluate::{self, EvalReport};
use super::options::FitOptions;
use super::report::{raw_bytes, view_error};
use crate::btf::{self, tiling};
use crate::model::{PlmcModel, codec};
use crate::{Error, Result};
use std::path::Path;

/// Everything `btfpt eval` prints and writes about one model file.
pub struct FileEvaluation {
    /// The model read from the file.
    pub model: PlmcModel,
    /// The error table of the model and the refits.
    pub report: EvalReport,
    /// Seam ratios (and the tile's error against its region, for tiled models).
    pub seams: SeamReport,
    /// The tiles' cut, for a tiled model.
    pub stitch: Option<tiling::Stitch>,
    /// Size of the model file in bytes.
    pub file_bytes: usize,
    /// 8-bit RGB raw size of the whole measured sample, in bytes.
    pub sample_raw: usize,
    /// How the measured data stores its values (to tell a model fitted to another encoding).
    pub data_encoding: btf::StoredEncoding,
}

/// Evaluates the model file `model_path` against the measured BTF `data_path` (see the module
/// doc); `progress` is called once per evaluated view.
pub fn evaluate_file(
    model_path: &Path,
    data_path: &Path,
    opts: &FitOptions,
    pca_k: Option<usize>,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<FileEvaluation> {
    let (model, section) = codec::read_tiled(model_path)?;
    let stitch = section.as_ref().map(|t| t.stitch(model_path)).transpose()?;
    let file_bytes = std::fs::metadata(model_path)
        .map_err(|e| Error::io(model_path, e))?
        .len() as usize;
    let data = btf::open(data_path)?;
    let tiled = stitch
        .as_ref()
        .map(|s| tiling::TiledSource::new(&*data, s))
        .transpose()
        .map_err(|e| {
            Error::Invalid(format!(
                "{} holds tiles cut from another sample than {}: {e}",
                model_path.display(),
                data_path.display()
            ))
        })?;
    let source: &dyn btf::BtfSource = match &tiled {
        Some(t) => t,
        None => &*data,
    };
    let report = evaluate::evaluate(source, &model, file_bytes, opts, pca_k, progress)?;
    let seams = seams(&*data, &model, stitch.as_ref())?;
    let sample_raw = raw_bytes(
        data.views().len(),
        data.lights().len(),
        data.width() * data.height(),
    );
    Ok(FileEvaluation {
        model,
        report,
        seams,
        stitch,
        file_bytes,
        sample_raw,
        data_encoding: data.encoding(),
    })
}

impl FileEvaluation {
    /// The compression ratio of the model file: 8-bit RGB raw size of the texels the model
    /// stores / file size (docs/model.md).
    pub fn ratio(&self) -> f64 {
        let m = &self.model;
        raw_bytes(m.views.len(), m.lights.len(), m.width * m.height) as f64
            / self.file_bytes.max(1) as f64
    }

    /// The document `btfpt eval --json` writes: the error table, the seam figures and, for
    /// tiled models, the tile's.
    pub fn json(&self) -> Result<serde_json::Value> {
        let to_value = |v: serde_json::Result<serde_json::Value>| {
            v.map_err(|e| Error::Invalid(format!("cannot serialise the evaluation: {e}")))
        };
        let mut value = to_value(serde_json::to_value(&self.report))?;
        let seams = to_value(serde_json::to_value(&self.seams))?;
        if let Some(obj) = value.as_object_mut() {
            obj.insert(
                "seam_ratio".into(),
                serde_json::json!(self.seams.seam_ratio),
            );
            obj.insert("seams".into(), seams);
            if let Some(s) = &self.stitch {
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
                        "sample_raw_bytes": self.sample_raw,
                        "file_bytes": self.file_bytes,
                        "ratio": self.ratio(),
                        "ratio_vs_sample": self.sample_raw as f64 / self.file_bytes.max(1) as f64,
                        "region_mae": self.seams.region_mae,
                    }),
                );
            }
        }
        Ok(value)
    }
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
    model: &PlmcModel,
    stitch: Option<&tiling::Stitch>,
) -> Result<SeamReport> {
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
        .map(|v| -> Result<PerView> {
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
        .collect::<Result<_>>()?;
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
