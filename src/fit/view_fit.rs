//! Fitting one view: LM per texel, then PLM's per-image mappings, then PLM-C's clusters with the
//! model-space refinement.

use super::lafortune::{self, LobeFitter};
use super::mapping;
use super::options::{
    ClusterOn, FitOptions, L1_ROUNDS, REFINE_CANDIDATES, SECOND_REFINE_ITERS, Stage, value_space,
};
use super::refine;
use super::select;
use crate::btf::{DirectionSet, StoredEncoding};
use crate::math::color::linear_to_srgb;
use crate::math::kmeans;
use crate::math::order_key;
use crate::model::lobe::{self, Lobe};
use crate::model::polynomial::{self, Poly};
use crate::model::{ModelKind, PackedLobe, ValueSpace, ViewParams};
use rayon::prelude::*;

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
    out.plm_polys = fit_polys(
        lights,
        data,
        &sorted,
        texels,
        &mut out.stats,
        Model::Texels(texel_images(lights, &lm_lobes, texels)),
    );
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
    let mut polys = fit_polys(
        lights,
        data,
        &sorted,
        texels,
        &mut stats,
        Model::Clusters {
            table: &unpacked,
            index: &index,
        },
    );
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
        let polys2 = fit_polys(
            lights,
            data,
            &sorted,
            texels,
            &mut stats2,
            Model::Clusters {
                table: &unpacked2,
                index: &index2,
            },
        );
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
    out.par_chunks_mut(texels).enumerate().for_each_init(
        || (Vec::new(), Vec::new()),
        |(keys, tmp), (i, dst)| {
            let (l, c) = (i / 3, i % 3);
            for (t, d) in dst.iter_mut().enumerate() {
                *d = data[(l * texels + t) * 3 + c];
            }
            mapping::radix_sort(dst, keys, tmp);
        },
    );
    out
}

/// The LM model's images `[light][channel][texel]` from per-texel lobes `[texel][channel]`.
fn texel_images(lights: &DirectionSet, lobes: &[Lobe], texels: usize) -> Vec<f32> {
    let mut out = vec![0.0f32; lights.len() * 3 * texels];
    out.par_chunks_mut(texels.max(1))
        .enumerate()
        .for_each(|(i, img)| {
            let (l, c) = (i / 3, i % 3);
            let u = lights.dirs[l];
            for (t, v) in img.iter_mut().enumerate() {
                *v = lobe::eval(&lobes[3 * t + c], u);
            }
        });
    out
}

/// The model whose images [`fit_polys`] maps onto the original images.
enum Model<'a> {
    /// Texel-wise images `[light][channel][texel]` (see [`texel_images`]).
    Texels(Vec<f32>),
    /// A clustered model: lobe table `[cluster][channel]`, index image `[texel][channel]`. An
    /// image takes each cluster's lobe value at every member texel, so its pairs come sorted
    /// without sorting texels: members grouped by cluster once per channel, clusters ordered by
    /// their value per image.
    Clusters { table: &'a [Lobe], index: &'a [u16] },
}

/// The texels of each cluster of one channel, ascending: cluster j's are
/// `texels[start[j]..start[j + 1]]` (a counting sort of the index image).
struct Members {
    start: Vec<usize>,
    texels: Vec<u32>,
}

impl Members {
    fn new(index: &[u16], c: usize, k: usize) -> Self {
        let mut start = vec![0usize; k + 1];
        for ix in index.chunks_exact(3) {
            start[ix[c] as usize + 1] += 1;
        }
        for j in 0..k {
            start[j + 1] += start[j];
        }
        let mut pos = start.clone();
        let mut texels = vec![0u32; index.len() / 3];
        for (t, ix) in index.chunks_exact(3).enumerate() {
            let j = ix[c] as usize;
            texels[pos[j]] = t as u32;
            pos[j] += 1;
        }
        Members { start, texels }
    }

    fn of(&self, j: usize) -> &[u32] {
        &self.texels[self.start[j]..self.start[j + 1]]
    }
}

/// Per-image buffers of [`fit_polys`].
#[derive(Default)]
struct PolyScratch {
    mapping: mapping::Scratch,
    order: Vec<usize>,
    merged: Vec<u32>,
    xs: Vec<f32>,
    ys: Vec<f32>,
}

