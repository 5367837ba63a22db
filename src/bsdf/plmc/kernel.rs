//! Every evaluation of a [`PlmcMaterial`] (the material itself, its layout and construction are
//! `material.rs`): the generic PLM-C / PLM / LM kernel (4 lanes per view: R, G, B, pad) for
//! SSE2 and AVX2+FMA, and the dispatch to the AVX-512 kernels where they apply.
//!
//! The lane kernels index several arrays with one loop variable; iterator rewrites obscure them.
#![allow(clippy::needless_range_loop)]

use super::material::{LobeRec, Params, PlmcMaterial};
use super::query::{BATCH, BatchQuery};
use crate::math::Vec3;
#[cfg(target_arch = "x86_64")]
use crate::math::simd::Level;
use crate::math::simd::approx::{fused_exp2_f4, fused_log2_f4};
use crate::math::simd::f4::F4;
use crate::model::ValueSpace;

/// Lobe values Y below this are 0 in the kernel (keeps the arithmetic free of denormals).
pub const FLUSH: f32 = 1e-20;
/// Lanes of one view in the kernel: R, G, B and a pad lane whose result is discarded.
pub const LANES: usize = 4;

/// The lobes (R, G, B) of one (view, texel), transposed to lanes: ρ, Dx, Dy, Dz, n.
pub(super) type LaneLobes = [F4; 5];

/// Gathers the lobes of (view, texel): the only part that differs between the layouts.
pub(super) trait LobeAt {
    fn lobes(&self, view: usize, texel: usize) -> LaneLobes;
}

pub(super) struct Clustered<'a, I> {
    k: usize,
    views: usize,
    records: &'a [LobeRec],
    index: &'a [[I; 4]],
}

impl<I: Copy + Into<usize>> LobeAt for Clustered<'_, I> {
    #[inline(always)]
    fn lobes(&self, view: usize, texel: usize) -> LaneLobes {
        let i = self.index[texel * self.views + view];
        let base = view * 3 * self.k;
        let r = &self.records[base + i[0].into()].0;
        let g = &self.records[base + self.k + i[1].into()].0;
        let b = &self.records[base + 2 * self.k + i[2].into()].0;
        F4::transpose3(r, g, b)
    }
}

pub(super) struct PerTexel<'a> {
    texels: usize,
    lobes: &'a [[f32; 5]],
}

impl LobeAt for PerTexel<'_> {
    #[inline(always)]
    fn lobes(&self, view: usize, texel: usize) -> LaneLobes {
        let l = &self.lobes[(view * self.texels + texel) * 3..][..3];
        std::array::from_fn(|p| F4::from_array([l[0][p], l[1][p], l[2][p], 0.0]))
    }
}

/// Per view of one evaluation: the light-interpolated polynomial `a_0..a_4` and the two range
/// clamps (lobe value Y, polynomial output), as lanes.
#[derive(Clone, Copy)]
pub(super) struct ViewPoly {
    a: [F4; 5],
    y_max: F4,
    out_max: F4,
}

impl PlmcMaterial {
    /// B(view `wi`, light `wo`, texel) (cosine-baked, linear RGB) of the nearest texel
    /// (column `x`, row `y`); both directions must be in the upper hemisphere.
    #[inline]
    pub fn eval_b(&self, wi: Vec3, wo: Vec3, x: usize, y: usize) -> [f32; 3] {
        let (vi, vw) = self.view_lookup(wi);
        let (li, lw) = self.light_lookup(wo);
        self.eval_b_with(vi, vw, li, lw, wo, &[(y * self.width + x, 1.0)])
    }

    /// B blended over `texels` (texel index, weight) with the view lookup already done.
    #[inline]
    pub fn eval_b_with_views(
        &self,
        vi: [u32; 3],
        vw: [f32; 3],
        wo: Vec3,
        texels: &[(usize, f32)],
    ) -> [f32; 3] {
        let (li, lw) = self.light_lookup(wo);
        self.eval_b_with(vi, vw, li, lw, wo, texels)
    }

