//! The fitted models (LM, PLM, PLM-C; DESIGN §4) evaluated at every shading hit, and their BSDF.
//!
//! For a hit (texel, ω_v, ω_l): the 3 measured views around ω_v with barycentric weights; per view
//! and channel the texel's lobe (PLM-C: its cluster's lobe via the u8 index planes) is evaluated
//! at the actual ω_l, mapped by the degree-4 polynomial whose coefficients are interpolated over
//! the 3 measured lights around ω_l (LM: identity), decoded to linear if the model was fitted in
//! sRGB (`srgb_to_linear(max(0, ·))`), and the 3 views are blended.
//!
//! Layout (data-oriented, nothing allocated per evaluation, no branch on data in the inner loop):
//! - the 3 views × 3 channels are 9 of [`LANES`] = 12 lanes (three 4-wide or 8+4 vectors); lobe
//!   parameters are gathered into structure-of-arrays lanes `[ρ; 12] [Dx; 12] …` and the
//!   Lafortune power, polynomial and sRGB decode run lane-wise with a branch-free exp2/log2;
//! - PLM-C cluster tables: per (view, channel) K records `{ρ, Dx, Dy, Dz, n}` padded to 8 f32
//!   (32-byte aligned, one record never straddles a cache line: a gather is one line, not five
//!   as with a table per parameter);
//! - index planes: per view `[texel][R, G, B, pad]` u8 (u16 above 256 clusters), so one texel of
//!   one view is one 4-byte load and neighbouring texels share cache lines;
//! - polynomial coefficients: dense `[view][light]` rows of 16 f32 (a_0..a_4 for R, G, B + pad),
//!   64-byte aligned: light interpolation is three 16-wide multiply-adds on three cache lines.
//!
//! Kernels: on AVX-512 CPUs the PLM-C case of the renderer (u8 indices, nearest texel) runs
//! `avx512.rs`, the 9 lanes in one 16-lane register (about a third of the 4-wide build's
//! instructions); everything else runs the generic 4-wide kernel below, built for AVX2+FMA where
//! the CPU has it, else SSE2. A shading hit's view lookup and texel addressing are done once by
//! [`PlmcBsdf::prepare`] and shared by its `eval_pdf` and `sample` ([`PlmcHit`]).
//!
//! Sampling reuses the raw material's tabulated light distribution ([`BtfMaterial`]), built at
//! load from the model's texel-averaged values at the measured directions, mixed with the uniform
//! defensive component exactly as for raw data.
//!
//! The lane kernels index several arrays with one loop variable; iterator rewrites obscure them.
#![allow(clippy::needless_range_loop)]

use crate::bsdf::{BsdfFlags, BsdfSample, BtfMaterial};
use crate::btf::{RawBtf, StoredEncoding};
use crate::fit::lafortune;
use crate::fit::model::{ModelKind, PlmcModel, ValueSpace, ViewParams};
use crate::fit::polynomial;
use crate::geometry::SurfaceInteraction;
use crate::math::{INV_PI, Spectrum, Vec2, Vec3};
use crate::{Error, Result};
use f4::{F4, Isa, Sse2};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Lobe values Y below this are 0 in the kernel (keeps the arithmetic free of denormals).
pub const FLUSH: f32 = 1e-20;
/// Lanes of one view in the kernel: R, G, B and a pad lane whose result is discarded.
pub const LANES: usize = 4;
/// Texels per axis averaged (at most) per image when building the sampling tables.
const TABLE_TEXELS: usize = 64;

/// One lobe record `[ρ, Dx, Dy, Dz, n, 0, 0, 0]`, 32-byte aligned.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub struct LobeRec(pub [f32; 8]);

/// Polynomial coefficients of one (view, light), coefficient-major: `[a_j of R, G, B]` for
/// j = 0..4 then one pad. `a_j` of the 3 channels is the 4-lane window starting at `3 j` (its pad
/// lane reads the next coefficient, harmless: that lane is discarded).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
pub struct PolyRow(pub [f32; 16]);

/// How the per-texel lobes are stored.
enum Params {
    /// PLM-C, ≤ 256 clusters: records `[view][channel][k]`, index `[texel][view][R, G, B, pad]`
    /// (the 3 views of one evaluation are a few hundred bytes apart: one or two cache lines).
    Clustered8 {
        k: usize,
        records: Vec<LobeRec>,
        index: Vec<[u8; 4]>,
    },
    /// PLM-C with more than 256 clusters: u16 indices.
    Clustered16 {
        k: usize,
        records: Vec<LobeRec>,
        index: Vec<[u16; 4]>,
    },
    /// LM / PLM: one lobe per texel and channel, `[view][texel][channel]` as `[ρ, Dx, Dy, Dz, n]`.
    Texel { lobes: Vec<[f32; 5]> },
}

/// The lobes (R, G, B) of one (view, texel), transposed to lanes: ρ, Dx, Dy, Dz, n.
type LaneLobes = [F4; 5];

/// Gathers the lobes of (view, texel): the only part that differs between the layouts.
trait LobeAt {
    fn lobes(&self, view: usize, texel: usize) -> LaneLobes;
}

