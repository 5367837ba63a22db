//! The per-(view, light) tables a material derives from its model at load: texel-mean values at
//! the measured directions (what the light sampler is built on) and the range clamps `y_max` /
//! `out_max` of the evaluation.
//!
//! A PLM-C model needs every cluster's lobe at every measured light of every view, mapped by that
//! image's polynomial: views × lights × 3 × K terms (5 M for 81 × 81 directions and K = 256).
//! They run 16 lobes per step in SoA with the branch-free `exp2`/`log2` of
//! [`crate::math::simd::approx`] (no fused multiply-adds: the same bits on every ISA), the same
//! kind of arithmetic the evaluation kernels use, instead of two libm `powf` calls per term (the
//! Lafortune power and the sRGB decode), whose cost would otherwise dominate a material's load.

use crate::math::simd::approx;
use crate::model::{PlmcModel, ValueSpace, ViewParams, lobe, polynomial};
use rayon::prelude::*;

/// Texels per axis averaged (at most) per image when building the tables of per-texel models.
const TABLE_TEXELS: usize = 64;

/// Lobes per SoA step.
const W: usize = 16;

/// The lobes of one (view, channel) in SoA, padded to a multiple of [`W`] with zero-weight lanes
/// (ρ = 0, weight 0: they add nothing to a sum and are kept out of the maxima).
#[derive(Default)]
struct LobeSoa {
    rho: Vec<f32>,
    dx: Vec<f32>,
    dy: Vec<f32>,
    dz: Vec<f32>,
    n: Vec<f32>,
    /// Texels the lobe stands for (a cluster's member count; 1 for a sampled texel).
    weight: Vec<f32>,
}

impl LobeSoa {
    fn push(&mut self, l: &lobe::Lobe, weight: f32) {
        self.rho.push(l[0]);
        self.dx.push(l[1]);
        self.dy.push(l[2]);
        self.dz.push(l[3]);
        self.n.push(l[4]);
        self.weight.push(weight);
    }

    fn pad(&mut self) {
        while !self.rho.len().is_multiple_of(W) {
            self.push(&lobe::ZERO_LOBE, 0.0);
        }
    }
}

/// Sums and maxima of one (view, channel) at one light: Σ weight · linear value and the largest
/// model-space output (≥ 0) over the lobes of positive weight.
#[derive(Clone, Copy, Default)]
struct LightSum {
    sum: f64,
    out_max: f32,
}

/// Per light `l` (direction `dirs[l]`, mapping `polys[l]`): Σ weight · to_linear(poly(Y)) and
/// max(0, poly(Y)) over the lobes of `s`, Y = ρ · max(0, D·u)^n.
#[inline(always)]
fn light_sums_body(
    s: &LobeSoa,
    dirs: &[crate::math::Vec3],
    polys: &[polynomial::Poly],
    srgb: bool,
    out: &mut [LightSum],
) {
    for ((u, a), o) in dirs.iter().zip(polys).zip(out.iter_mut()) {
        let mut sum = [0f32; W];
        let mut omax = [0f32; W];
        for c in 0..s.rho.len() / W {
            let r = c * W..(c + 1) * W;
            let (rho, dx, dy, dz, n, w) = (
                &s.rho[r.clone()],
                &s.dx[r.clone()],
                &s.dy[r.clone()],
                &s.dz[r.clone()],
                &s.n[r.clone()],
                &s.weight[r],
            );
            for i in 0..W {
                let b = dx[i] * u.x + dy[i] * u.y + dz[i] * u.z;
                // b^n = 2^(n log2 b); b ≤ 0 gives 0 (the select keeps log2's NaN out).
                let p = approx::exp2(n[i] * approx::log2(b.max(1e-30)));
                let y = if b > 0.0 { rho[i] * p } else { 0.0 };
                let m = polynomial::eval(a, y);
                let lin = if srgb {
                    let v = m.max(0.0);
                    let hi = approx::exp2(2.4 * approx::log2(((v + 0.055) / 1.055).max(1e-30)));
                    if v <= 0.04045 { v / 12.92 } else { hi }
                } else {
                    m.max(0.0)
                };
                sum[i] += w[i] * lin;
                omax[i] = if w[i] > 0.0 { omax[i].max(m) } else { omax[i] };
            }
        }
        *o = LightSum {
            sum: sum.iter().map(|&x| x as f64).sum(),
            out_max: omax.iter().fold(0f32, |a, &b| a.max(b)),
        };
    }
}

/// Per lobe of `s`: the largest Lafortune base max(0, D·u) over the directions `dirs`.
#[inline(always)]
fn max_bases_body(s: &LobeSoa, dirs: &[crate::math::Vec3], bmax: &mut [f32]) {
    bmax.iter_mut().for_each(|b| *b = 0.0);
    for u in dirs {
        for c in 0..s.rho.len() / W {
            let r = c * W..(c + 1) * W;
            let (dx, dy, dz) = (&s.dx[r.clone()], &s.dy[r.clone()], &s.dz[r.clone()]);
            let m = &mut bmax[r];
            for i in 0..W {
                m[i] = m[i].max(dx[i] * u.x + dy[i] * u.y + dz[i] * u.z);
            }
        }
    }
}

