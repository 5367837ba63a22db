//! Texel clusters of a raw BTF for its light-sampling tables: texels whose light distributions
//! have the same shape share one set of tables, so a texel whose highlight sits elsewhere than
//! the material average's (a bump tilted away, a varnished patch in a matte weave) is sampled
//! from tables of its own kind.
//!
//! Features: per texel, for [`FEATURE_VIEWS`] measured views spread over the view set, the
//! square roots of the luminance of B at every measured light, divided by the sum over the
//! lights of that view (each view's features have unit length). The squared distance of two
//! texels is then 2 Σ_v H²_v, the Hellinger distances of their per-view light distributions:
//! the shape of B over the lights, which is all a normalised sampling table sees, independent
//! of the texel's brightness and tint. The texels the tables average (a grid of at most
//! [`TABLE_TEXELS`]² texels, as for the material-wide table) are clustered by K-means (none
//! when their features spread less than [`MIN_SPREAD`]); centres nearer each other than that
//! are merged, every texel takes the nearest centre among the clusters with a grid member, and
//! each cluster's tables are built, as the material-wide table is, from the luminance of B
//! averaged over its grid texels. One cluster is exactly the material-wide table.
//!
//! Memory: [`BtfLightSampler::bytes_per_set`] per cluster plus one byte per texel; the number
//! of clusters is the largest that fits [`TABLE_BUDGET_BYTES`] up to [`MAX_CLUSTERS`] (down to
//! 1, which needs no texel index).
//!
//! [`BtfLightSampler::bytes_per_set`]: super::btf_sampler::BtfLightSampler::bytes_per_set

use crate::btf::{BtfSource, RawBtf};
use crate::math::Spectrum;
use crate::math::color::luminance;
use crate::math::kmeans::kmeans;
use half::f16;
use rayon::prelude::*;

/// Texels per axis averaged per image when building the sampling tables (larger BTFs are read
/// on an evenly strided grid of at most this many texels per axis).
pub const TABLE_TEXELS: usize = 64;
/// Most texel clusters (sets of sampling tables) of one material.
pub const MAX_CLUSTERS: usize = 16;
/// Bytes the cluster tables and the texel index of one material may take; fewer clusters are
/// made when [`MAX_CLUSTERS`] do not fit (81 × 81 directions: 0.35 MiB per cluster).
pub const TABLE_BUDGET_BYTES: usize = 16 << 20;
/// Measured views whose light distributions make a texel's features.
pub const FEATURE_VIEWS: usize = 16;
/// Texels whose features spread less than this around their mean (mean squared distance per
/// feature view, 2 H² in Hellinger terms) share one table set, and so do clusters whose
/// centres are nearer than this: their light distributions differ too little for separate
/// tables to lower the variance noticeably (about 4 · this, relative).
pub const MIN_SPREAD: f32 = 1e-3;
/// Lloyd iterations of the clustering at most.
const KMEANS_ITERS: usize = 30;
/// Seed of the clustering (k-means++ seeding), fixed so a material loads the same every time.
const KMEANS_SEED: u64 = 0x7ab1_e5e7;
/// Texels whose features are computed in one parallel task.
const CHUNK: usize = 256;

/// What a raw material's sampling tables are built from.
#[derive(Clone, Debug)]
pub struct TexelClusters {
    /// Number of clusters (sets of tables); 1 = the material-wide table.
    pub k: usize,
    /// Per texel (row-major, `row · width + column`) its cluster; empty when `k` is 1.
    pub index: Vec<u8>,
    /// Luminance of B averaged over each cluster's grid texels, `[cluster][view][light]`
    /// (linear, cosine-baked; non-finite and negative averages as 0).
    pub lum: Vec<f32>,
}

/// How many clusters fit `budget` bytes when one set of tables takes `bytes_per_set` and the
/// texel index one byte per texel: at most `max`, at least 1 (the single table, which needs no
/// index, whatever the budget).
pub fn clusters_within(budget: usize, bytes_per_set: usize, texels: usize, max: usize) -> usize {
    let max = max.min(u8::MAX as usize + 1);
    if max <= 1 {
        return 1;
    }
    let fit = budget.saturating_sub(texels) / bytes_per_set.max(1);
    fit.clamp(1, max)
}