struct Clustered<'a, I> {
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

struct PerTexel<'a> {
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
struct ViewPoly {
    a: [F4; 5],
    y_max: F4,
    out_max: F4,
}

/// A fitted model in its evaluation layout, with direction interpolators and sampling tables;
/// shared (`Arc`) by every [`PlmcBsdf`] that uses the same file.
pub struct PlmcMaterial {
    kind: ModelKind,
    space: ValueSpace,
    width: usize,
    height: usize,
    n_views: usize,
    n_lights: usize,
    params: Params,
    /// `[view][light]`; empty for LM.
    polys: Vec<PolyRow>,
    /// `[view]` (R, G, B, 0): the largest lobe value Y over the measured lights (and the clusters /
    /// sampled texels). The polynomials were fitted on Y in this range; Y is clamped to it before
    /// the polynomial, which a degree-4 mapping would otherwise extrapolate wildly at unmeasured
    /// light directions near a sharp lobe's peak.
    y_max: Vec<[f32; 4]>,
    /// `[view][light]`: the largest polynomial output (model space) per channel over the
    /// clusters / sampled texels at that measured (view, light). Between measured lights the
    /// output is clamped to the largest bound of the 3 lights: a guard against ill-conditioned
    /// fitted polynomials (|a_j| up to 1e38 occur) that are harmless at the measured directions
    /// but explode for lobe values in between; values at measured directions are unchanged.
    out_max: Vec<[f32; 4]>,
    /// Sampling tables and the view and light interpolators, built from the model's texel-mean
    /// values (its light interpolator is the model's: the same direction set).
    sampler: BtfMaterial,
    /// Set if this CPU has AVX2 + FMA (detected once here): the kernel runs its fused build.
    #[cfg(target_arch = "x86_64")]
    avx2: Option<f4::Avx2Fma>,
    /// Set if this CPU has AVX-512F (and AVX2 + FMA): PLM-C with u8 indices, nearest texel,
    /// runs the 16-lane kernel of `avx512.rs`.
    #[cfg(target_arch = "x86_64")]
    avx512: Option<avx512::Avx512>,
}

impl PlmcMaterial {
    /// Builds the evaluation layout, interpolators and sampling tables of a validated model.
    pub fn new(model: &PlmcModel) -> Result<Self> {
        model.validate()?;
        let (nv, nl) = (model.views.len(), model.lights.len());
        let texels = model.width * model.height;
        let rec = |l: [f32; 5]| LobeRec([l[0], l[1], l[2], l[3], l[4], 0.0, 0.0, 0.0]);
        let params = match model.kind {
            ModelKind::PlmC => {
                let k = model.clusters.max(1);
                let mut records = vec![LobeRec::default(); nv * 3 * k];
                let mut idx16 = vec![[0u16; 4]; nv * texels];
                for (v, p) in model.params.iter().enumerate() {
                    let ViewParams::Clustered {
                        k: kv,
                        table,
                        index,
                    } = p
                    else {
                        return Err(Error::Invalid(format!(
                            "PLM-C model: view {v} has per-texel lobes"
                        )));
                    };
                    for j in 0..*kv {
                        for c in 0..3 {
                            records[(v * 3 + c) * k + j] = rec(table[3 * j + c].unpack());
                        }
                    }
                    for t in 0..texels {
                        let d = &mut idx16[t * nv + v];
                        d[..3].copy_from_slice(&index[3 * t..3 * t + 3]);
                    }
                }
                if k <= 256 {
                    let index = idx16
                        .iter()
                        .map(|q| [q[0] as u8, q[1] as u8, q[2] as u8, 0])
                        .collect();
                    Params::Clustered8 { k, records, index }
                } else {
                    Params::Clustered16 {
                        k,
                        records,
                        index: idx16,
                    }
                }
            }
            ModelKind::Lm | ModelKind::Plm => {
                let mut lobes = Vec::with_capacity(nv * texels * 3);
                for (v, p) in model.params.iter().enumerate() {
                    let ViewParams::Texel(l) = p else {
                        return Err(Error::Invalid(format!(
                            "{} model: view {v} is clustered",
                            model.kind.name()
                        )));
                    };
                    lobes.extend(l.iter().map(|p| p.unpack()));
                }
                Params::Texel { lobes }
            }
        };
        let polys = if model.kind.has_polys() {
            let mut rows = vec![PolyRow::default(); nv * nl];
            for v in 0..nv {
                for l in 0..nl {
                    for c in 0..3 {
                        let a = model.poly(v, l, c);
                        for j in 0..5 {
                            rows[v * nl + l].0[3 * j + c] = a[j];
                        }
                    }
                }
            }
            rows
        } else {
            Vec::new()
        };
        let (means, y_max, out_max) = mean_values(model);
        let y_max = y_max.iter().map(|m| [m[0], m[1], m[2], 0.0]).collect();
        let table = RawBtf::from_f32(
            model.views.clone(),
            model.lights.clone(),
            1,
            1,
            StoredEncoding::Linear,
            &means,
        )?;
        let sampler = BtfMaterial::new(Arc::new(table))?;
        Ok(PlmcMaterial {
            kind: model.kind,
            space: model.space,
            width: model.width,
            height: model.height,
            n_views: nv,
            n_lights: nl,
            params,
            polys,
            y_max,
            out_max,
            sampler,
            #[cfg(target_arch = "x86_64")]
            avx2: f4::Avx2Fma::detect(),
            #[cfg(target_arch = "x86_64")]
            avx512: avx512::Avx512::detect(),
        })
    }

