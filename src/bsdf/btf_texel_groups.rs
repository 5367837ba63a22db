//! Texel groups of a raw BTF for its light-sampling tables: texels whose light distributions
//! have the same shape share a table, so a varnished or metallic texel's highlight is not
//! averaged away by the texels around it (one table per view averaged over all texels samples a
//! narrow, texel-dependent peak almost uniformly).
//!
//! A texel is described by the shape of its light distribution (luminance over the measured
//! lights, normalised to unit sum) in [`FEATURE_VIEWS`] views spread over the view list; the
//! texels of the table grid (at most 64 × 64, as the tables average) are clustered by k-means
//! (`math::kmeans`, seeded: the same groups on every run), every texel goes to its nearest
//! centre, and each group's tables average the grid texels of that group. Memory: one byte per
//! texel and [`BtfLightSampler::group_bytes`] per group (about 0.36 MB on the UBO2003
//! directions), at most [`GROUP_TABLE_BYTES`] in all.

use super::btf_sampler::BtfLightSampler;
use crate::btf::{BtfSource, RawBtf};
use crate::math::Spectrum;
use crate::math::color::luminance;
use crate::math::kmeans::kmeans;
use rayon::prelude::*;

/// Most texel groups (k-means clusters).
pub const MAX_GROUPS: usize = 16;
/// Grid texels per group at least: fewer texels give fewer groups (a table averaged over a
/// handful of texels would follow their noise).
const MIN_TEXELS_PER_GROUP: usize = 16;
/// The memory all groups' tables may take, in bytes.
pub const GROUP_TABLE_BYTES: usize = 64 << 20;
/// Views whose light distributions describe a texel.
pub const FEATURE_VIEWS: usize = 9;
/// Lloyd iterations of the clustering.
const KMEANS_ITERATIONS: usize = 30;
/// Seed of the clustering.
const SEED: u64 = 0x6274_6667;

/// The texels' groups and the per-group table input.
pub struct TexelGroups {
    /// Group of every texel, `[row][column]`; empty when there is one group.
    pub of_texel: Vec<u8>,
    /// Luminance of B averaged over each group's grid texels, `[group][view][light]`.
    pub lum: Vec<f32>,
}

/// Groups the texels of `btf`; `grid` is the table grid's texel stride (columns, rows) and
/// `triangles` the light triangulation's size (for the memory bound).
pub fn texel_groups(btf: &RawBtf, grid: (usize, usize), triangles: usize) -> TexelGroups {
    let (nv, nl) = (btf.views().len(), btf.lights().len());
    let (w, h) = (btf.width(), btf.height());
    let grid_texels: Vec<usize> = (0..h)
        .step_by(grid.1)
        .flat_map(|y| (0..w).step_by(grid.0).map(move |x| y * w + x))
        .collect();
    let by_memory = GROUP_TABLE_BYTES / BtfLightSampler::group_bytes(nv, triangles).max(1);
    let k = MAX_GROUPS
        .min(grid_texels.len() / MIN_TEXELS_PER_GROUP)
        .min(by_memory);
    let one = |of_texel: Vec<u8>| TexelGroups {
        lum: group_luminance(btf, &grid_texels, &of_texel, 1),
        of_texel,
    };
    if k <= 1 || nl == 0 {
        return one(Vec::new());
    }
    let views: Vec<usize> = (0..FEATURE_VIEWS.min(nv))
        .map(|i| i * nv / FEATURE_VIEWS.min(nv))
        .collect();
    let dim = views.len() * nl;
    let feat = features(btf, &views, &grid_texels);
    let km = kmeans(&feat, dim, k, SEED, KMEANS_ITERATIONS);
    if km.k <= 1 {
        return one(Vec::new());
    }
    // Every texel (the grid's included) at its nearest centre, row by row.
    let of_texel: Vec<u8> = (0..h)
        .into_par_iter()
        .flat_map_iter(|y| {
            let row: Vec<usize> = (y * w..(y + 1) * w).collect();
            let f = features(btf, &views, &row);
            let centers = &km.centers;
            f.chunks_exact(dim)
                .map(|p| nearest(p, centers, km.k, km.dim) as u8)
                .collect::<Vec<_>>()
        })
        .collect();
    TexelGroups {
        lum: group_luminance(btf, &grid_texels, &of_texel, km.k),
        of_texel,
    }
}

