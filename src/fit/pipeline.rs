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

use super::kmeans;
use super::lafortune::{self, LobeFitter};
use super::mapping;
use super::parts;
use super::refine;
use super::select;
use crate::btf::{BtfSource, DirectionSet, StoredEncoding};
use crate::math::color::linear_to_srgb;
use crate::model::lobe::{self, Lobe};
use crate::model::polynomial::{self, Poly};
use crate::model::{ModelKind, PackedLobe, PlmcModel, ValueSpace, ViewParams};
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
    /// Fit in the data's stored encoding (sRGB for 8-bit data) instead of linear values.
    pub fit_stored: bool,
    /// What K-means clusters the texels on (PLM-C).
    pub cluster_on: ClusterOn,
    /// Rounds of model-space refinement after K-means (PLM-C; 0 = the paper's method, see
    /// [`refine`]).
    pub refine_iters: usize,
}

/// Reweighting rounds of the least-absolute-error mapping regression (see [`fit_polys`]).
pub const L1_ROUNDS: usize = 4;

/// Rounds of the second refinement, through the PLM-C mappings (see [`fit_view`]).
pub const SECOND_REFINE_ITERS: usize = 2;

/// Clusters a texel may move to per refinement round (the nearest to its own, by lobe curve).
pub const REFINE_CANDIDATES: usize = 16;

