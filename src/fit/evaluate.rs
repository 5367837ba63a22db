//! `btfpt eval`: reconstructs LM, PLM, PLM-C and the PCA baseline at the measured directions and
//! measures them against the data. The model read from the file is used for its own kind; the
//! other kinds are refitted from the data with the same code and options (deterministic), and
//! their sizes are the exact sizes their `.plmc` files would have.

use super::pipeline::{self, FitOptions, Stage};
use super::report::{ModelReport, ViewError, raw_bytes, view_error};
use super::{lafortune::LobeFitter, pca};
use crate::btf::BtfSource;
use crate::model::codec;
use crate::model::{ModelKind, PlmcModel};
use crate::{Error, Result};
use rayon::prelude::*;
use std::collections::BTreeMap;

/// The evaluation table.
#[derive(Clone, Debug, serde::Serialize)]
pub struct EvalReport {
    /// "lm", "plm", "plmc", "pca".
    pub models: BTreeMap<String, ModelReport>,
    /// 8-bit RGB per texel per image.
    pub raw_bytes: usize,
    /// Which kind came from the file (the others are refits).
    pub from_file: String,
    /// PCA components used per view (size-matched to PLM-C unless fixed).
    pub pca_components: Vec<usize>,
}

/// Evaluates `model` (whose file has `file_bytes` bytes) against `source`. `pca_k` fixes the PCA
/// component count; `None` matches each view's PCA size to its PLM-C size.
pub fn evaluate(
    source: &dyn BtfSource,
    model: &PlmcModel,
    file_bytes: usize,
    opts: &FitOptions,
    pca_k: Option<usize>,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<EvalReport> {
    if model.width != source.width()
        || model.height != source.height()
        || model.views != *source.views()
        || model.lights != *source.lights()
    {
        return Err(Error::Invalid(format!(
            "the model ({}×{} texels, {} views, {} lights) does not match the data ({}×{}, {} views, {} lights)",
            model.width,
            model.height,
            model.views.len(),
            model.lights.len(),
            source.width(),
            source.height(),
            source.views().len(),
            source.lights().len()
        )));
    }
    let fitter = LobeFitter::new(&source.lights().dirs)?;
    let texels = source.width() * source.height();
    let nl = source.lights().len();
    let dims = 3 * nl;
    let enc = source.encoding();
    let refit_kind = if model.kind == ModelKind::PlmC {
        ModelKind::Plm
    } else {
        ModelKind::PlmC
    };
    let refit_opts = FitOptions {
        kind: refit_kind,
        fit_stored: model.space == crate::model::ValueSpace::Srgb,
        clusters: if model.kind == ModelKind::PlmC {
            model.clusters
        } else {
            opts.clusters
        },
        ..*opts
    };
    struct PerView {
        err: [ViewError; 4],
        section: [usize; 3],
        /// POLY record bytes of the view, per kind.
        poly: [usize; 3],
        k: usize,
    }
    let kinds = [ModelKind::Lm, ModelKind::Plm, ModelKind::PlmC];
    let per_view: Vec<PerView> = (0..source.views().len())
        .into_par_iter()
        .map(|v| -> Result<PerView> {
            let data = source.load_view(v)?;
            let fit = pipeline::fit_view(
                &fitter,
                source.lights(),
                &data,
                texels,
                enc,
                &refit_opts,
                &|_: Stage| {},
            );
            let mut recon = Vec::new();
            let mut err = [ViewError::default(); 4];
            let mut section = [0usize; 3];
            let mut poly = [0usize; 3];
            for (i, &kind) in kinds.iter().enumerate() {
                if kind == model.kind {
                    model.reconstruct_view(v, &mut recon);
                    section[i] = codec::view_section_size(v, &model.params[v], model.clusters)?;
                    if kind.has_polys() {
                        let n = model.lights.len() * 3;
                        poly[i] = codec::poly_bytes(&model.polys[v * n..(v + 1) * n])?;
                    }
                } else {
                    let m = pipeline::view_model(
                        source,
                        v,
                        &fit,
                        kind,
                        refit_opts.clusters,
                        model.space,
                    )
                    .ok_or_else(|| {
                        Error::Invalid(format!("view {v}: {} was not refitted", kind.name()))
                    })?;
                    m.reconstruct_view(0, &mut recon);
                    section[i] = codec::view_section_size(v, &m.params[0], m.clusters)?;
                    poly[i] = codec::poly_bytes(&m.polys)?;
                }
                err[i] = view_error(&data, &recon, enc);
            }
            let k = pca_k.unwrap_or_else(|| pca::k_for_budget(dims, texels, section[2] + poly[2]));
            pca::reconstruct_view(&data, texels, k, &mut recon);
            err[3] = view_error(&data, &recon, enc);
            progress(v);
            Ok(PerView {
                err,
                section,
                poly,
                k,
            })
        })
        .collect::<Result<_>>()?;
    let raw = raw_bytes(source.views().len(), nl, texels);
    let mut models = BTreeMap::new();
    for (i, &kind) in kinds.iter().enumerate() {
        let bytes = if kind == model.kind {
            file_bytes
        } else {
            let mut skel = model.clone();
            skel.kind = kind;
            skel.params.clear();
            skel.polys.clear();
            skel.clusters = if kind == ModelKind::PlmC {
                refit_opts.clusters
            } else {
                0
            };
            codec::file_size(
                &skel,
                per_view.iter().map(|p| p.section[i]).sum(),
                per_view.iter().map(|p| p.poly[i]).sum(),
            )?
        };
        let errs: Vec<ViewError> = per_view.iter().map(|p| p.err[i]).collect();
        models.insert(
            kind.name().to_string(),
            ModelReport::from_views(&errs, bytes, raw),
        );
    }
    let pca_bytes = per_view
        .iter()
        .map(|p| pca::view_bytes(dims, texels, p.k))
        .sum();
    let errs: Vec<ViewError> = per_view.iter().map(|p| p.err[3]).collect();
    models.insert("pca".into(), ModelReport::from_views(&errs, pca_bytes, raw));
    Ok(EvalReport {
        models,
        raw_bytes: raw,
        from_file: model.kind.name().into(),
        pca_components: per_view.iter().map(|p| p.k).collect(),
    })
}