    /// B blended over `texels` with both direction lookups done (views `vi`/`vw`, lights
    /// `li`/`lw` around `wo`).
    #[inline]
    pub fn eval_b_with(
        &self,
        vi: [u32; 3],
        vw: [f32; 3],
        li: [u32; 3],
        lw: [f32; 3],
        wo: Vec3,
        texels: &[(usize, f32)],
    ) -> [f32; 3] {
        #[cfg(target_arch = "x86_64")]
        if let ([(texel, tw)], Some(t)) = (texels, self.avx512_tables()) {
            // SAFETY: `avx512_tables` is Some only at `Level::Avx512`, which `simd::isa()`
            // gives only on CPUs with AVX-512F, AVX2 and FMA.
            let b = unsafe { super::avx512::eval(&t, vi, vw, li, lw, [wo.x, wo.y, wo.z], *texel) };
            return b.map(|x| x * tw);
        }
        #[cfg(target_arch = "x86_64")]
        if self.isa.level() >= Level::Avx2 {
            // SAFETY: `simd::isa()` gives these levels only on CPUs with AVX2 and FMA.
            return unsafe { self.eval_b_avx2(vi, vw, (li, lw), wo, texels) };
        }
        self.eval_b_lanes(vi, vw, (li, lw), wo, texels)
    }