/// The K-means features of PLM-C: each texel's values in the KL-selected images, either measured
/// or as its own LM lobe predicts them.
///
/// The paper clusters the original values. Measured values carry per-texel noise and detail the
/// one-lobe model cannot represent, so K-means on them partly groups texels by that residual, and
/// the lobe refitted on a cluster then sits farther from its members' own lobes. Clustering the
/// LM values groups texels by what a cluster lobe can represent: on synthetic 64² samples
/// (seed 1, K = 256, 20 features) PLM-C's MAE drops .0377 → .0350 on wool (PLM .0319), .0200 →
/// .0186 on leather (PLM .0158), .0091 → .0078 on wood, .0209 → .0207 on corduroy and rises
/// .0323 → .0326 on foil, file sizes within 4% (figures measured before the model-space
/// refinement of `refine.rs`, which now follows K-means either way: with it, leather PLM-C/PLM is
/// 1.091 on LM values and 1.105 on originals). KL selection is on the original images, as in the
/// paper; the refinement and the L1 polynomials are departures, stated in `fit`'s output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ClusterOn {
    /// The original (measured) values, as in the paper.
    Original,
    /// The texel's LM-model values (the default).
    #[default]
    LmModel,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            kind: ModelKind::PlmC,
            clusters: 256,
            features: 20,
            seed: 0,
            kmeans_iters: 40,
            fit_stored: true,
            cluster_on: ClusterOn::LmModel,
            refine_iters: 6,
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
    /// Mappings (PLM and PLM-C) kept from histogram matching, the paper's method.
    pub matched_polys: usize,
    /// Mappings where the texel-wise least-squares regression had the lower MAE and was kept.
    pub regression_polys: usize,
    /// Texel moves of the model-space refinement (summed over channels).
    pub refine_moves: usize,
    /// Refinement rounds run (summed over channels).
    pub refine_rounds: usize,
    /// Summed L1 error of the cluster lobes (before the polynomials) before refinement.
    pub refine_error_before: f64,
    /// The same after refinement.
    pub refine_error_after: f64,
    /// Views whose second refinement (through the PLM-C mappings) lowered the error and was kept.
    pub refine_second_kept: usize,
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
    let space = value_space(encoding, opts);
    let converted: Vec<f32>;
    let data = if space == ValueSpace::Srgb {
        converted = data
            .iter()
            .map(|&v| linear_to_srgb(v.clamp(0.0, 1.0)))
            .collect();
        &converted[..]
    } else {
        data
    };
    // LM: one lobe per texel and channel.
    let lm: Vec<PackedLobe> = (0..texels * 3)
        .into_par_iter()
        .with_min_len(256)
        .map_init(
            || vec![0.0f32; nl],
            |y, i| {
                let (t, c) = (i / 3, i % 3);
                texel_curve(data, texels, t, c, y);
                PackedLobe::pack(&fitter.fit(y).lobe)
            },
        )
        .collect();
    stage(Stage::Lm);
    let lm_lobes: Vec<Lobe> = lm.iter().map(|p| p.unpack()).collect();
    // Every original image sorted once, `[light][channel][rank]`, for both histogram matchings.
    let sorted = sorted_planes(data, texels, nl);
    let mut out = ViewFit {
        lm,
        plm_polys: Vec::new(),
        plmc: None,
        stats: ViewStats::default(),
    };
    if opts.kind == ModelKind::Lm {
        return out;
    }
    out.plm_polys = fit_polys(lights, data, &sorted, texels, &mut out.stats, |t, c, u| {
        lobe::eval(&lm_lobes[3 * t + c], u)
    });
    stage(Stage::Plm);
    if opts.kind == ModelKind::Plm {
        return out;
    }

    // PLM-C, per channel (the mapping counts then describe the PLM-C mappings only).
    out.stats.matched_polys = 0;
    out.stats.regression_polys = 0;
    let mut tables: [Vec<Lobe>; 3] = Default::default();
    let mut index = vec![0u16; texels * 3];
    let mut planes: Vec<Vec<f32>> = vec![Vec::new(); nl];
    let stored_from_linear = encoding == StoredEncoding::Srgb8 && space == ValueSpace::Linear;
    for c in 0..3 {
        for (l, p) in planes.iter_mut().enumerate() {
            plane(data, texels, l, c, p);
            if stored_from_linear {
                p.iter_mut().for_each(|v| *v = linear_to_srgb(v.max(0.0)));
            }
        }
        let refs: Vec<&[f32]> = planes.iter().map(|p| p.as_slice()).collect();
        let sel = select::select_images(&refs, opts.features.max(1));
        // K-means features: the selected images' values of each texel, either as measured (the
        // paper) or as the texel's own LM lobe predicts them (see [`ClusterOn`]); in the stored
        // encoding either way.
        let d = sel.len();
        let mut feat = vec![0.0f32; texels * d];
        for (j, &l) in sel.iter().enumerate() {
            match opts.cluster_on {
                ClusterOn::Original => {
                    for t in 0..texels {
                        feat[t * d + j] = planes[l][t];
                    }
                }
                ClusterOn::LmModel => {
                    let u = lights.dirs[l];
                    for t in 0..texels {
                        let v = lobe::eval(&lm_lobes[3 * t + c], u);
                        feat[t * d + j] = if stored_from_linear {
                            linear_to_srgb(v.clamp(0.0, 1.0))
                        } else {
                            v
                        };
                    }
                }
            }
        }
        let seed = opts.seed ^ (c as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let km = kmeans::kmeans(
            &feat,
            d,
            opts.clusters.clamp(1, 65536),
            seed,
            opts.kmeans_iters,
        );
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
        let results: Vec<(Lobe, bool)> = (0..k)
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
                if e_refit <= e_avg {
                    (refit, true)
                } else {
                    (avg, false)
                }
            })
            .collect();
        for r in &results {
            if r.1 {
                out.stats.refit_wins += 1;
            } else {
                out.stats.average_wins += 1;
            }
        }
        let mut lobes: Vec<Lobe> = results.iter().map(|r| r.0).collect();
        let mut assign = km.assign;
        if opts.refine_iters > 0 {
            let mut ytex = vec![0.0f32; texels * nl];
            channel_curves(data, texels, c, &mut ytex);
            // The PLM mappings of this channel stand in for the PLM-C ones fitted afterwards.
            let map: Vec<Poly> = (0..nl).map(|l| out.plm_polys[3 * l + c]).collect();
            let r = refine::refine(
                fitter,
                &ytex,
                stored_from_linear,
                Some(&map),
                &mut lobes,
                &mut assign,
                refine::RefineOptions {
                    iterations: opts.refine_iters,
                    candidates: REFINE_CANDIDATES,
                },
            );
            out.stats.refine_moves += r.moves;
            out.stats.refine_rounds += r.errors.len().saturating_sub(1);
            if let (Some(a), Some(b)) = (r.errors.first(), r.errors.last()) {
                out.stats.refine_error_before += a;
                out.stats.refine_error_after += b;
            }
        }
        // Order clusters by brightness so the three channels' indices correlate (the file's
        // channel-delta filter then deflates well).
        let mut cv = vec![0.0f32; nl];
        let bright: Vec<f64> = lobes
            .iter()
            .map(|l| {
                lafortune::eval_all(l, fitter, &mut cv);
                cv.iter().map(|&v| v as f64).sum::<f64>()
            })
            .collect();
        let mut order: Vec<usize> = (0..k).collect();
        order.sort_by(|&a, &b| bright[a].total_cmp(&bright[b]).then(a.cmp(&b)));
        let mut rank = vec![0u16; k];
        for (r, &a) in order.iter().enumerate() {
            rank[a] = r as u16;
        }
        tables[c] = order.iter().map(|&a| lobes[a]).collect();
        for t in 0..texels {
            index[3 * t + c] = rank[assign[t] as usize];
        }
    }
    // Tables of the three channels share one K: pad shorter channels (constant data) with a copy
    // of their last lobe, never referenced.
    let k = tables.iter().map(|t| t.len()).max().unwrap_or(1).max(1);
    let mut table = vec![PackedLobe::pack(&lobe::ZERO_LOBE); 3 * k];
    for (c, tc) in tables.iter().enumerate() {
        for j in 0..k {
            let l = tc.get(j).or(tc.last()).copied().unwrap_or(lobe::ZERO_LOBE);
            table[3 * j + c] = PackedLobe::pack(&l);
        }
    }
    let unpacked: Vec<Lobe> = table.iter().map(|p| p.unpack()).collect();
    let mut stats = out.stats;
    let mut polys = fit_polys(lights, data, &sorted, texels, &mut stats, |t, c, u| {
        lobe::eval(&unpacked[3 * index[3 * t + c] as usize + c], u)
    });
    if opts.refine_iters > 0 {
        // A second, short refinement through the PLM-C mappings themselves (the first used PLM's),
        // then the mappings refitted; kept only if the view's absolute error drops.
        let view_err = |table: &[PackedLobe], index: &[u16], polys: &[Poly]| -> f64 {
            let lobes: Vec<Lobe> = table.iter().map(|p| p.unpack()).collect();
            (0..nl)
                .into_par_iter()
                .map(|l| {
                    let u = lights.dirs[l];
                    let vals: Vec<f32> = (0..3 * k)
                        .map(|i| {
                            let c = i % 3;
                            let v = lobe::eval(&lobes[i], u);
                            polynomial::eval(&polys[3 * l + c], v).max(0.0)
                        })
                        .collect();
                    (0..3 * texels)
                        .map(|i| {
                            let (t, c) = (i / 3, i % 3);
                            let m = vals[3 * index[i] as usize + c];
                            (m - data[(l * texels + t) * 3 + c]).abs() as f64
                        })
                        .sum::<f64>()
                })
                .sum()
        };
        let (mut table2, mut index2) = (table.clone(), index.clone());
        let mut ytex = vec![0.0f32; texels * nl];
        for c in 0..3 {
            let mut lobes: Vec<Lobe> = (0..k).map(|j| table[3 * j + c].unpack()).collect();
            let mut assign: Vec<u32> = (0..texels).map(|t| index[3 * t + c] as u32).collect();
            channel_curves(data, texels, c, &mut ytex);
            let map: Vec<Poly> = (0..nl).map(|l| polys[3 * l + c]).collect();
            let r = refine::refine(
                fitter,
                &ytex,
                stored_from_linear,
                Some(&map),
                &mut lobes,
                &mut assign,
                refine::RefineOptions {
                    iterations: SECOND_REFINE_ITERS,
                    candidates: REFINE_CANDIDATES,
                },
            );
            out.stats.refine_moves += r.moves;
            out.stats.refine_rounds += r.errors.len().saturating_sub(1);
            for (j, l) in lobes.iter().enumerate() {
                table2[3 * j + c] = PackedLobe::pack(l);
            }
            for t in 0..texels {
                index2[3 * t + c] = assign[t] as u16;
            }
        }
        let unpacked2: Vec<Lobe> = table2.iter().map(|p| p.unpack()).collect();
        let mut stats2 = out.stats;
        let polys2 = fit_polys(lights, data, &sorted, texels, &mut stats2, |t, c, u| {
            lobe::eval(&unpacked2[3 * index2[3 * t + c] as usize + c], u)
        });
        if view_err(&table2, &index2, &polys2) < view_err(&table, &index, &polys) {
            (table, index, polys, stats) = (table2, index2, polys2, stats2);
            stats.refine_second_kept += 1;
        }
    }
    out.stats.matched_polys = stats.matched_polys;
    out.stats.regression_polys = stats.regression_polys;
    out.stats.refine_second_kept = stats.refine_second_kept;
    out.plmc = Some((ViewParams::Clustered { k, table, index }, polys));
    stage(Stage::PlmC);
    out
}