crate::isa_dispatch! {
    /// [`max_bases_body`] built for an instruction set (16 lobes per step).
    fn max_bases(s: &LobeSoa, dirs: &[crate::math::Vec3], bmax: &mut [f32]) -> () = max_bases_body;
}

/// The largest value over the measured lights of the lobes of positive weight in `s`:
/// ρ · (max_l D·u_l)^n (x^n is monotone), by libm `powf` on the 16-wide maxima.
fn y_peak(isa: crate::math::simd::Isa, s: &LobeSoa, dirs: &[crate::math::Vec3]) -> f32 {
    let mut bmax = vec![0f32; s.rho.len()];
    max_bases(isa, s, dirs, &mut bmax);
    let mut y = 0f32;
    for (j, &b) in bmax.iter().enumerate() {
        if s.weight[j] > 0.0 && b > 0.0 {
            y = y.max(s.rho[j] * b.powf(s.n[j]));
        }
    }
    y
}

crate::isa_dispatch! {
    /// [`light_sums_body`] built for an instruction set (16 lobes per step in SoA).
    fn light_sums(
        s: &LobeSoa,
        dirs: &[crate::math::Vec3],
        polys: &[polynomial::Poly],
        srgb: bool,
        out: &mut [LightSum],
    ) -> () = light_sums_body;
}

/// Texel-mean model values at the measured directions, `[view][light][rgb]` (linear; PLM-C:
/// every cluster weighted by its member count; per-texel models: at most 64 × 64 sampled texels
/// per image), the largest lobe value per view and channel over the measured lights (`y_max`),
/// and the largest model-space output per (view, light) and channel (`out_max`).
pub(super) fn mean_values(model: &PlmcModel) -> (Vec<f32>, Vec<[f32; 3]>, Vec<[f32; 4]>) {
    let (nv, nl) = (model.views.len(), model.lights.len());
    let (w, h) = (model.width, model.height);
    let isa = crate::math::simd::isa();
    let srgb = model.space == ValueSpace::Srgb;
    type PerView = (Vec<f32>, [f32; 3], Vec<[f32; 4]>);
    let per_view: Vec<PerView> = (0..nv)
        .into_par_iter()
        .map(|v| {
            let mut y_max = [0f32; 3];
            // Per channel: the lobes, and the divisor of their weighted sum.
            let mut soa: [LobeSoa; 3] = Default::default();
            let divisor = match &model.params[v] {
                ViewParams::Clustered { k, table, index } => {
                    let mut counts = vec![0u32; 3 * k];
                    for (t, &i) in index.iter().enumerate() {
                        counts[3 * i as usize + t % 3] += 1;
                    }
                    for (j, p) in table.iter().enumerate() {
                        if counts[j] > 0 {
                            soa[j % 3].push(&p.unpack(), counts[j] as f32);
                        }
                    }
                    for (c, s) in soa.iter_mut().enumerate() {
                        s.pad();
                        y_max[c] = y_peak(isa, s, &model.lights.dirs);
                    }
                    (w * h) as f64
                }
                ViewParams::Texel(packed) => {
                    // Y's range over every texel, the sums over the sampled ones.
                    let mut all: [LobeSoa; 3] = Default::default();
                    for (t, p) in packed.iter().enumerate() {
                        all[t % 3].push(&p.unpack(), 1.0);
                    }
                    for (c, s) in all.iter_mut().enumerate() {
                        s.pad();
                        y_max[c] = y_peak(isa, s, &model.lights.dirs);
                    }
                    let (sx, sy) = (w.div_ceil(TABLE_TEXELS), h.div_ceil(TABLE_TEXELS));
                    let mut picks = 0usize;
                    for y in (0..h).step_by(sy) {
                        for x in (0..w).step_by(sx) {
                            let t = y * w + x;
                            for (c, s) in soa.iter_mut().enumerate() {
                                s.push(&packed[3 * t + c].unpack(), 1.0);
                            }
                            picks += 1;
                        }
                    }
                    picks as f64
                }
            };
            let mut out = vec![0f32; nl * 3];
            let mut omax = vec![[0f32; 4]; nl];
            let mut sums = vec![LightSum::default(); nl];
            for (c, s) in soa.iter_mut().enumerate() {
                s.pad();
                let polys: Vec<polynomial::Poly> = (0..nl).map(|l| model.poly(v, l, c)).collect();
                light_sums(isa, s, &model.lights.dirs, &polys, srgb, &mut sums);
                for (l, r) in sums.iter().enumerate() {
                    out[3 * l + c] = (r.sum / divisor) as f32;
                    omax[l][c] = r.out_max;
                }
            }
            (out, y_max, omax)
        })
        .collect();
    let y_max = per_view.iter().map(|p| p.1).collect();
    let out_max = per_view.iter().flat_map(|p| p.2.iter().copied()).collect();
    (
        per_view.into_iter().flat_map(|p| p.0).collect(),
        y_max,
        out_max,
    )
}
