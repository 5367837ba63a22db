//! The fitting pipeline raw BTF → LM → PLM → PLM-C, per view (the paper fits every view
//! separately so view-dependent masking and parallax stay in the per-view parameters).
//!
//! Space: by default lobes and polynomials are fitted in the data's stored encoding (sRGB for 8-bit
//! data, as the paper fits the 8-bit pixels; its MAE is measured there too); the model records its
//! [`ValueSpace`] and the renderer decodes. With `fit_stored = false` (or linear data) they are
//! fitted to the linear cosine-baked values. K-means features are in the stored encoding: by default
//! the texels' LM-model values, not the original pixels the paper clusters (see [`ClusterOn`]).
//!
//! Departures from the paper, each measured and switchable: the K-means clusters are refined in
//! model space ([`refine`], `FitOptions::refine_iters`, 0 = off) and the mapping regression
//! minimises the absolute error (see [`fit_polys`]).
//!
//! Files: `options.rs` (settings), `view_fit.rs` (one view's LM → PLM → PLM-C), `parts.rs` (part
//! files), this file (the whole model: fingerprints, resumption, assembly).

pub use super::options::{ClusterOn, FitOptions, Stage, value_space};
pub use super::view_fit::{ViewFit, ViewStats, fit_view};

use super::lafortune::LobeFitter;
use super::parts;
use super::view_selection::ViewSelection;
use crate::btf::{BtfSource, DirectionSet};
use crate::model::polynomial::Poly;
use crate::model::{ModelKind, PlmcModel, ValueSpace, ViewParams};
use crate::{Error, Result};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// A hash of everything that determines a view's fit, so parts of another fit are not reused.
pub fn fingerprint(source: &dyn BtfSource, opts: &FitOptions) -> u64 {
    fingerprint_keyed(source, opts, 0)
}

/// [`fingerprint`] that also covers `key` (a hash of how the source was derived, e.g. the tile
/// stitch); key 0 gives the plain fingerprint.
pub fn fingerprint_keyed(source: &dyn BtfSource, opts: &FitOptions, key: u64) -> u64 {
    use crate::math::rng::mix64;
    let mut h = 0x504c_4d43u64;
    let mut add = |v: u64| h = mix64(h ^ v);
    add(opts.kind.code() as u64);
    add(opts.clusters as u64);
    add(opts.features as u64);
    add(opts.seed);
    add(opts.kmeans_iters as u64);
    add(opts.fit_stored as u64);
    add(opts.cluster_on as u64);
    add(opts.refine_iters as u64);
    add(source.width() as u64);
    add(source.height() as u64);
    add(source.encoding() as u64);
    for d in source
        .views()
        .angles_deg
        .iter()
        .chain(&source.lights().angles_deg)
    {
        add(d.0.to_bits() as u64);
        add(d.1.to_bits() as u64);
    }
    add(FIT_CODE_VERSION);
    if key != 0 {
        add(key);
    }
    h
}

/// Bumped whenever the fitting code changes results, so stale parts are refitted.
const FIT_CODE_VERSION: u64 = 5;

/// The sidecar directory holding finished views of an interrupted fit: `mat.plmc.parts/`.
pub fn parts_dir(output: &Path) -> PathBuf {
    let mut name = output
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    name.push(".parts");
    output.with_file_name(name)
}

/// Result of [`fit_model`].
#[derive(Clone, Debug)]
pub struct FitOutcome {
    pub model: PlmcModel,
    /// Views taken from part files of an earlier, interrupted run.
    pub resumed_views: usize,
    /// Summed per-view statistics.
    pub stats: ViewStats,
}

/// The empty model (no views yet) for a source and options.
fn skeleton(
    source: &dyn BtfSource,
    kind: ModelKind,
    clusters: usize,
    space: ValueSpace,
) -> PlmcModel {
    PlmcModel {
        space,
        kind,
        views: source.views().clone(),
        lights: source.lights().clone(),
        width: source.width(),
        height: source.height(),
        clusters: if kind == ModelKind::PlmC { clusters } else { 0 },
        params: Vec::new(),
        polys: Vec::new(),
    }
}

/// The model of kind `kind` from one view's fit (a complete one-view model).
pub fn view_model(
    source: &dyn BtfSource,
    view: usize,
    fit: &ViewFit,
    kind: ModelKind,
    clusters: usize,
    space: ValueSpace,
) -> Option<PlmcModel> {
    let mut m = skeleton(source, kind, clusters, space);
    m.views = DirectionSet::from_angles_deg(vec![source.views().angles_deg[view]]);
    match kind {
        ModelKind::Lm => m.params.push(ViewParams::Texel(fit.lm.clone())),
        ModelKind::Plm => {
            if fit.plm_polys.is_empty() {
                return None;
            }
            m.params.push(ViewParams::Texel(fit.lm.clone()));
            m.polys = fit.plm_polys.clone();
        }
        ModelKind::PlmC => {
            let (p, polys) = fit.plmc.clone()?;
            if let ViewParams::Clustered { k, .. } = &p {
                m.clusters = m.clusters.max(*k);
            }
            m.params.push(p);
            m.polys = polys;
        }
    }
    Some(m)
}