    /// The tables of the AVX kernels, if this material has their layout: PLM-C with u8 indices
    /// and polynomials.
    #[cfg(target_arch = "x86_64")]
    #[inline]
    fn avx_tables(&self) -> Option<super::query::Tables<'_>> {
        match &self.params {
            Params::Clustered8 { k, records, index } if !self.polys.is_empty() => {
                Some(super::query::Tables {
                    k: *k,
                    n_views: self.n_views,
                    n_lights: self.n_lights,
                    records,
                    index,
                    polys: &self.polys,
                    y_max: &self.y_max,
                    out_max: &self.out_max,
                    srgb: self.space == ValueSpace::Srgb,
                })
            }
            _ => None,
        }
    }

    /// The tables of the single-query AVX-512 kernel, if this material runs it: the AVX
    /// layout on an AVX-512 CPU (nearest texel; the caller checks that).
    #[cfg(target_arch = "x86_64")]
    #[inline]
    fn avx512_tables(&self) -> Option<super::query::Tables<'_>> {
        (self.isa.level() == Level::Avx512)
            .then(|| self.avx_tables())
            .flatten()
    }

    /// The tables of the 16-query kernel, if this material runs it: the AVX layout on an AVX2
    /// or AVX-512 CPU (on AVX-512 with every offset within its gathers' 32-bit range).
    #[cfg(target_arch = "x86_64")]
    #[inline]
    fn batch_tables(&self) -> Option<super::query::Tables<'_>> {
        let level = self.isa.level();
        (level >= Level::Avx2)
            .then(|| self.avx_tables())
            .flatten()
            .filter(|t| level != Level::Avx512 || super::batch::fits(t))
    }

    /// True if [`PlmcMaterial::eval_b_batch`] runs the 16-query kernel (else it evaluates the
    /// queries one by one).
    pub fn batches(&self) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self.batch_tables().is_some() {
            return true;
        }
        false
    }

    /// B (nearest texel) of up to 16 queries, each exactly what [`PlmcMaterial::eval_b_with`]
    /// returns for it with the single texel `(q.texel, 1.0)`: one call of the 16-query kernel
    /// (16 AVX-512 lanes, or two passes of 8 AVX2 lanes) where [`PlmcMaterial::batches`], else
    /// query by query.
    pub fn eval_b_batch(&self, q: &[BatchQuery], out: &mut [[f32; 3]]) {
        assert!(q.len() <= BATCH && out.len() == q.len());
        #[cfg(target_arch = "x86_64")]
        if let Some(t) = self.batch_tables() {
            if self.isa.level() == Level::Avx512 {
                // SAFETY: `simd::isa()` gives `Level::Avx512` only on CPUs with AVX-512F, AVX2
                // and FMA.
                unsafe { super::batch::eval(&t, q, out) };
            } else {
                // SAFETY: `batch_tables` is Some only at `Level::Avx2` or above, which
                // `simd::isa()` gives only on CPUs with AVX2 and FMA.
                unsafe { super::batch_avx2::eval(&t, q, out) };
            }
            return;
        }
        for (o, q) in out.iter_mut().zip(q) {
            let wo = Vec3::new(q.wo[0], q.wo[1], q.wo[2]);
            *o = self.eval_b_with(q.vi, q.vw, q.li, q.lw, wo, &[(q.texel as usize, 1.0)]);
        }
    }

    /// [`PlmcMaterial::eval_b_with`] compiled for AVX2 + FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn eval_b_avx2(
        &self,
        vi: [u32; 3],
        vw: [f32; 3],
        lights: ([u32; 3], [f32; 3]),
        wo: Vec3,
        texels: &[(usize, f32)],
    ) -> [f32; 3] {
        self.eval_b_lanes(vi, vw, lights, wo, texels)
    }

    /// The kernel (for the instruction set of the caller's build), dispatched on the index
    /// layout.
    #[inline(always)]
    fn eval_b_lanes(
        &self,
        vi: [u32; 3],
        vw: [f32; 3],
        (li, lw): ([u32; 3], [f32; 3]),
        wo: Vec3,
        texels: &[(usize, f32)],
    ) -> [f32; 3] {
        let texel_count = self.width * self.height;
        match &self.params {
            Params::Clustered8 { k, records, index } => self.eval_texels(
                &Clustered {
                    k: *k,
                    views: self.n_views,
                    records,
                    index,
                },
                vi,
                vw,
                (li, lw),
                wo,
                texels,
            ),
            Params::Clustered16 { k, records, index } => self.eval_texels(
                &Clustered {
                    k: *k,
                    views: self.n_views,
                    records,
                    index,
                },
                vi,
                vw,
                (li, lw),
                wo,
                texels,
            ),
            Params::Texel { lobes } => self.eval_texels(
                &PerTexel {
                    texels: texel_count,
                    lobes,
                },
                vi,
                vw,
                (li, lw),
                wo,
                texels,
            ),
        }
    }

    /// The light-interpolated polynomial and clamps of view `v` (lights `li` with weights `lw`).
    #[inline(always)]
    fn view_poly(&self, v: usize, li: [u32; 3], lw: [f32; 3]) -> ViewPoly {
        let base = v * self.n_lights;
        let r = each3(|b| &self.polys[base + li[b] as usize].0);
        let m = each3(|b| F4::load(&self.out_max[base + li[b] as usize]));
        let w = each3(|b| F4::splat(lw[b]));
        // a_j of R, G, B is the 4-lane window at 3 j of the row (the pad lane is discarded).
        let win = |row: &[f32; 16], j: usize| F4::load(&row[3 * j..]);
        ViewPoly {
            a: each5(|j| {
                w[2].mul_add(
                    win(r[2], j),
                    w[1].mul_add(win(r[1], j), w[0] * win(r[0], j)),
                )
            }),
            y_max: F4::load(&self.y_max[v]),
            out_max: m[0].max(m[1]).max(m[2]),
        }
    }

    /// [`PlmcMaterial::view_poly`] of the 3 views (no closure: too big for the inliner, it
    /// stays an out-of-line call per view).
    #[inline(always)]
    fn view_polys(&self, vi: [usize; 3], li: [u32; 3], lw: [f32; 3]) -> [ViewPoly; 3] {
        [
            self.view_poly(vi[0], li, lw),
            self.view_poly(vi[1], li, lw),
            self.view_poly(vi[2], li, lw),
        ]
    }

    #[inline(always)]
    fn eval_texels<P: LobeAt>(
        &self,
        p: &P,
        vi: [u32; 3],
        vw: [f32; 3],
        (li, lw): ([u32; 3], [f32; 3]),
        wo: Vec3,
        texels: &[(usize, f32)],
    ) -> [f32; 3] {
        let has_polys = !self.polys.is_empty();
        let vi = each3(|a| vi[a] as usize);
        let mut out = F4::splat(0.0);
        // Light interpolation of the polynomial rows: once per evaluation when several texels
        // share it (bilinear); for one texel after the gathers, so that their cache misses are
        // issued first and the rows need not stay live across them.
        let shared = (has_polys && texels.len() > 1).then(|| self.view_polys(vi, li, lw));
        for &(t, tw) in texels {
            // All 9 lobes first: their cache misses overlap instead of stalling view by view.
            let lobes = [p.lobes(vi[0], t), p.lobes(vi[1], t), p.lobes(vi[2], t)];
            let vp = match shared {
                Some(s) => Some(s),
                None if has_polys => Some(self.view_polys(vi, li, lw)),
                None => None,
            };
            let y = self.eval_views(&lobes, vp.as_ref(), wo);
            for a in 0..3 {
                out = F4::splat(tw * vw[a]).mul_add(y[a], out);
            }
        }
        let o = out.to_array();
        [o[0], o[1], o[2]]
    }

    /// The (R, G, B, pad) values of the 3 views' lobes at light `wo`, linear. Stage by stage
    /// over the views, so their independent dependency chains (log2 → exp2 → polynomial →
    /// decode) are interleaved in the instruction stream rather than run one after the other.
    #[inline(always)]
    fn eval_views(&self, l: &[LaneLobes; 3], vp: Option<&[ViewPoly; 3]>, wo: Vec3) -> [F4; 3] {
        let zero = F4::splat(0.0);
        let (wx, wy, wz) = (F4::splat(wo.x), F4::splat(wo.y), F4::splat(wo.z));
        let b: [F4; 3] = each3(|a| l[a][3].mul_add(wz, l[a][2].mul_add(wy, l[a][1] * wx)));
        // b^n = 2^(n log2 b), 0 where b ≤ 0 (the clamp keeps log2 finite). No denormals
        // anywhere: each one costs a ~150-cycle microcode assist on x86, and random directions
        // make many (lanes with b ≤ 0, steep lobes). So the exponent is clamped at −100 and
        // Y < FLUSH (a value no measurement resolves) is flushed to 0 before the polynomial.
        let lg: [F4; 3] = each3(|a| fused_log2_f4(b[a].max(F4::splat(1e-30))));
        let pw: [F4; 3] = each3(|a| fused_exp2_f4((l[a][4] * lg[a]).max(F4::splat(-100.0))));
        let mut y: [F4; 3] = each3(|a| {
            let y = l[a][0] * pw[a];
            b[a].gt_or_zero(zero, y.gt_or_zero(F4::splat(FLUSH), y))
        });
        if let Some(vp) = vp {
            y = each3(|a| {
                let x = y[a].min(vp[a].y_max);
                let c = &vp[a].a;
                // Estrin: (a0 + a1 x) + x² ((a2 + a3 x) + x² a4): 3 dependent steps, not 4.
                let x2 = x * x;
                let lo = c[1].mul_add(x, c[0]);
                let hi = c[4].mul_add(x2, c[3].mul_add(x, c[2]));
                hi.mul_add(x2, lo).min(vp[a].out_max)
            });
        }
        match self.space {
            // As maxps: NaN → 0, like `f32::max(v, 0.0)`.
            ValueSpace::Linear => each3(|a| y[a].max(zero)),
            ValueSpace::Srgb => each3(|a| srgb_to_linear_f4(y[a])),
        }
    }
}