/// Clusters the texels of `btf` into at most `max_clusters` (see the module doc) and averages
/// the luminance of B per cluster.
pub fn cluster_texels(btf: &RawBtf, max_clusters: usize) -> TexelClusters {
    let (w, h) = (btf.width(), btf.height());
    let grid = grid_texels(w, h);
    let max_clusters = max_clusters.min(u8::MAX as usize + 1);
    if max_clusters <= 1 || grid.len() < 2 {
        return TexelClusters {
            k: 1,
            index: Vec::new(),
            lum: cluster_luminance(btf, &[], 1),
        };
    }
    let views = feature_views(btf.views().len());
    let dim = views.len() * btf.lights().len();
    let feat = features(btf, &views, &grid);
    let single = || TexelClusters {
        k: 1,
        index: Vec::new(),
        lum: cluster_luminance(btf, &[], 1),
    };
    if spread(&feat, dim) / (views.len() as f64) < MIN_SPREAD as f64 {
        return single();
    }
    let km = kmeans(&feat, dim, max_clusters, KMEANS_SEED, KMEANS_ITERS);
    if km.k <= 1 {
        return single();
    }
    let centres = &km.centers;
    // The grid texels' nearest centres, then the centres that have a grid member (only those
    // get tables), numbered in order; a centre within MIN_SPREAD of an earlier numbered one
    // shares its number.
    let grid_of: Vec<u32> = feat
        .par_chunks(dim)
        .map(|f| nearest(f, centres, dim, None))
        .collect();
    let mut used = vec![false; km.k];
    for &c in &grid_of {
        used[c as usize] = true;
    }
    let centre = |c: usize| &centres[c * dim..(c + 1) * dim];
    let merge_below = MIN_SPREAD * views.len() as f32;
    let mut renumber = vec![u32::MAX; km.k];
    let mut leaders: Vec<usize> = Vec::new();
    for c in (0..km.k).filter(|&c| used[c]) {
        let near = leaders
            .iter()
            .position(|&r| dist2(centre(c), centre(r)) < merge_below);
        renumber[c] = match near {
            Some(j) => j as u32,
            None => {
                leaders.push(c);
                (leaders.len() - 1) as u32
            }
        };
    }
    let k = leaders.len();
    if k <= 1 {
        return single();
    }
    let mut index = vec![0u8; w * h];
    if grid.len() == w * h {
        // Every texel is a grid texel (the grid lists them in row-major order).
        for (i, &c) in index.iter_mut().zip(&grid_of) {
            *i = renumber[c as usize] as u8;
        }
    } else {
        let all: Vec<u32> = (0..(w * h) as u32).collect();
        index
            .par_chunks_mut(CHUNK)
            .zip(all.par_chunks(CHUNK))
            .for_each(|(out, texels)| {
                let f = features(btf, &views, texels);
                for (o, fi) in out.iter_mut().zip(f.chunks_exact(dim)) {
                    *o = renumber[nearest(fi, centres, dim, Some(&used)) as usize] as u8;
                }
            });
        // A grid texel keeps the cluster it was averaged into.
        for (&t, &c) in grid.iter().zip(&grid_of) {
            index[t as usize] = renumber[c as usize] as u8;
        }
    }
    TexelClusters {
        k,
        lum: cluster_luminance(btf, &index, k),
        index,
    }
}

/// The grid texels the tables average, row-major `row · w + column`: rows and columns strided
/// so that at most [`TABLE_TEXELS`] of each are read.
fn grid_texels(w: usize, h: usize) -> Vec<u32> {
    let (sx, sy) = (w.div_ceil(TABLE_TEXELS), h.div_ceil(TABLE_TEXELS));
    (0..h)
        .step_by(sy)
        .flat_map(|y| (0..w).step_by(sx).map(move |x| (y * w + x) as u32))
        .collect()
}

/// [`FEATURE_VIEWS`] view indices spread evenly over `nv` (all of them when there are fewer).
fn feature_views(nv: usize) -> Vec<usize> {
    let n = FEATURE_VIEWS.min(nv);
    (0..n).map(|i| i * nv / n).collect()
}

/// Luminance of B at value index `i` of the data (the red value's): 0 for non-finite or
/// negative values.
#[inline]
fn lum_at(data: &[f16], i: usize) -> f32 {
    let l = luminance(Spectrum::new(
        data[i].to_f32(),
        data[i + 1].to_f32(),
        data[i + 2].to_f32(),
    ));
    if l.is_finite() { l.max(0.0) } else { 0.0 }
}