/// The space a fit with `opts` works in for data stored with `encoding`.
pub fn value_space(encoding: StoredEncoding, opts: &FitOptions) -> ValueSpace {
    if opts.fit_stored && encoding == StoredEncoding::Srgb8 {
        ValueSpace::Srgb
    } else {
        ValueSpace::Linear
    }
}

/// Texel `t`'s values over the lights in channel `c` (`out.len()` lights) from the view's
/// images `data` = `[light][texel][rgb]`.
fn texel_curve(data: &[f32], texels: usize, t: usize, c: usize, out: &mut [f32]) {
    for (l, v) in out.iter_mut().enumerate() {
        *v = data[(l * texels + t) * 3 + c];
    }
}

/// Every texel's curve of channel `c`, `[texel][light]` (`out.len() / texels` lights).
fn channel_curves(data: &[f32], texels: usize, c: usize, out: &mut [f32]) {
    let nl = out.len() / texels;
    for (t, y) in out.chunks_exact_mut(nl).enumerate() {
        texel_curve(data, texels, t, c, y);
    }
}

/// The original images sorted ascending, `[light][channel][rank]` (`texels` values each).
fn sorted_planes(data: &[f32], texels: usize, lights: usize) -> Vec<f32> {
    let mut out = vec![0.0f32; lights * 3 * texels];
    out.par_chunks_mut(texels).enumerate().for_each(|(i, dst)| {
        let (l, c) = (i / 3, i % 3);
        for (t, d) in dst.iter_mut().enumerate() {
            *d = data[(l * texels + t) * 3 + c];
        }
        dst.sort_unstable_by(f32::total_cmp);
    });
    out
}