/// Per texel of `texels`: its luminance over the lights in each of `views`, normalised to unit
/// sum per view (all 0 for a black view), `[texel][view][light]`.
fn features(btf: &RawBtf, views: &[usize], texels: &[usize]) -> Vec<f32> {
    let nl = btf.lights().len();
    let plane = btf.width() * btf.height();
    let data = btf.data();
    let dim = views.len() * nl;
    let mut f = vec![0f32; texels.len() * dim];
    for (a, &v) in views.iter().enumerate() {
        for l in 0..nl {
            let base = (v * nl + l) * plane;
            for (t, &texel) in texels.iter().enumerate() {
                let i = 3 * (base + texel);
                let b = Spectrum::new(data[i].to_f32(), data[i + 1].to_f32(), data[i + 2].to_f32());
                let y = luminance(b);
                f[t * dim + a * nl + l] = if y.is_finite() { y.max(0.0) } else { 0.0 };
            }
        }
    }
    for per_view in f.chunks_exact_mut(nl) {
        let sum: f32 = per_view.iter().sum();
        if sum > 0.0 && sum.is_finite() {
            per_view.iter_mut().for_each(|y| *y /= sum);
        } else {
            per_view.fill(0.0);
        }
    }
    f
}

/// The centre (of `k`, `dim` floats each, zero-padded beyond `p.len()`) nearest to `p`; ties go
/// to the lower index.
fn nearest(p: &[f32], centers: &[f32], k: usize, dim: usize) -> usize {
    let mut best = (f32::INFINITY, 0);
    for c in 0..k {
        let centre = &centers[c * dim..c * dim + p.len()];
        let d: f32 = p.iter().zip(centre).map(|(a, b)| (a - b) * (a - b)).sum();
        if d < best.0 {
            best = (d, c);
        }
    }
    best.1
}

/// `[group][view][light]` luminance of B averaged over the grid texels of each of `k` groups
/// (`of_texel` empty: one group of all). A group without grid texels takes the average of all.
fn group_luminance(btf: &RawBtf, grid: &[usize], of_texel: &[u8], k: usize) -> Vec<f32> {
    let (nv, nl) = (btf.views().len(), btf.lights().len());
    let plane = btf.width() * btf.height();
    let data = btf.data();
    let group = |t: usize| of_texel.get(t).map_or(0, |&g| g as usize);
    // Per (view, light): every group's mean luminance.
    let per_vl: Vec<Vec<f32>> = (0..nv * nl)
        .into_par_iter()
        .map(|vl| {
            let mut sum = vec![Spectrum::ZERO; k];
            let mut count = vec![0u32; k];
            for &t in grid {
                let i = 3 * (vl * plane + t);
                let g = group(t);
                sum[g] +=
                    Spectrum::new(data[i].to_f32(), data[i + 1].to_f32(), data[i + 2].to_f32());
                count[g] += 1;
            }
            let all = sum.iter().fold(Spectrum::ZERO, |a, &b| a + b) / grid.len().max(1) as f32;
            let clean = |l: f32| if l.is_finite() { l.max(0.0) } else { 0.0 };
            (0..k)
                .map(|g| {
                    let mean = if count[g] > 0 {
                        sum[g] / count[g] as f32
                    } else {
                        all
                    };
                    clean(luminance(mean))
                })
                .collect()
        })
        .collect();
    let mut lum = vec![0f32; k * nv * nl];
    for (vl, groups) in per_vl.iter().enumerate() {
        for (g, &l) in groups.iter().enumerate() {
            lum[g * nv * nl + vl] = l;
        }
    }
    lum
}