/// The features of `texels` (see the module doc), `texels.len() × (views.len() · lights)`,
/// computed in parallel chunks.
fn features(btf: &RawBtf, views: &[usize], texels: &[u32]) -> Vec<f32> {
    let nl = btf.lights().len();
    let dim = views.len() * nl;
    let img = btf.width() * btf.height();
    let data = btf.data();
    let mut feat = vec![0f32; texels.len() * dim];
    feat.par_chunks_mut(CHUNK * dim)
        .zip(texels.par_chunks(CHUNK))
        .for_each(|(out, texels)| {
            for (j, &v) in views.iter().enumerate() {
                for l in 0..nl {
                    let base = 3 * (v * nl + l) * img;
                    for (i, &t) in texels.iter().enumerate() {
                        out[i * dim + j * nl + l] = lum_at(data, base + 3 * t as usize);
                    }
                }
            }
            for row in out.chunks_exact_mut(nl) {
                let s: f32 = row.iter().sum();
                if s > 0.0 && s.is_finite() {
                    row.iter_mut().for_each(|x| *x = (*x / s).sqrt());
                } else {
                    row.fill(0.0);
                }
            }
        });
    feat
}

/// Squared Euclidean distance of two feature vectors.
fn dist2(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// Mean squared distance of the rows of `feat` (`n × dim`) from their mean.
fn spread(feat: &[f32], dim: usize) -> f64 {
    let n = feat.len() / dim;
    let mut mean = vec![0f64; dim];
    for row in feat.chunks_exact(dim) {
        for (m, &x) in mean.iter_mut().zip(row) {
            *m += x as f64;
        }
    }
    mean.iter_mut().for_each(|m| *m /= n as f64);
    let sum: f64 = feat
        .chunks_exact(dim)
        .map(|row| {
            row.iter()
                .zip(&mean)
                .map(|(&x, m)| (x as f64 - m) * (x as f64 - m))
                .sum::<f64>()
        })
        .sum();
    sum / n as f64
}

/// The centre of `centres` (`k × dim`) nearest `f` among those `allowed` (all when None),
/// ties to the lowest index.
fn nearest(f: &[f32], centres: &[f32], dim: usize, allowed: Option<&[bool]>) -> u32 {
    let mut best: Option<(f32, u32)> = None;
    for (c, centre) in centres.chunks_exact(dim).enumerate() {
        if allowed.is_some_and(|a| !a[c]) {
            continue;
        }
        let d = dist2(f, centre);
        if best.is_none_or(|(b, _)| d < b) {
            best = Some((d, c as u32));
        }
    }
    best.map_or(0, |(_, c)| c)
}

/// Luminance of B averaged over each of the `k` clusters' grid texels, `[cluster][view][light]`:
/// the RGB values summed in row-major order, divided by the count, then the luminance (so one
/// cluster gives exactly the material-wide average). `index` is the texels' clusters (empty:
/// all in cluster 0).
fn cluster_luminance(btf: &RawBtf, index: &[u8], k: usize) -> Vec<f32> {
    let (nv, nl) = (btf.views().len(), btf.lights().len());
    let (w, h) = (btf.width(), btf.height());
    let (sx, sy) = (w.div_ceil(TABLE_TEXELS), h.div_ceil(TABLE_TEXELS));
    let data = btf.data();
    let per_image: Vec<Vec<f32>> = (0..nv * nl)
        .into_par_iter()
        .map(|vl| {
            let mut sum = vec![Spectrum::ZERO; k];
            let mut count = vec![0u32; k];
            for y in (0..h).step_by(sy) {
                let row = 3 * ((vl * h + y) * w);
                for x in (0..w).step_by(sx) {
                    let c = index.get(y * w + x).map_or(0, |&c| c as usize);
                    let i = row + 3 * x;
                    sum[c] +=
                        Spectrum::new(data[i].to_f32(), data[i + 1].to_f32(), data[i + 2].to_f32());
                    count[c] += 1;
                }
            }
            sum.iter()
                .zip(&count)
                .map(|(&s, &n)| {
                    let l = luminance(s / n.max(1) as f32);
                    if l.is_finite() { l.max(0.0) } else { 0.0 }
                })
                .collect()
        })
        .collect();
    let mut lum = vec![0f32; k * nv * nl];
    for (vl, img) in per_image.iter().enumerate() {
        for (c, &l) in img.iter().enumerate() {
            lum[c * nv * nl + vl] = l;
        }
    }
    lum
}