    /// The same material evaluated by the baseline SSE2 kernel even on an AVX2+FMA CPU (to
    /// compare the two builds; results agree to float rounding).
    pub fn without_avx2(mut self) -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            self.avx2 = None;
            self.avx512 = None;
        }
        self
    }

    /// The same material without the AVX-512 kernel (the generic kernel's AVX2+FMA build where
    /// the CPU has it): to compare the builds; results agree to float rounding.
    pub fn without_avx512(mut self) -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            self.avx512 = None;
        }
        self
    }

    /// True if evaluations run the AVX2+FMA build of the kernel.
    pub fn uses_avx2(&self) -> bool {
        #[cfg(target_arch = "x86_64")]
        return self.avx2.is_some();
        #[cfg(not(target_arch = "x86_64"))]
        false
    }

    /// True if PLM-C evaluations (u8 indices, nearest texel) run the AVX-512 kernel.
    pub fn uses_avx512(&self) -> bool {
        #[cfg(target_arch = "x86_64")]
        return self.avx512.is_some() && matches!(self.params, Params::Clustered8 { .. });
        #[cfg(not(target_arch = "x86_64"))]
        false
    }

    /// Reads a `.plmc` file and builds the material; errors name the file.
    pub fn load(path: &Path) -> Result<Self> {
        let model = crate::btf::format::read(path)?;
        Self::new(&model).map_err(|e| Error::format(path, e.to_string()))
    }

    /// The model kind.
    pub fn kind(&self) -> ModelKind {
        self.kind
    }

    /// Texels per row.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Rows of texels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Starts loading the index entries of `texel` (all views: a few cache lines) into the
    /// cache, without waiting; a no-op for per-texel models, whose views are far apart.
    #[inline]
    pub fn prefetch_texel(&self, texel: usize) {
        let nv = self.n_views;
        let (ptr, bytes) = match &self.params {
            Params::Clustered8 { index, .. } => match index.get(texel * nv..(texel + 1) * nv) {
                Some(s) => (s.as_ptr() as usize, std::mem::size_of_val(s)),
                None => return,
            },
            Params::Clustered16 { index, .. } => match index.get(texel * nv..(texel + 1) * nv) {
                Some(s) => (s.as_ptr() as usize, std::mem::size_of_val(s)),
                None => return,
            },
            Params::Texel { .. } => return,
        };
        if bytes == 0 {
            return;
        }
        for line in (ptr & !63..ptr + bytes).step_by(64) {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: a prefetch never faults, and this line holds part of the slice anyway.
            unsafe {
                std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                    line as *const i8,
                );
            }
            #[cfg(not(target_arch = "x86_64"))]
            let _ = line;
        }
    }

    /// Interpolation indices and weights of the 3 measured views around `wi` (local frame).
    #[inline]
    pub fn view_lookup(&self, wi: Vec3) -> ([u32; 3], [f32; 3]) {
        self.sampler.view_interp().lookup(wi)
    }

    /// Interpolation indices and weights of the 3 measured lights around `wo` (local frame).
    #[inline]
    pub fn light_lookup(&self, wo: Vec3) -> ([u32; 3], [f32; 3]) {
        self.sampler.light_interp().lookup(wo)
    }

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
        if let (Some(token), Params::Clustered8 { k, records, index }, [(texel, tw)]) =
            (self.avx512, &self.params, texels)
            && !self.polys.is_empty()
        {
            let t = avx512::Tables {
                k: *k,
                n_views: self.n_views,
                n_lights: self.n_lights,
                records,
                index,
                polys: &self.polys,
                y_max: &self.y_max,
                out_max: &self.out_max,
                srgb: self.space == ValueSpace::Srgb,
            };
            // SAFETY: the token exists only if this CPU has AVX-512F, AVX2 and FMA.
            let b = unsafe { avx512::eval(token, &t, vi, vw, li, lw, [wo.x, wo.y, wo.z], *texel) };
            return b.map(|x| x * tw);
        }
        #[cfg(target_arch = "x86_64")]
        if let Some(isa) = self.avx2 {
            // SAFETY: the token exists only if this CPU has AVX2 and FMA.
            return unsafe { self.eval_b_avx2(isa, vi, vw, (li, lw), wo, texels) };
        }
        self.eval_b_isa(Sse2, vi, vw, (li, lw), wo, texels)
    }

    /// [`PlmcMaterial::eval_b_with`] compiled for AVX2 + FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn eval_b_avx2(
        &self,
        isa: f4::Avx2Fma,
        vi: [u32; 3],
        vw: [f32; 3],
        lights: ([u32; 3], [f32; 3]),
        wo: Vec3,
        texels: &[(usize, f32)],
    ) -> [f32; 3] {
        self.eval_b_isa(isa, vi, vw, lights, wo, texels)
    }

    /// The kernel for the instruction set `isa`, dispatched on the index layout.
    #[inline(always)]
    fn eval_b_isa<I: Isa>(
        &self,
        isa: I,
        vi: [u32; 3],
        vw: [f32; 3],
        (li, lw): ([u32; 3], [f32; 3]),
        wo: Vec3,
        texels: &[(usize, f32)],
    ) -> [f32; 3] {
        let texel_count = self.width * self.height;
        match &self.params {
            Params::Clustered8 { k, records, index } => self.eval_texels(
                (
                    &Clustered {
                        k: *k,
                        views: self.n_views,
                        records,
                        index,
                    },
                    isa,
                ),
                vi,
                vw,
                (li, lw),
                wo,
                texels,
            ),
            Params::Clustered16 { k, records, index } => self.eval_texels(
                (
                    &Clustered {
                        k: *k,
                        views: self.n_views,
                        records,
                        index,
                    },
                    isa,
                ),
                vi,
                vw,
                (li, lw),
                wo,
                texels,
            ),
            Params::Texel { lobes } => self.eval_texels(
                (
                    &PerTexel {
                        texels: texel_count,
                        lobes,
                    },
                    isa,
                ),
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
    fn view_poly<I: Isa>(&self, isa: I, v: usize, li: [u32; 3], lw: [f32; 3]) -> ViewPoly {
        let base = v * self.n_lights;
        let r = each3(|b| &self.polys[base + li[b] as usize].0);
        let m = each3(|b| F4::load(&self.out_max[base + li[b] as usize]));
        let w = each3(|b| F4::splat(lw[b]));
        // a_j of R, G, B is the 4-lane window at 3 j of the row (the pad lane is discarded).
        let win = |row: &[f32; 16], j: usize| F4::load(&row[3 * j..]);
        ViewPoly {
            a: each5(|j| {
                isa.fma(
                    w[2],
                    win(r[2], j),
                    isa.fma(w[1], win(r[1], j), w[0] * win(r[0], j)),
                )
            }),
            y_max: F4::load(&self.y_max[v]),
            out_max: m[0].max(m[1]).max(m[2]),
        }
    }

    /// [`PlmcMaterial::view_poly`] of the 3 views (no closure: too big for the inliner, it
    /// stays an out-of-line call per view).
    #[inline(always)]
    fn view_polys<I: Isa>(
        &self,
        isa: I,
        vi: [usize; 3],
        li: [u32; 3],
        lw: [f32; 3],
    ) -> [ViewPoly; 3] {
        [
            self.view_poly(isa, vi[0], li, lw),
            self.view_poly(isa, vi[1], li, lw),
            self.view_poly(isa, vi[2], li, lw),
        ]
    }

    #[inline(always)]
    fn eval_texels<P: LobeAt, I: Isa>(
        &self,
        (p, isa): (&P, I),
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
        let shared = (has_polys && texels.len() > 1).then(|| self.view_polys(isa, vi, li, lw));
        for &(t, tw) in texels {
            // All 9 lobes first: their cache misses overlap instead of stalling view by view.
            let lobes = [p.lobes(vi[0], t), p.lobes(vi[1], t), p.lobes(vi[2], t)];
            let vp = match shared {
                Some(s) => Some(s),
                None if has_polys => Some(self.view_polys(isa, vi, li, lw)),
                None => None,
            };
            let y = self.eval_views(isa, &lobes, vp.as_ref(), wo);
            for a in 0..3 {
                out = isa.fma(F4::splat(tw * vw[a]), y[a], out);
            }
        }
        let o = out.to_array();
        [o[0], o[1], o[2]]
    }

    /// The (R, G, B, pad) values of the 3 views' lobes at light `wo`, linear. Stage by stage
    /// over the views, so their independent dependency chains (log2 → exp2 → polynomial →
    /// decode) are interleaved in the instruction stream rather than run one after the other.
    #[inline(always)]
    fn eval_views<I: Isa>(
        &self,
        isa: I,
        l: &[LaneLobes; 3],
        vp: Option<&[ViewPoly; 3]>,
        wo: Vec3,
    ) -> [F4; 3] {
        let zero = F4::splat(0.0);
        let (wx, wy, wz) = (F4::splat(wo.x), F4::splat(wo.y), F4::splat(wo.z));
        let b: [F4; 3] = each3(|a| isa.fma(l[a][3], wz, isa.fma(l[a][2], wy, l[a][1] * wx)));
        // b^n = 2^(n log2 b), 0 where b ≤ 0 (the clamp keeps log2 finite). No denormals
        // anywhere: each one costs a ~150-cycle microcode assist on x86, and random directions
        // make many (lanes with b ≤ 0, steep lobes). So the exponent is clamped at −100 and
        // Y < FLUSH (a value no measurement resolves) is flushed to 0 before the polynomial.
        let lg: [F4; 3] = each3(|a| b[a].max(F4::splat(1e-30)).log2(isa));
        let pw: [F4; 3] = each3(|a| (l[a][4] * lg[a]).max(F4::splat(-100.0)).exp2(isa));
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
                let lo = isa.fma(c[1], x, c[0]);
                let hi = isa.fma(c[4], x2, isa.fma(c[3], x, c[2]));
                isa.fma(hi, x2, lo).min(vp[a].out_max)
            });
        }
        match self.space {
            // As maxps: NaN → 0, like `f32::max(v, 0.0)`.
            ValueSpace::Linear => each3(|a| y[a].max(zero)),
            ValueSpace::Srgb => each3(|a| srgb_to_linear_f4(isa, y[a])),
        }
    }
}

