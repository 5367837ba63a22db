//! The fitting pipeline raw BTF → LM → PLM → PLM-C, per view (the paper fits every view
//! separately so view-dependent masking and parallax stay in the per-view parameters).
//!
//! Space: lobes and polynomials are fitted to the linear, cosine-baked values (what the renderer
//! needs). K-means features are the original values in the data's stored encoding (sRGB for 8-bit
//! data) — the paper clusters the original pixels, and that is also the space its MAE is in.

use super::kmeans;
use super::lafortune::{self, Lobe, LobeFitter};
use super::model::{ModelKind, PackedLobe, PlmcModel, ViewParams};
use super::polynomial::{self, Poly};
use super::select;
use crate::btf::{BtfSource, DirectionSet, StoredEncoding, format};
use crate::math::color::linear_to_srgb;
use crate::{Error, Result};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Fitting settings (the `btfpt fit` options).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitOptions {
    pub kind: ModelKind,
    /// K of K-means per view and channel (PLM-C).
    pub clusters: usize,
    /// Images chosen by KL selection as K-means features (PLM-C).
    pub features: usize,
    /// Seed of the k-means++ initialisation.
    pub seed: u64,
    /// Cap on Lloyd iterations.
    pub kmeans_iters: usize,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            kind: ModelKind::PlmC,
            clusters: 256,
            features: 20,
            seed: 0,
            kmeans_iters: 40,
        }
    }
}

/// Pipeline stages reported to the progress callback (once per view each).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Per-texel Lafortune fits done.
    Lm,
    /// Per-image polynomials done.
    Plm,
    /// Clustering and cluster refits done.
    PlmC,
    /// View finished (fitted now or taken from a part file).
    Done,
}

/// Statistics of one view's fit.
#[derive(Clone, Copy, Debug, Default)]
pub struct ViewStats {
    /// Clusters where refitting the LM on the members beat averaging their parameters.
    pub refit_wins: usize,
    /// Clusters where the averaged member parameters were better.
    pub average_wins: usize,
    /// Clusters actually produced (summed over channels).
    pub clusters: usize,
    /// Lloyd iterations (summed over channels).
    pub kmeans_iterations: usize,
}

/// One view's result: the parameters at the requested level, its polynomials and the
/// intermediate levels (for evaluation without refitting).
#[derive(Clone, Debug)]
pub struct ViewFit {
    /// Per-texel LM lobes `[texel][channel]`.
    pub lm: Vec<PackedLobe>,
    /// PLM polynomials `[light][channel]` (empty if not requested).
    pub plm_polys: Vec<Poly>,
    /// PLM-C parameters and polynomials (if requested).
    pub plmc: Option<(ViewParams, Vec<Poly>)>,
    pub stats: ViewStats,
}

fn plane(data: &[f32], texels: usize, light: usize, channel: usize, out: &mut Vec<f32>) {
    out.clear();
    out.extend((0..texels).map(|t| data[(light * texels + t) * 3 + channel]));
}