/// `[f(0), f(1), f(2)]`, always inlined (`array::map` and `from_fn` are not always, and in
/// the AVX2 kernel an out-of-line closure is a call per view).
#[inline(always)]
fn each3<T>(mut f: impl FnMut(usize) -> T) -> [T; 3] {
    [f(0), f(1), f(2)]
}

/// `[f(0), …, f(4)]`, always inlined (see [`each3`]).
#[inline(always)]
fn each5<T>(mut f: impl FnMut(usize) -> T) -> [T; 5] {
    [f(0), f(1), f(2), f(3), f(4)]
}

/// `srgb_to_linear(max(0, v))` lane-wise, branch-free.
#[inline(always)]
pub(super) fn srgb_to_linear_f4(y: F4) -> F4 {
    let v = y.max(F4::splat(0.0));
    let lo = v * F4::splat(1.0 / 12.92);
    let base = ((v + F4::splat(0.055)) * F4::splat(1.0 / 1.055)).max(F4::splat(1e-30));
    let hi = fused_exp2_f4(F4::splat(2.4) * fused_log2_f4(base));
    v.le_select(F4::splat(0.04045), lo, hi)
}

/// b^n = exp2(n · log2 b) lane-wise for b > 0 (normal) and n ≥ 0; results below 2^−100 are
/// 2^−100 (never a denormal, see `eval_view`).
#[cfg(test)]
#[inline(always)]
pub(super) fn pow_f4(b: F4, n: F4) -> F4 {
    fused_exp2_f4((n * fused_log2_f4(b)).max(F4::splat(-100.0)))
}