/// Polynomials `[light][channel]` mapping the model image `model(texel, channel, u)` onto the
/// original image `data` (`[light][texel][rgb]`, also given sorted, see [`sorted_planes`]).
///
/// Per image two mappings are fitted and the one with the lower MAE on the image is kept (counted
/// in `stats`): the paper's histogram matching (rank k of the model ↦ rank k of the original; it
/// keeps the original's histogram, hence its contrast) and the texel-wise regression of the
/// original on the model value, least squares refined to least absolute error by
/// [`L1_ROUNDS`] reweighting rounds (the MAE is what the model is judged by; not in the paper:
/// on the 64² synth materials and the impalla crop it lowers PLM's MAE by 2–10 %). Why regress
/// at all: least squares gives E[original | model value]; with an imperfect model, above all a
/// clustered one, matching reproduces the full contrast at the wrong texels and its error is up
/// to 2σ²(1 − ρ) against the regression's σ²(1 − ρ²). Each mapping is conditioned on [0, the
/// largest model value of its channel over all lights] (the range the renderer evaluates it on
/// between measured directions).
fn fit_polys(
    lights: &DirectionSet,
    data: &[f32],
    sorted: &[f32],
    texels: usize,
    stats: &mut ViewStats,
    model: impl Fn(usize, usize, crate::math::Vec3) -> f32 + Sync,
) -> Vec<Poly> {
    let images: Vec<f32> = (0..lights.len() * 3)
        .into_par_iter()
        .flat_map_iter(|i| {
            let (l, c) = (i / 3, i % 3);
            let u = lights.dirs[l];
            (0..texels).map(move |t| (t, c, u))
        })
        .map(|(t, c, u)| model(t, c, u))
        .collect();
    let mut floor = [0.0f32; 3];
    for (i, img) in images.chunks(texels.max(1)).enumerate() {
        let m = img.iter().fold(0.0f32, |m, &v| m.max(v));
        floor[i % 3] = floor[i % 3].max(m);
    }
    let fits: Vec<(Poly, bool)> = (0..lights.len() * 3)
        .into_par_iter()
        .map_init(
            || {
                (
                    mapping::Scratch::default(),
                    Vec::new(),
                    Vec::new(),
                    Vec::new(),
                )
            },
            |(s, pairs, xs, ys), i| {
                let (l, c) = (i / 3, i % 3);
                let img = &images[i * texels..(i + 1) * texels];
                let f = floor[c];
                let matched =
                    mapping::fit_mapping_sorted(img, &sorted[i * texels..(i + 1) * texels], f, s);
                pairs.clear();
                pairs.extend(
                    img.iter()
                        .enumerate()
                        .map(|(t, &m)| (m, data[(l * texels + t) * 3 + c])),
                );
                pairs.sort_unstable_by(|a: &(f32, f32), b| a.0.total_cmp(&b.0));
                xs.clear();
                ys.clear();
                xs.extend(pairs.iter().map(|p| p.0));
                ys.extend(pairs.iter().map(|p| p.1));
                let regressed = mapping::fit_pairs_l1(xs, ys, f, L1_ROUNDS);
                let mae = |a: &Poly| {
                    pairs
                        .iter()
                        .map(|&(m, o)| (polynomial::eval(a, m).max(0.0) - o).abs() as f64)
                        .sum::<f64>()
                };
                if mae(&regressed) < mae(&matched) {
                    (regressed, true)
                } else {
                    (matched, false)
                }
            },
        )
        .collect();
    let regression = fits.iter().filter(|f| f.1).count();
    stats.regression_polys += regression;
    stats.matched_polys += fits.len() - regression;
    fits.into_iter().map(|f| f.0).collect()
}

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
    fit_model_keyed(source, opts, 0, parts, progress)
}