/// Fits a whole BTF, views in parallel. With `parts`, every finished view is saved there first and
/// views already present (same fingerprint) are reused, so a killed fit resumes; the caller
/// removes the directory after writing the final model.
pub fn fit_model(
    source: &dyn BtfSource,
    opts: &FitOptions,
    parts: Option<&Path>,
    progress: &(dyn Fn(usize, Stage) + Sync),
) -> Result<FitOutcome> {
    fit_model_keyed(source, opts, 0, parts, &AtomicBool::new(false), progress)
}

/// [`fit_model`] whose part files are keyed by `key` too (see [`fingerprint_keyed`]), for sources
/// derived from the data (tiles), so parts of another derivation are never reused. Once `stop` is
/// set (a signal handler) no further view is started; views already running finish and are saved,
/// then the fit returns [`Error::Interrupted`] saying how many views are kept.
pub fn fit_model_keyed(
    source: &dyn BtfSource,
    opts: &FitOptions,
    key: u64,
    parts: Option<&Path>,
    stop: &AtomicBool,
    progress: &(dyn Fn(usize, Stage) + Sync),
) -> Result<FitOutcome> {
    let run = fit_selected(source, opts, key, parts, &|_| true, stop, progress)?;
    let views: Vec<_> = run
        .views
        .into_iter()
        .map(|v| v.ok_or_else(|| Error::Invalid("a view was not fitted".into())))
        .collect::<Result<_>>()?;
    let mut model = skeleton(
        source,
        opts.kind,
        opts.clusters,
        value_space(source.encoding(), opts),
    );
    let mut stats = ViewStats::default();
    for (p, polys, s) in views {
        model.params.push(p);
        model.polys.extend(polys);
        stats.refit_wins += s.refit_wins;
        stats.average_wins += s.average_wins;
        stats.clusters += s.clusters;
        stats.kmeans_iterations += s.kmeans_iterations;
        stats.matched_polys += s.matched_polys;
        stats.regression_polys += s.regression_polys;
        stats.refine_moves += s.refine_moves;
        stats.refine_rounds += s.refine_rounds;
        stats.refine_error_before += s.refine_error_before;
        stats.refine_error_after += s.refine_error_after;
        stats.refine_second_kept += s.refine_second_kept;
    }
    model.validate()?;
    Ok(FitOutcome {
        model,
        resumed_views: run.resumed,
        stats,
    })
}

/// Result of [`fit_views_keyed`].
#[derive(Clone, Debug)]
pub struct PartsOutcome {
    /// Selected views fitted by this run.
    pub fitted: usize,
    /// Selected views whose parts were already there.
    pub resumed: usize,
    /// Views of the whole BTF that still have no part file (the assembling run fits them).
    pub missing: Vec<usize>,
}

/// Fits only the `views` selected into the parts directory `parts` (no model is assembled), so
/// one fit is split over processes or machines: a later [`fit_model_keyed`] with the same options
/// and parts directory finds every part and only assembles, refitting nothing. Parts already there
/// are reused; parts of another fit are refused as in [`fit_model_keyed`].
pub fn fit_views_keyed(
    source: &dyn BtfSource,
    opts: &FitOptions,
    key: u64,
    parts: &Path,
    views: &ViewSelection,
    stop: &AtomicBool,
    progress: &(dyn Fn(usize, Stage) + Sync),
) -> Result<PartsOutcome> {
    let run = fit_selected(
        source,
        opts,
        key,
        Some(parts),
        &|v| views.contains(v),
        stop,
        progress,
    )?;
    let missing = (0..source.views().len())
        .filter(|&v| !part_path(parts, v).exists())
        .collect();
    Ok(PartsOutcome {
        fitted: views.len() - run.resumed,
        resumed: run.resumed,
        missing,
    })
}

/// The part file of view `v` in a parts directory.
fn part_path(parts: &Path, v: usize) -> PathBuf {
    parts.join(format!("view{v:05}.part"))
}

/// Refuses a parts directory holding a part of another fit (other options, data, tiles or code
/// version), so parts are never mixed. Corrupt parts (a crash of the machine) pass: they are
/// refitted. Temporaries and unrelated files are ignored.
fn check_parts(parts: &Path, fp: u64, views: usize) -> Result<()> {
    for v in 0..views {
        let p = part_path(parts, v);
        if !p.exists() {
            continue;
        }
        let bytes = std::fs::read(&p).map_err(|e| Error::io(&p, e))?;
        if let Ok(None) = parts::part_from_bytes(&bytes, &p, fp, v) {
            return Err(Error::format(
                &p,
                format!(
                    "written by a fit with other options, data or btfpt version; parts are never \
                     mixed: rerun with the options that made {}, or remove it to start over",
                    parts.display()
                ),
            ));
        }
    }
    Ok(())
}