/// Fits one view from its images `data` = `[light][texel][rgb]` (linear).
pub fn fit_view(
    fitter: &LobeFitter,
    lights: &DirectionSet,
    data: &[f32],
    texels: usize,
    encoding: StoredEncoding,
    opts: &FitOptions,
    stage: &(dyn Fn(Stage) + Sync),
) -> ViewFit {
    let nl = lights.len();
    // LM: one lobe per texel and channel.
    let lm: Vec<PackedLobe> = (0..texels * 3)
        .into_par_iter()
        .with_min_len(256)
        .map_init(
            || vec![0.0f32; nl],
            |y, i| {
                let (t, c) = (i / 3, i % 3);
                for (l, v) in y.iter_mut().enumerate() {
                    *v = data[(l * texels + t) * 3 + c];
                }
                PackedLobe::pack(&fitter.fit(y).lobe)
            },
        )
        .collect();
    stage(Stage::Lm);
    let lm_lobes: Vec<Lobe> = lm.iter().map(|p| p.unpack()).collect();
    let mut out = ViewFit {
        lm,
        plm_polys: Vec::new(),
        plmc: None,
        stats: ViewStats::default(),
    };
    if opts.kind == ModelKind::Lm {
        return out;
    }
    out.plm_polys = fit_polys(lights, data, texels, |t, c, u| lafortune::eval(&lm_lobes[3 * t + c], u));
    stage(Stage::Plm);
    if opts.kind == ModelKind::Plm {
        return out;
    }

    // PLM-C, per channel.
    let mut tables: [Vec<Lobe>; 3] = Default::default();
    let mut index = vec![0u16; texels * 3];
    let mut planes: Vec<Vec<f32>> = vec![Vec::new(); nl];
    for c in 0..3 {
        for (l, p) in planes.iter_mut().enumerate() {
            plane(data, texels, l, c, p);
            if encoding == StoredEncoding::Srgb8 {
                p.iter_mut().for_each(|v| *v = linear_to_srgb(v.max(0.0)));
            }
        }
        let refs: Vec<&[f32]> = planes.iter().map(|p| p.as_slice()).collect();
        let sel = select::select_images(&refs, opts.features.max(1));
        let d = sel.len();
        let mut feat = vec![0.0f32; texels * d];
        for (j, &l) in sel.iter().enumerate() {
            for t in 0..texels {
                feat[t * d + j] = planes[l][t];
            }
        }
        let seed = opts.seed ^ (c as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let km = kmeans::kmeans(&feat, d, opts.clusters.clamp(1, 65536), seed, opts.kmeans_iters);
        out.stats.clusters += km.k;
        out.stats.kmeans_iterations += km.iterations;
        // Members' mean light curve (linear) and mean parameters per cluster.
        let k = km.k;
        let mut mean = vec![0.0f64; k * nl];
        let mut psum = vec![[0.0f64; 5]; k];
        let mut count = vec![0usize; k];
        for t in 0..texels {
            let a = km.assign[t] as usize;
            count[a] += 1;
            for l in 0..nl {
                mean[a * nl + l] += data[(l * texels + t) * 3 + c] as f64;
            }
            for (s, &v) in psum[a].iter_mut().zip(&lm_lobes[3 * t + c]) {
                *s += v as f64;
            }
        }
        let results: Vec<(Lobe, bool, f64)> = (0..k)
            .into_par_iter()
            .map(|a| {
                let n = count[a].max(1) as f64;
                let y: Vec<f32> = (0..nl).map(|l| (mean[a * nl + l] / n) as f32).collect();
                // Refit on the members: LSQ over all member samples = LSQ on their mean curve.
                let refit = PackedLobe::pack(&fitter.fit(&y).lobe).unpack();
                let mut avg: Lobe = psum[a].map(|s| (s / n) as f32);
                let len = (avg[1] * avg[1] + avg[2] * avg[2] + avg[3] * avg[3]).sqrt();
                if len > 0.0 {
                    avg[1] /= len;
                    avg[2] /= len;
                    avg[3] /= len;
                }
                let avg = PackedLobe::pack(&avg).unpack();
                let (e_refit, e_avg) = (fitter.sse(&refit, &y), fitter.sse(&avg, &y));
                let bright = y.iter().map(|&v| v as f64).sum::<f64>();
                if e_refit <= e_avg { (refit, true, bright) } else { (avg, false, bright) }
            })
            .collect();
        // Order clusters by brightness so the three channels' indices correlate (the file's
        // channel-delta filter then deflates well).
        let mut order: Vec<usize> = (0..k).collect();
        order.sort_by(|&a, &b| results[a].2.total_cmp(&results[b].2).then(a.cmp(&b)));
        let mut rank = vec![0u16; k];
        for (r, &a) in order.iter().enumerate() {
            rank[a] = r as u16;
        }
        tables[c] = order.iter().map(|&a| results[a].0).collect();
        for r in &results {
            if r.1 {
                out.stats.refit_wins += 1;
            } else {
                out.stats.average_wins += 1;
            }
        }
        for t in 0..texels {
            index[3 * t + c] = rank[km.assign[t] as usize];
        }
    }
    // Tables of the three channels share one K: pad shorter channels (constant data) with a copy
    // of their last lobe, never referenced.
    let k = tables.iter().map(|t| t.len()).max().unwrap_or(1).max(1);
    let mut table = vec![PackedLobe::pack(&lafortune::ZERO_LOBE); 3 * k];
    for (c, tc) in tables.iter().enumerate() {
        for j in 0..k {
            let l = tc.get(j).or(tc.last()).copied().unwrap_or(lafortune::ZERO_LOBE);
            table[3 * j + c] = PackedLobe::pack(&l);
        }
    }
    let unpacked: Vec<Lobe> = table.iter().map(|p| p.unpack()).collect();
    let polys = fit_polys(lights, data, texels, |t, c, u| {
        lafortune::eval(&unpacked[3 * index[3 * t + c] as usize + c], u)
    });
    out.plmc = Some((ViewParams::Clustered { k, table, index }, polys));
    stage(Stage::PlmC);
    out
}

/// Polynomials `[light][channel]` mapping the model image `model(texel, channel, u)` onto the
/// original image by histogram matching.
fn fit_polys(
    lights: &DirectionSet,
    data: &[f32],
    texels: usize,
    model: impl Fn(usize, usize, crate::math::Vec3) -> f32 + Sync,
) -> Vec<Poly> {
    (0..lights.len() * 3)
        .into_par_iter()
        .map_init(
            || (Vec::new(), Vec::new(), polynomial::Scratch::default()),
            |(m, o, s), i| {
                let (l, c) = (i / 3, i % 3);
                let u = lights.dirs[l];
                m.clear();
                m.extend((0..texels).map(|t| model(t, c, u)));
                plane(data, texels, l, c, o);
                polynomial::fit_mapping(m, o, s)
            },
        )
        .collect()
}

/// A hash of everything that determines a view's fit, so parts of another fit are not reused.
pub fn fingerprint(source: &dyn BtfSource, opts: &FitOptions) -> u64 {
    use crate::math::rng::mix64;
    let mut h = 0x504c_4d43u64;
    let mut add = |v: u64| h = mix64(h ^ v);
    add(opts.kind.code() as u64);
    add(opts.clusters as u64);
    add(opts.features as u64);
    add(opts.seed);
    add(opts.kmeans_iters as u64);
    add(source.width() as u64);
    add(source.height() as u64);
    add(source.encoding() as u64);
    for d in source.views().angles_deg.iter().chain(&source.lights().angles_deg) {
        add(d.0.to_bits() as u64);
        add(d.1.to_bits() as u64);
    }
    add(FIT_CODE_VERSION);
    h
}

/// Bumped whenever the fitting code changes results, so stale parts are refitted.
const FIT_CODE_VERSION: u64 = 1;

/// The sidecar directory holding finished views of an interrupted fit: `mat.plmc.parts/`.
pub fn parts_dir(output: &Path) -> PathBuf {
    let mut name = output.file_name().map(|n| n.to_os_string()).unwrap_or_default();
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
fn skeleton(source: &dyn BtfSource, kind: ModelKind, clusters: usize) -> PlmcModel {
    PlmcModel {
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
pub fn view_model(source: &dyn BtfSource, view: usize, fit: &ViewFit, kind: ModelKind, clusters: usize) -> Option<PlmcModel> {
    let mut m = skeleton(source, kind, clusters);
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
    if opts.kind == ModelKind::PlmC && !(1..=65536).contains(&opts.clusters) {
        return Err(Error::Invalid(format!("--clusters must be in 1..=65536, got {}", opts.clusters)));
    }
    if opts.kind == ModelKind::PlmC && opts.features == 0 {
        return Err(Error::Invalid("--features must be at least 1".into()));
    }
    let fitter = LobeFitter::new(&source.lights().dirs)?;
    let fp = fingerprint(source, opts);
    if let Some(dir) = parts {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    }
    let texels = source.width() * source.height();
    let resumed = AtomicUsize::new(0);
    let views: Vec<(ViewParams, Vec<Poly>, ViewStats)> = (0..source.views().len())
        .into_par_iter()
        .map(|v| -> Result<(ViewParams, Vec<Poly>, ViewStats)> {
            let part_path = parts.map(|d| d.join(format!("view{v:05}.part")));
            if let Some(p) = &part_path
                && p.exists()
            {
                let bytes = std::fs::read(p).map_err(|e| Error::io(p, e))?;
                // A corrupt part (e.g. from a crash of the machine) is simply refitted.
                if let Ok(Some(mut m)) = format::part_from_bytes(&bytes, p, fp, v)
                    && m.params.len() == 1
                    && m.width * m.height == texels
                {
                    resumed.fetch_add(1, Ordering::Relaxed);
                    progress(v, Stage::Done);
                    return Ok((m.params.remove(0), m.polys, ViewStats::default()));
                }
            }
            let data = source.load_view(v)?;
            let fit = fit_view(&fitter, source.lights(), &data, texels, source.encoding(), opts, &|s| progress(v, s));
            let m = view_model(source, v, &fit, opts.kind, opts.clusters)
                .ok_or_else(|| Error::Invalid(format!("view {v}: requested level was not fitted")))?;
            if let Some(p) = &part_path {
                let bytes = format::part_to_bytes(fp, v, &m)?;
                crate::io::write_atomic(p, |w| w.write_all(&bytes).map_err(|e| Error::io(p, e)))?;
            }
            progress(v, Stage::Done);
            let mut m = m;
            Ok((m.params.remove(0), m.polys, fit.stats))
        })
        .collect::<Result<_>>()?;
    let mut model = skeleton(source, opts.kind, opts.clusters);
    let mut stats = ViewStats::default();
    for (p, polys, s) in views {
        model.params.push(p);
        model.polys.extend(polys);
        stats.refit_wins += s.refit_wins;
        stats.average_wins += s.average_wins;
        stats.clusters += s.clusters;
        stats.kmeans_iterations += s.kmeans_iterations;
    }
    model.validate()?;
    Ok(FitOutcome {
        model,
        resumed_views: resumed.into_inner(),
        stats,
    })
}