/// Texel-mean model values at the measured directions, `[view][light][rgb]` (linear, exact
/// per-cluster sums for PLM-C; at most 64 × 64 texels per image for per-texel models), and the
/// largest lobe value per view and channel over the measured lights (see `y_max`).
fn mean_values(model: &PlmcModel) -> (Vec<f32>, Vec<[f32; 3]>, Vec<[f32; 4]>) {
    let (nv, nl) = (model.views.len(), model.lights.len());
    let (w, h) = (model.width, model.height);
    // (linear value, model-space polynomial output) of a lobe at a measured (view, light).
    let value2 = |v: usize, l: usize, c: usize, lobe: &lafortune::Lobe| {
        let o = polynomial::eval(
            &model.poly(v, l, c),
            lafortune::eval(lobe, model.lights.dirs[l]),
        );
        (model.space.to_linear(o), o.max(0.0))
    };
    // Largest value of a lobe over the measured lights: ρ · (max_l D·u_l)^n (x^n is monotone).
    let peak = |lobe: &lafortune::Lobe| {
        let b = model.lights.dirs.iter().fold(0f32, |m, u| {
            m.max(lobe[1] * u.x + lobe[2] * u.y + lobe[3] * u.z)
        });
        if b > 0.0 {
            lobe[0] * b.powf(lobe[4])
        } else {
            0.0
        }
    };
    type PerView = (Vec<f32>, [f32; 3], Vec<[f32; 4]>);
    let per_view: Vec<PerView> = (0..nv)
        .into_par_iter()
        .map(|v| {
            let mut out = vec![0f32; nl * 3];
            let mut omax = vec![[0f32; 4]; nl];
            let mut y_max = [0f32; 3];
            match &model.params[v] {
                ViewParams::Clustered { k, table, index } => {
                    let mut counts = vec![0u32; 3 * k];
                    for (t, &i) in index.iter().enumerate() {
                        counts[3 * i as usize + t % 3] += 1;
                    }
                    let lobes: Vec<_> = table.iter().map(|p| p.unpack()).collect();
                    for (j, lobe) in lobes.iter().enumerate() {
                        if counts[j] > 0 {
                            y_max[j % 3] = y_max[j % 3].max(peak(lobe));
                        }
                    }
                    for l in 0..nl {
                        for c in 0..3 {
                            let mut s = 0f64;
                            for j in 0..*k {
                                let n = counts[3 * j + c];
                                if n > 0 {
                                    let (lin, o) = value2(v, l, c, &lobes[3 * j + c]);
                                    s += n as f64 * lin as f64;
                                    omax[l][c] = omax[l][c].max(o);
                                }
                            }
                            out[3 * l + c] = (s / (w * h) as f64) as f32;
                        }
                    }
                }
                ViewParams::Texel(packed) => {
                    let (sx, sy) = (w.div_ceil(TABLE_TEXELS), h.div_ceil(TABLE_TEXELS));
                    let picks: Vec<usize> = (0..h)
                        .step_by(sy)
                        .flat_map(|y| (0..w).step_by(sx).map(move |x| y * w + x))
                        .collect();
                    let lobes: Vec<[lafortune::Lobe; 3]> = picks
                        .iter()
                        .map(|&t| std::array::from_fn(|c| packed[3 * t + c].unpack()))
                        .collect();
                    for (t, p) in packed.iter().enumerate() {
                        y_max[t % 3] = y_max[t % 3].max(peak(&p.unpack()));
                    }
                    for l in 0..nl {
                        for c in 0..3 {
                            let mut s = 0f64;
                            for lb in &lobes {
                                let (lin, o) = value2(v, l, c, &lb[c]);
                                s += lin as f64;
                                omax[l][c] = omax[l][c].max(o);
                            }
                            out[3 * l + c] = (s / lobes.len() as f64) as f32;
                        }
                    }
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
fn srgb_to_linear_f4<I: Isa>(isa: I, y: F4) -> F4 {
    let v = y.max(F4::splat(0.0));
    let lo = v * F4::splat(1.0 / 12.92);
    let base = ((v + F4::splat(0.055)) * F4::splat(1.0 / 1.055)).max(F4::splat(1e-30));
    let hi = (F4::splat(2.4) * base.log2(isa)).exp2(isa);
    v.le_select(F4::splat(0.04045), lo, hi)
}

/// b^n = exp2(n · log2 b) lane-wise for b > 0 (normal) and n ≥ 0; results below 2^−100 are
/// 2^−100 (never a denormal, see `eval_view`).
#[cfg(test)]
#[inline(always)]
fn pow_f4<I: Isa>(isa: I, b: F4, n: F4) -> F4 {
    (n * b.log2(isa)).max(F4::splat(-100.0)).exp2(isa)
}

/// Summary only: the tables can be large.
impl std::fmt::Debug for PlmcMaterial {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let clusters = match &self.params {
            Params::Clustered8 { k, .. } | Params::Clustered16 { k, .. } => *k,
            Params::Texel { .. } => 0,
        };
        f.debug_struct("PlmcMaterial")
            .field("kind", &self.kind.name())
            .field("space", &self.space)
            .field("width", &self.width)
            .field("height", &self.height)
            .field("lights", &self.n_lights)
            .field("clusters", &clusters)
            .finish_non_exhaustive()
    }
}

/// A fitted-model BTF instance: shared model + uv tiling + texel filter.
#[derive(Clone, Debug)]
pub struct PlmcBsdf {
    material: Arc<PlmcMaterial>,
    /// Texture-space repetitions per unit of uv.
    uv_scale: f32,
    /// Bilinear texel filtering (4 texels evaluated and blended) instead of nearest.
    bilinear: bool,
    /// [`PlmcBsdf::prefetch`] issues its loads (off only to measure what it saves).
    prefetch: bool,
}

impl PlmcBsdf {
    /// An instance of `material` tiled `uv_scale` times per unit uv (finite, non-zero).
    pub fn new(material: Arc<PlmcMaterial>, uv_scale: f32, bilinear: bool) -> Result<Self> {
        if !uv_scale.is_finite() || uv_scale == 0.0 {
            return Err(Error::Invalid(format!(
                "btf uv_scale must be finite and non-zero, got {uv_scale}"
            )));
        }
        Ok(PlmcBsdf {
            material,
            uv_scale,
            bilinear,
            prefetch: true,
        })
    }

    /// The same instance with [`PlmcBsdf::prefetch`] a no-op (to measure what it saves).
    pub fn without_prefetch(mut self) -> Self {
        self.prefetch = false;
        self
    }

    /// The shared material.
    pub fn material(&self) -> &Arc<PlmcMaterial> {
        &self.material
    }

    /// Texel (column, row) of uv: ⌊frac(u·uv_scale)·W⌋, ⌊frac(v·uv_scale)·H⌋ (DESIGN §2).
    #[inline]
    pub fn texel(&self, uv: Vec2) -> (usize, usize) {
        let m = &self.material;
        let idx = |c: f32, n: usize| {
            let s = c * self.uv_scale;
            let f = s - floor_fast(s);
            ((f * n as f32) as usize).min(n - 1)
        };
        (idx(uv.x, m.width), idx(uv.y, m.height))
    }

    /// The texels (index, weight) that filter uv: 1 (nearest) or 4 (bilinear between texel
    /// centres, wrapping at the tile border).
    #[inline]
    fn texels(&self, uv: Vec2) -> ([(usize, f32); 4], usize) {
        let m = &self.material;
        if !self.bilinear {
            let (x, y) = self.texel(uv);
            return ([(y * m.width + x, 1.0), (0, 0.0), (0, 0.0), (0, 0.0)], 1);
        }
        let axis = |c: f32, n: usize| {
            let s = c * self.uv_scale;
            let p = (s - floor_fast(s)) * n as f32 - 0.5;
            let f = floor_fast(p);
            let i0 = (f as i64).rem_euclid(n as i64) as usize;
            (i0, (i0 + 1) % n, (p - f).clamp(0.0, 1.0))
        };
        let (x0, x1, fx) = axis(uv.x, m.width);
        let (y0, y1, fy) = axis(uv.y, m.height);
        let w = m.width;
        (
            [
                (y0 * w + x0, (1.0 - fx) * (1.0 - fy)),
                (y0 * w + x1, fx * (1.0 - fy)),
                (y1 * w + x0, (1.0 - fx) * fy),
                (y1 * w + x1, fx * fy),
            ],
            4,
        )
    }

    /// Starts loading the index entries of the texels that filter `si.uv` (see
    /// [`PlmcMaterial::prefetch_texel`]); only a cache hint.
    #[inline]
    pub fn prefetch(&self, si: &SurfaceInteraction) {
        if !self.prefetch {
            return;
        }
        let (t, n) = self.texels(si.uv);
        for &(texel, _) in &t[..n] {
            self.material.prefetch_texel(texel);
        }
    }

    /// Lobes: measured reflection, glossy in general, varying over the surface.
    pub fn flags(&self) -> BsdfFlags {
        BsdfFlags::GLOSSY_REFLECTION | BsdfFlags::SPATIALLY_VARYING
    }

    /// The per-hit state of a shading point (see [`PlmcHit`]); None below the horizon (where
    /// every call returns zero) — the caller then uses the stateless methods. Also starts the
    /// loads of the texels' index entries ([`PlmcBsdf::prefetch`]) before the view lookup, so
    /// the lookup overlaps with them.
    #[inline]
    pub fn prepare(&self, si: &SurfaceInteraction) -> Option<PlmcHit> {
        if si.wi.z <= 0.0 {
            return None;
        }
        Some(self.hit_at(si, self.prefetch))
    }

    /// The view lookup and texel addressing of `si` (wi above the horizon), with the texels'
    /// index entries prefetched first when `prefetch` is set.
    #[inline]
    fn hit_at(&self, si: &SurfaceInteraction, prefetch: bool) -> PlmcHit {
        let (texels, n) = self.texels(si.uv);
        if prefetch {
            for &(texel, _) in &texels[..n] {
                self.material.prefetch_texel(texel);
            }
        }
        let (vi, vw) = self.material.view_lookup(si.wi);
        PlmcHit {
            vi,
            vw,
            texels,
            n: n as u8,
        }
    }

    /// f·cos θ_o and the pdf at `wo` for a prepared hit: one light-triangulation search serves
    /// both (the model and its sampling tables share the light direction set).
    #[inline]
    fn eval_pdf_hit_inner(&self, hit: &PlmcHit, wo: Vec3) -> (Spectrum, f32) {
        let located = self.material.sampler.light_interp().locate([wo.x, wo.y]);
        self.eval_pdf_located(hit, wo, located)
    }

    /// [`PlmcBsdf::eval_pdf_hit_inner`] with `wo` already located in the light triangulation.
    #[inline]
    fn eval_pdf_located(
        &self,
        hit: &PlmcHit,
        wo: Vec3,
        located: (usize, [f32; 3]),
    ) -> (Spectrum, f32) {
        let m = &*self.material;
        let (li, lw) = m.sampler.light_interp().interpolation(located.0, located.1);
        let t = &hit.texels[..hit.n as usize];
        let f = Spectrum::from(m.eval_b_with(hit.vi, hit.vw, li, lw, wo, t)) * INV_PI;
        (f, m.sampler.light_pdf_located(hit.vi, hit.vw, wo, located))
    }

    /// f · cos θ_o = B/π with wi = view (toward the camera), wo = light; 0 below either horizon.
    #[inline]
    pub fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        if si.wi.z <= 0.0 || wo.z <= 0.0 {
            return Spectrum::ZERO;
        }
        let m = &*self.material;
        let (vi, vw) = m.view_lookup(si.wi);
        let (t, n) = self.texels(si.uv);
        Spectrum::from(m.eval_b_with_views(vi, vw, wo, &t[..n])) * INV_PI
    }

    /// [`PlmcBsdf::eval`] at a prepared hit (the same value).
    #[inline]
    pub fn eval_hit(&self, hit: &PlmcHit, wo: Vec3) -> Spectrum {
        if wo.z <= 0.0 {
            return Spectrum::ZERO;
        }
        let t = &hit.texels[..hit.n as usize];
        Spectrum::from(self.material.eval_b_with_views(hit.vi, hit.vw, wo, t)) * INV_PI
    }

    /// Solid-angle pdf of [`PlmcBsdf::sample`].
    #[inline]
    pub fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        if si.wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let (vi, vw) = self.material.view_lookup(si.wi);
        self.material.sampler.light_pdf(vi, vw, wo)
    }

    /// [`PlmcBsdf::pdf`] at a prepared hit (the same value).
    #[inline]
    pub fn pdf_hit(&self, hit: &PlmcHit, wo: Vec3) -> f32 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        self.material.sampler.light_pdf(hit.vi, hit.vw, wo)
    }

    /// `(eval, pdf)` sharing the view lookup and the light search.
    #[inline]
    pub fn eval_pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> (Spectrum, f32) {
        if si.wi.z <= 0.0 || wo.z <= 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        self.eval_pdf_hit_inner(&self.hit_at(si, false), wo)
    }

    /// [`PlmcBsdf::eval_pdf`] at a prepared hit (the same values).
    #[inline]
    pub fn eval_pdf_hit(&self, hit: &PlmcHit, wo: Vec3) -> (Spectrum, f32) {
        if wo.z <= 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        self.eval_pdf_hit_inner(hit, wo)
    }

    /// Samples a light direction from the tabulated mixture; weight = eval / pdf.
    pub fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        if si.wi.z <= 0.0 {
            return None;
        }
        self.sample_hit(&self.hit_at(si, false), sample1, sample2)
    }

    /// [`PlmcBsdf::sample`] at a prepared hit (the same sample and weight).
    #[inline]
    pub fn sample_hit(
        &self,
        hit: &PlmcHit,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        let m = &*self.material;
        let (wo, tri) = m
            .sampler
            .sample_light_located(hit.vi, hit.vw, sample1, sample2);
        if wo.z <= 0.0 {
            return None;
        }
        // Drawn inside a light triangle: that is the triangle the search would find (up to ties
        // on its edges, where both sides interpolate alike), so only its weights are computed.
        let lights = m.sampler.light_interp();
        let located = match tri {
            Some(t) => (t, lights.triangle_weights(t, [wo.x, wo.y])),
            None => lights.locate([wo.x, wo.y]),
        };
        let (f, pdf) = self.eval_pdf_located(hit, wo, located);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        let s = BsdfSample {
            wo,
            pdf,
            eta: 1.0,
            sampled: BsdfFlags::GLOSSY_REFLECTION,
        };
        Some((s, f / pdf))
    }
}