/// [`fit_model`] whose part files are keyed by `key` too (see [`fingerprint_keyed`]), for sources
/// derived from the data (tiles), so parts of another derivation are never reused.
pub fn fit_model_keyed(
    source: &dyn BtfSource,
    opts: &FitOptions,
    key: u64,
    parts: Option<&Path>,
    progress: &(dyn Fn(usize, Stage) + Sync),
) -> Result<FitOutcome> {
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
                if let Ok(Some(mut m)) = parts::part_from_bytes(&bytes, p, fp, v)
                    && m.params.len() == 1
                    && m.width * m.height == texels
                {
                    resumed.fetch_add(1, Ordering::Relaxed);
                    progress(v, Stage::Done);
                    return Ok((m.params.remove(0), m.polys, ViewStats::default()));
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
            progress(v, Stage::Done);
            let mut m = m;
            Ok((m.params.remove(0), m.polys, fit.stats))
        })
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
        resumed_views: resumed.into_inner(),
        stats,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::btf::RawBtf;
    use crate::fit::report::view_error;
    use crate::math::Pcg32;
    use crate::model::codec;

    /// A synthetic BTF: texels drawn from 6 material types (one lobe per channel each), plus a
    /// monotone per-image tone curve y ↦ y^γ (what one lobe cannot model, PLM can), plus noise.
    fn synth(views: usize, side: usize, seed: u64) -> RawBtf {
        let lights = DirectionSet::ubo2003();
        let vdirs = DirectionSet::from_angles_deg(lights.angles_deg[..views].to_vec());
        let mut rng = Pcg32::new(seed, 11);
        let types: Vec<[Lobe; 3]> = (0..6)
            .map(|_| {
                let th = rng.next_f32() * 0.6;
                let ph = rng.next_f32() * std::f32::consts::TAU;
                let n = 1.0 + rng.next_f32() * 8.0;
                std::array::from_fn(|_| {
                    [
                        0.2 + rng.next_f32(),
                        th.sin() * ph.cos(),
                        th.sin() * ph.sin(),
                        th.cos(),
                        n,
                    ]
                })
            })
            .collect();
        let texel_type: Vec<usize> = (0..side * side)
            .map(|_| rng.next_below(6) as usize)
            .collect();
        let gamma: Vec<f32> = (0..views * 81).map(|_| 0.5 + rng.next_f32()).collect();
        let mut data = Vec::new();
        for v in 0..views {
            for l in 0..81 {
                for &ty in &texel_type {
                    for lobe in &types[ty] {
                        let y = lobe::eval(lobe, lights.dirs[l]);
                        data.push(
                            (y.powf(gamma[v * 81 + l]) + 0.01 * (rng.next_f32() - 0.5)).max(0.0),
                        );
                    }
                }
            }
        }
        RawBtf::from_f32(vdirs, lights, side, side, StoredEncoding::Linear, &data).unwrap()
    }

    /// One view of `side`² texels, each with its own lobe (direction, exponent and albedo drawn
    /// continuously) plus uniform per-sample noise of amplitude `noise` (linear values).
    fn noisy_continuum(side: usize, noise: f32, seed: u64) -> RawBtf {
        let lights = DirectionSet::ubo2003();
        let vdirs = DirectionSet::from_angles_deg(vec![(0.0, 0.0)]);
        let mut rng = Pcg32::new(seed, 5);
        let lobes: Vec<Lobe> = (0..side * side)
            .map(|_| {
                let th = rng.next_f32() * 0.5;
                let ph = rng.next_f32() * std::f32::consts::TAU;
                [
                    0.2 + 0.6 * rng.next_f32(),
                    th.sin() * ph.cos(),
                    th.sin() * ph.sin(),
                    th.cos(),
                    1.0 + 6.0 * rng.next_f32(),
                ]
            })
            .collect();
        let mut data = Vec::new();
        for l in 0..81 {
            for lobe in &lobes {
                let y = lobe::eval(lobe, lights.dirs[l]) + noise * (rng.next_f32() - 0.5);
                data.extend([y.max(0.0); 3]);
            }
        }
        RawBtf::from_f32(vdirs, lights, side, side, StoredEncoding::Linear, &data).unwrap()
    }

    #[test]
    fn clustering_lm_values_beats_clustering_noisy_originals() {
        // Texels whose lobes vary continuously, under noise as strong as the lobes' detail:
        // K-means on the measured values partly groups texels by their noise, K-means on the LM
        // values by their lobes, so the refitted cluster lobes represent the members better.
        // Errors are measured against the noiseless values (same lobes, same seed): the noise
        // itself would otherwise dominate both errors.
        let btf = noisy_continuum(24, 0.3, 3);
        let clean = noisy_continuum(24, 0.0, 3);
        let fit = |cluster_on| {
            let o = FitOptions {
                clusters: 12,
                cluster_on,
                ..FitOptions::default()
            };
            mae(
                &clean,
                &fit_model(&btf, &o, None, &|_, _| {}).unwrap().model,
            )
        };
        let plm = FitOptions {
            kind: ModelKind::Plm,
            ..FitOptions::default()
        };
        let e_plm = mae(
            &clean,
            &fit_model(&btf, &plm, None, &|_, _| {}).unwrap().model,
        );
        let (e_orig, e_lm) = (fit(ClusterOn::Original), fit(ClusterOn::LmModel));
        eprintln!("PLM {e_plm} PLM-C original {e_orig} PLM-C lm {e_lm}");
        assert!(e_lm < e_orig, "PLM {e_plm} original {e_orig} lm {e_lm}");
    }

    fn mae(btf: &RawBtf, m: &PlmcModel) -> f64 {
        let mut r = Vec::new();
        (0..m.views.len())
            .map(|v| {
                m.reconstruct_view(v, &mut r);
                view_error(&btf.load_view(v).unwrap(), &r, btf.encoding()).mae
            })
            .sum::<f64>()
            / m.views.len() as f64
    }

    #[test]
    fn plm_beats_lm_and_plmc_stays_close_to_plm() {
        let btf = synth(2, 12, 1);
        let fit = |kind, clusters| {
            let o = FitOptions {
                kind,
                clusters,
                features: 20,
                ..FitOptions::default()
            };
            fit_model(&btf, &o, None, &|_, _| {}).unwrap().model
        };
        let (lm, plm, plmc) = (
            fit(ModelKind::Lm, 0),
            fit(ModelKind::Plm, 0),
            fit(ModelKind::PlmC, 16),
        );
        let (e_lm, e_plm, e_plmc) = (mae(&btf, &lm), mae(&btf, &plm), mae(&btf, &plmc));
        assert!(e_plm < 0.7 * e_lm, "LM {e_lm} PLM {e_plm}");
        assert!(e_plmc < 1.1 * e_plm, "PLM {e_plm} PLM-C {e_plmc}");
        // K larger than the texel count is handled (K-means stops at the distinct texels).
        let big = fit(ModelKind::PlmC, 1000);
        assert!(mae(&btf, &big) < 1.1 * e_plm);
        // Round trip through the file keeps the reconstruction.
        let bytes = codec::to_bytes(&plmc).unwrap();
        let back = codec::from_bytes(&bytes, Path::new("m.plmc")).unwrap();
        assert_eq!(back, plmc);
    }

    #[test]
    fn constant_data_do_not_break_plmc() {
        let lights = DirectionSet::ubo2003();
        let v = DirectionSet::from_angles_deg(vec![(0.0, 0.0)]);
        let btf = RawBtf::from_f32(
            v,
            lights,
            4,
            4,
            StoredEncoding::Srgb8,
            &vec![0.25; 81 * 16 * 3],
        )
        .unwrap();
        let o = FitOptions {
            clusters: 256,
            ..FitOptions::default()
        };
        let m = fit_model(&btf, &o, None, &|_, _| {}).unwrap().model;
        let mut r = Vec::new();
        m.reconstruct_view(0, &mut r);
        assert!(r.iter().all(|&x| (x - 0.25).abs() < 2e-3), "{:?}", &r[..3]);
        let zero = RawBtf::from_f32(
            btf.views().clone(),
            btf.lights().clone(),
            4,
            4,
            StoredEncoding::Linear,
            &vec![0.0; 81 * 48],
        )
        .unwrap();
        let m = fit_model(&zero, &o, None, &|_, _| {}).unwrap().model;
        m.reconstruct_view(0, &mut r);
        assert!(r.iter().all(|&x| x == 0.0));
    }

    #[test]
    fn killed_fits_resume_from_parts() {
        let btf = synth(3, 6, 2);
        let dir = tempfile::tempdir().unwrap();
        let parts = parts_dir(&dir.path().join("m.plmc"));
        let o = FitOptions {
            clusters: 8,
            ..FitOptions::default()
        };
        let first = fit_model(&btf, &o, Some(&parts), &|_, _| {}).unwrap();
        assert_eq!(first.resumed_views, 0);
        // Simulate a kill: one view missing, one part corrupt; the rest are reused.
        std::fs::remove_file(parts.join("view00001.part")).unwrap();
        let p2 = parts.join("view00002.part");
        let mut b = std::fs::read(&p2).unwrap();
        let last = b.len() - 30;
        b[last] ^= 0xff;
        std::fs::write(&p2, b).unwrap();
        let fitted = AtomicUsize::new(0);
        let second = fit_model(&btf, &o, Some(&parts), &|_, s| {
            if s == Stage::Lm {
                fitted.fetch_add(1, Ordering::Relaxed);
            }
        })
        .unwrap();
        assert_eq!(second.resumed_views, 1);
        assert_eq!(fitted.into_inner(), 2);
        assert_eq!(second.model, first.model);
        // Parts of a fit with other options are not reused.
        let other = FitOptions { seed: 9, ..o };
        assert_eq!(
            fit_model(&btf, &other, Some(&parts), &|_, _| {})
                .unwrap()
                .resumed_views,
            0
        );
    }

    /// Sharp lobes over a constant floor: at grazing lights the LM images are ~1e-18 while the
    /// measured images are 0.02, the case where the old mapping fit (scaled by the image's own
    /// largest value) wrote coefficients up to 1e38.
    #[test]
    fn sharp_lobes_give_bounded_polynomial_coefficients() {
        let lights = DirectionSet::ubo2003();
        let views = DirectionSet::from_angles_deg(vec![(0.0, 0.0)]);
        let mut rng = Pcg32::new(5, 5);
        let side = 8;
        let lobes: Vec<Lobe> = (0..side * side)
            .map(|_| {
                let th = 0.1 * rng.next_f32();
                [
                    0.5 + 0.5 * rng.next_f32(),
                    th.sin(),
                    0.0,
                    th.cos(),
                    20.0 + 40.0 * rng.next_f32(),
                ]
            })
            .collect();
        let mut data = Vec::new();
        for l in 0..81 {
            for lobe in &lobes {
                for _ in 0..3 {
                    let y = lobe::eval(lobe, lights.dirs[l]);
                    data.push(y + 0.02 + 0.004 * rng.next_f32());
                }
            }
        }
        let btf =
            RawBtf::from_f32(views, lights, side, side, StoredEncoding::Linear, &data).unwrap();
        for kind in [ModelKind::Plm, ModelKind::PlmC] {
            let o = FitOptions {
                kind,
                clusters: 16,
                ..FitOptions::default()
            };
            let m = fit_model(&btf, &o, None, &|_, _| {}).unwrap().model;
            // Lobe values reach ~1: every mapping must stay within a few times the data there.
            for a in &m.polys {
                let growth: f32 = a.iter().map(|v| v.abs()).sum();
                assert!(growth < 100.0, "{kind:?} {a:?}");
            }
            let lm = fit_model(
                &btf,
                &FitOptions {
                    kind: ModelKind::Lm,
                    ..o
                },
                None,
                &|_, _| {},
            );
            assert!(mae(&btf, &m) < mae(&btf, &lm.unwrap().model), "{kind:?}");
        }
    }
}