/// One view's fitted parameters, mapping polynomials and statistics.
type ViewResult = (ViewParams, Vec<Poly>, ViewStats);

/// What [`fit_selected`] produced: per view, its result if it was selected.
struct SelectedRun {
    views: Vec<Option<ViewResult>>,
    resumed: usize,
}

/// Fits the views for which `selected` holds, in parallel, reusing and writing parts in `parts`.
fn fit_selected(
    source: &dyn BtfSource,
    opts: &FitOptions,
    key: u64,
    parts: Option<&Path>,
    selected: &(dyn Fn(usize) -> bool + Sync),
    stop: &AtomicBool,
    progress: &(dyn Fn(usize, Stage) + Sync),
) -> Result<SelectedRun> {
    if opts.kind == ModelKind::PlmC && !(1..=65536).contains(&opts.clusters) {
        return Err(Error::Invalid(format!(
            "--clusters must be in 1..=65536, got {}",
            opts.clusters
        )));
    }
    if opts.kind == ModelKind::PlmC && opts.features == 0 {
        return Err(Error::Invalid("--features must be at least 1".into()));
    }
    let fitter = LobeFitter::new(&source.lights().dirs)?;
    let fp = fingerprint_keyed(source, opts, key);
    if let Some(dir) = parts {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        check_parts(dir, fp, source.views().len())?;
    }
    let texels = source.width() * source.height();
    let resumed = AtomicUsize::new(0);
    let finished = AtomicUsize::new(0);
    let result: Result<Vec<Option<ViewResult>>> = (0..source.views().len())
        .into_par_iter()
        .map(|v| -> Result<Option<ViewResult>> {
            if !selected(v) {
                return Ok(None);
            }
            if stop.load(Ordering::SeqCst) {
                return Err(Error::Interrupted(String::new()));
            }
            let part_path = parts.map(|d| part_path(d, v));
            if let Some(p) = &part_path
                && p.exists()
            {
                let bytes = std::fs::read(p).map_err(|e| Error::io(p, e))?;
                // A corrupt part (e.g. from a crash of the machine) is simply refitted.
                if let Ok(Some(mut m)) = parts::part_from_bytes(&bytes, p, fp, v)
                    && m.params.len() == 1
                    && m.width * m.height == texels
                {
                    resumed.fetch_add(1, Ordering::Relaxed);
                    finished.fetch_add(1, Ordering::Relaxed);
                    progress(v, Stage::Done);
                    return Ok(Some((m.params.remove(0), m.polys, ViewStats::default())));
                }
            }
            let data = source.load_view(v)?;
            if let Some(i) = data.iter().position(|x| !x.is_finite()) {
                return Err(Error::Invalid(format!(
                    "view {v}: measured value #{i} is NaN or infinite; the data must be finite"
                )));
            }
            let fit = fit_view(
                &fitter,
                source.lights(),
                &data,
                texels,
                source.encoding(),
                opts,
                &|s| progress(v, s),
            );
            let m = view_model(
                source,
                v,
                &fit,
                opts.kind,
                opts.clusters,
                value_space(source.encoding(), opts),
            )
            .ok_or_else(|| Error::Invalid(format!("view {v}: requested level was not fitted")))?;
            if let Some(p) = &part_path {
                let bytes = parts::part_to_bytes(fp, v, &m)?;
                crate::io::write_atomic(p, |w| w.write_all(&bytes).map_err(|e| Error::io(p, e)))?;
            }
            finished.fetch_add(1, Ordering::Relaxed);
            progress(v, Stage::Done);
            let mut m = m;
            Ok(Some((m.params.remove(0), m.polys, fit.stats)))
        })
        .collect();
    // Rayon returns only after the views already running have finished (and saved their parts),
    // so `finished` is final here.
    match result {
        Err(Error::Interrupted(_)) => {
            let kept = match parts {
                Some(dir) => format!(
                    "kept in {} (run the same command again to continue)",
                    dir.display()
                ),
                None => "not kept (no parts directory)".into(),
            };
            let total = (0..source.views().len()).filter(|&v| selected(v)).count();
            Err(Error::Interrupted(format!(
                "interrupted: {} of {total} views finished, {kept}",
                finished.load(Ordering::SeqCst),
            )))
        }
        Err(e) => Err(e),
        Ok(views) => Ok(SelectedRun {
            views,
            resumed: resumed.into_inner(),
        }),
    }
}

#[cfg(test)]
mod tests;