/// The (model, original) pairs of image `i` = (light, channel `c`) of a clustered model, in the
/// order of a stable sort by model value (`f32::total_cmp`, ties by texel): clusters by value,
/// each one's members ascending, members of clusters with the same value merged by texel.
fn cluster_pairs<'s>(
    vals: &[f32],
    members: &Members,
    orig: impl Fn(usize) -> f32,
    s: &'s mut PolyScratch,
) -> (&'s [f32], &'s [f32]) {
    s.order.clear();
    s.order
        .extend((0..vals.len()).filter(|&j| !members.of(j).is_empty()));
    s.order
        .sort_unstable_by_key(|&j| (order_key::key(vals[j]), j));
    s.xs.clear();
    s.ys.clear();
    let mut a = 0;
    while a < s.order.len() {
        let v = vals[s.order[a]];
        let mut b = a + 1;
        while b < s.order.len() && order_key::key(vals[s.order[b]]) == order_key::key(v) {
            b += 1;
        }
        let run: &[u32] = if b - a == 1 {
            members.of(s.order[a])
        } else {
            s.merged.clear();
            for &j in &s.order[a..b] {
                s.merged.extend_from_slice(members.of(j));
            }
            s.merged.sort_unstable();
            &s.merged
        };
        for &t in run {
            s.xs.push(v);
            s.ys.push(orig(t as usize));
        }
        a = b;
    }
    (&s.xs, &s.ys)
}

/// Polynomials `[light][channel]` mapping the images of `model` (`[light][channel]`) onto the
/// original images `data` (`[light][texel][rgb]`, also given sorted, see [`sorted_planes`]).
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
    model: Model,
) -> Vec<Poly> {
    let images = lights.len() * 3;
    // The model values: per image its texels' (texel-wise) or its clusters' (clustered).
    let (values, members): (Vec<f32>, Vec<Members>) = match model {
        Model::Texels(images) => (images, Vec::new()),
        Model::Clusters { table, index } => {
            let k = table.len() / 3;
            let vals = (0..images)
                .into_par_iter()
                .flat_map_iter(|i| {
                    let (l, c) = (i / 3, i % 3);
                    let u = lights.dirs[l];
                    (0..k).map(move |j| lobe::eval(&table[3 * j + c], u))
                })
                .collect();
            (vals, (0..3).map(|c| Members::new(index, c, k)).collect())
        }
    };
    let per_image = values.len() / images.max(1);
    // Each channel's mapping is conditioned on the largest model value of the channel.
    let mut floor = [0.0f32; 3];
    for (i, img) in values.chunks(per_image.max(1)).enumerate() {
        let c = i % 3;
        let m = img
            .iter()
            .enumerate()
            .filter(|&(j, _)| members.is_empty() || !members[c].of(j).is_empty())
            .fold(0.0f32, |m, (_, &v)| m.max(v));
        floor[c] = floor[c].max(m);
    }
    let fits: Vec<(Poly, bool)> = (0..images)
        .into_par_iter()
        .map_init(PolyScratch::default, |s, i| {
            let (l, c) = (i / 3, i % 3);
            let img = &values[i * per_image..(i + 1) * per_image];
            let f = floor[c];
            let orig = |t: usize| data[(l * texels + t) * 3 + c];
            // The pairs (model, original) by model value; their model values are the sorted
            // model image the histogram matching pairs rank by rank with the sorted original.
            let (xs, ys) = if members.is_empty() {
                s.mapping.sort_pairs(img, orig)
            } else {
                cluster_pairs(img, &members[c], orig, s)
            };
            let matched = mapping::fit_pairs_in(xs, &sorted[i * texels..(i + 1) * texels], f);
            let (regressed, e_regressed) = mapping::fit_pairs_l1(xs, ys, f, L1_ROUNDS);
            if e_regressed < mapping::abs_error(xs, ys, &matched) {
                (regressed, true)
            } else {
                (matched, false)
            }
        })
        .collect();
    let regression = fits.iter().filter(|f| f.1).count();
    stats.regression_polys += regression;
    stats.matched_polys += fits.len() - regression;
    fits.into_iter().map(|f| f.0).collect()
}