/// What every BSDF call at one shading point shares, computed once per hit by
/// [`PlmcBsdf::prepare`]: the 3 measured views around wi with their weights and the texels
/// that filter uv. Saves a view-triangulation search and the texel addressing per call (a path
/// vertex makes two: emitter sampling's `eval_pdf` and `sample`). Plain data on the stack.
#[derive(Clone, Copy, Debug)]
pub struct PlmcHit {
    vi: [u32; 3],
    vw: [f32; 3],
    texels: [(usize, f32); 4],
    n: u8,
}

/// `x.floor()` without the libm call the x86_64 baseline makes of it (no SSE4.1 `roundss`):
/// truncation, one down for negative non-integers; |x| ≥ 2^23 (already integers), infinities
/// and NaN take `floor` itself. Equal to `x.floor()` for every f32.
#[inline(always)]
fn floor_fast(x: f32) -> f32 {
    if x.abs() < 8_388_608.0 {
        // copysign: floor(−0) = −0.
        let t = (x as i32 as f32).copysign(x);
        if t > x { t - 1.0 } else { t }
    } else {
        x.floor()
    }
}

/// The model names `<bsdf type="btf">` and `--btf-model` accept.
pub const MODEL_NAMES: [&str; 4] = ["raw", "lm", "plm", "plmc"];

/// The file that holds `model` ("raw", "lm", "plm", "plmc") of the material named by
/// `filename` (a raw BTF or a `.plmc` model). Convention: the material `S` has its raw data at
/// `S` (UBO2003 folder), `S.btfc` or `S.btf`, and its models at `S.plmc` (any kind) or
/// `S.<model>.plmc`. A file of the requested kind itself is always used as is.
pub fn resolve_model_file(filename: &Path, model: &str) -> Result<PathBuf> {
    if !MODEL_NAMES.contains(&model) {
        return Err(Error::Invalid(format!(
            "btf model \"{model}\" is not one of raw, lm, plm, plmc"
        )));
    }
    let name = filename.to_string_lossy();
    let is_plmc = name.to_ascii_lowercase().ends_with(".plmc");
    // The material stem: without .plmc / .lm.plmc / .btfc / .btf.
    let stem: String = if is_plmc {
        let s = &name[..name.len() - 5];
        ["lm", "plm", "plmc"]
            .iter()
            .find_map(|m| s.strip_suffix(&format!(".{m}")))
            .unwrap_or(s)
            .to_string()
    } else {
        let lower = name.to_ascii_lowercase();
        [".btfc", ".btf"]
            .iter()
            .find(|e| lower.ends_with(*e))
            .map_or(name.to_string(), |e| {
                name[..name.len() - e.len()].to_string()
            })
    };
    let kind_of = |p: &Path| -> Option<&'static str> {
        use std::io::Read;
        // The HEAD payload starts after magic(4) version(4) tag(4) len(8) with the kind byte.
        let mut head = [0u8; 21];
        std::fs::File::open(p).ok()?.read_exact(&mut head).ok()?;
        (&head[..4] == crate::btf::format::MAGIC && &head[8..12] == b"HEAD")
            .then(|| ModelKind::from_code(head[20]).map(|k| k.name()))
            .flatten()
    };
    let mut tried = Vec::new();
    if model == "raw" {
        if !is_plmc {
            return Ok(filename.to_path_buf());
        }
        for c in [stem.clone(), format!("{stem}.btfc"), format!("{stem}.btf")] {
            let p = PathBuf::from(&c);
            if p.exists() {
                return Ok(p);
            }
            tried.push(c);
        }
    } else {
        // The named model file itself, if it is of that kind, or unreadable (the reader will say
        // precisely what is wrong with it).
        if is_plmc && kind_of(filename).is_none_or(|k| k == model) {
            return Ok(filename.to_path_buf());
        }
        let own = format!("{stem}.{model}.plmc");
        let plain = format!("{stem}.plmc");
        for c in [filename.to_string_lossy().to_string(), own, plain] {
            let p = PathBuf::from(&c);
            if c.to_ascii_lowercase().ends_with(".plmc") && kind_of(&p) == Some(model) {
                return Ok(p);
            }
            if !tried.contains(&c) {
                tried.push(c);
            }
        }
    }
    Err(Error::format(
        filename,
        format!(
            "no {model} data for this material (looked for {}{})",
            tried.join(", "),
            if model == "raw" {
                ""
            } else {
                " holding a model of that kind"
            }
        ),
    ))
}

/// One material per model file while anything uses it (several `<bsdf>` may share a file).
pub fn shared_material(path: &Path) -> Result<Arc<PlmcMaterial>> {
    static CACHE: crate::io::shared::SharedCache<PlmcMaterial> = std::sync::Mutex::new(None);
    crate::io::shared::shared_by_path(&CACHE, path, PlmcMaterial::load)
}

#[cfg(target_arch = "x86_64")]
mod avx512;
mod f4;
#[cfg(test)]
mod tests;
