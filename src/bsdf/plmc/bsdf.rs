//! The fitted-model BTF as a BSDF: texel addressing (nearest or bilinear), the per-hit state
//! shared by one vertex's calls, eval/pdf/sample through the material and the light sampler.

use super::lobes::HitLobes;
use super::material::PlmcMaterial;
use super::query::{BATCH, BatchQuery};
use crate::bsdf::btf_sampler::SAMPLE_LANES;
use crate::bsdf::{BsdfFlags, BsdfSample, Bxdf};
use crate::btf::locate16::LOCATE_LANES;
use crate::geometry::SurfaceInteraction;
use crate::math::{INV_PI, Spectrum, Vec2, Vec3};
use crate::{Error, Result};
use std::mem::MaybeUninit;
use std::sync::Arc;

/// The light sampler's table set of every hit: a fitted model builds one (its clusters are per
/// view and channel, not per texel).
const TABLE_SET: u32 = 0;

// One batched light location serves a whole batch.
const _: () = assert!(BATCH <= LOCATE_LANES);
// One batched light-direction draw serves a whole batch.
const _: () = assert!(BATCH <= SAMPLE_LANES);

/// A fitted-model BTF instance: shared model + uv tiling + texel filter.
#[derive(Clone, Debug)]
pub struct PlmcBsdf {
    material: Arc<PlmcMaterial>,
    /// Texture-space repetitions per unit of uv.
    pub(super) uv_scale: f32,
    /// Bilinear texel filtering (4 texels evaluated and blended) instead of nearest.
    pub(super) bilinear: bool,
    /// [`PlmcBsdf::prefetch`] issues its loads (off only to measure what it saves).
    pub(super) prefetch: bool,
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

    /// Texel (column, row) of uv: ⌊frac(u·uv_scale)·W⌋, ⌊frac(v·uv_scale)·H⌋ (docs/conventions.md).
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
    pub(super) fn texels(&self, uv: Vec2) -> ([(usize, f32); 4], usize) {
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
    /// loads of the index entries the evaluations will read (the 3 looked-up views of each
    /// filtering texel, [`PlmcMaterial::prefetch_views`]), so they land while the caller
    /// prepares its other lanes.
    #[inline]
    pub fn prepare(&self, si: &SurfaceInteraction) -> Option<PlmcHit> {
        self.hit_at(si, self.prefetch)
    }

    /// The view lookup and texel addressing of `si` (None below the horizon), then, when
    /// `prefetch` is set, the prefetch of the texels' index entries for those views (the
    /// stateless calls, which use the hit at once, do not prefetch). Prefetching after the
    /// lookup reads 1–3 lines per texel instead of the whole 81-view row (6 lines), which cost
    /// more in miss-buffer and TLB stalls than it hid.
    #[inline]
    fn hit_at(&self, si: &SurfaceInteraction, prefetch: bool) -> Option<PlmcHit> {
        if si.wi.z <= 0.0 {
            return None;
        }
        let (texels, n) = self.texels(si.uv);
        let (vi, vw) = self.material.view_lookup(si.wi);
        if prefetch {
            for &(texel, _) in &texels[..n] {
                self.material.prefetch_views(texel, vi);
            }
        }
        Some(PlmcHit {
            vi,
            vw,
            texels,
            n: n as u8,
            lobes: self
                .material
                .hit_lobes(vi, vw, &texels[..n])
                .unwrap_or_default(),
        })
    }

    /// [`PlmcBsdf::eval_pdf_hit`] with `wo` already located in the light triangulation.
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
        let table = m
            .sampler
            .pdf_located(TABLE_SET, hit.vi, hit.vw, wo, located);
        (f, hit.lobes.mix_pdf(wo, table))
    }

    /// f · cos θ_o = B/π with wi = view (toward the camera), wo = light; 0 below either horizon.
    #[inline]
    pub fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        match self.hit_at(si, false) {
            Some(hit) => self.eval_hit(&hit, wo),
            None => Spectrum::ZERO,
        }
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
        self.hit_at(si, false)
            .map_or(0.0, |hit| self.pdf_hit(&hit, wo))
    }

    /// [`PlmcBsdf::pdf`] at a prepared hit (the same value).
    #[inline]
    pub fn pdf_hit(&self, hit: &PlmcHit, wo: Vec3) -> f32 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        let table = self.material.sampler.pdf(TABLE_SET, hit.vi, hit.vw, wo);
        hit.lobes.mix_pdf(wo, table)
    }

    /// `(eval, pdf)` sharing the view lookup and the light search.
    #[inline]
    pub fn eval_pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> (Spectrum, f32) {
        self.hit_at(si, false)
            .map_or((Spectrum::ZERO, 0.0), |hit| self.eval_pdf_hit(&hit, wo))
    }

    /// [`PlmcBsdf::eval_pdf`] at a prepared hit (the same values).
    #[inline]
    pub fn eval_pdf_hit(&self, hit: &PlmcHit, wo: Vec3) -> (Spectrum, f32) {
        if wo.z <= 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        // One light-triangulation search serves both (the model and its sampling tables share
        // the light direction set).
        let located = self.material.sampler.light_interp().locate([wo.x, wo.y]);
        self.eval_pdf_located(hit, wo, located)
    }

    /// [`PlmcBsdf::eval_pdf_hit`] of up to [`BATCH`] (hit, ω_l) pairs at once, the same values;
    /// where `want_pdf[q]` is false the pdf is not computed and 0 is returned (the emitter
    /// sample of a delta light needs only [`PlmcBsdf::eval_hit`], which is the same value). The
    /// model evaluations of nearest-texel hits run as one pass of the 16-lane kernel
    /// ([`PlmcMaterial::eval_b_batch`]); the rest one by one.
    pub fn eval_pdf_batch(
        &self,
        hits: &[PlmcHit],
        wo: &[Vec3],
        want_pdf: &[bool],
        out: &mut [(Spectrum, f32)],
    ) {
        let n = hits.len();
        let located = self.locate_batch(wo);
        self.eval_pdf_located_batch(hits, wo, &located[..n], want_pdf, out);
    }

    /// [`PlmcBsdf::eval_pdf_batch`] with the model's value B = π · f · cos θ_l (cosine-baked,
    /// linear RGB; docs/conventions.md) in place of f · cos θ_l: the kernel's output itself,
    /// before the division by π (for callers that want the BTF value, e.g. array evaluation).
    pub fn eval_b_pdf_batch(
        &self,
        hits: &[PlmcHit],
        wo: &[Vec3],
        want_pdf: &[bool],
        out: &mut [([f32; 3], f32)],
    ) {
        let n = hits.len();
        let located = self.locate_batch(wo);
        self.b_pdf_located_batch(hits, wo, &located[..n], want_pdf, out);
    }

    /// The light triangles and weights of up to [`BATCH`] directions, located at once (lanes
    /// past `wo.len()` and below the horizon are not searched and not used).
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    fn locate_batch(&self, wo: &[Vec3]) -> [(usize, [f32; 3]); BATCH] {
        assert!(wo.len() <= BATCH);
        let lights = self.material.sampler.light_interp();
        let (mut qx, mut qy) = ([0f32; LOCATE_LANES], [0f32; LOCATE_LANES]);
        let mut lanes = 0u16;
        for (q, w) in wo.iter().enumerate() {
            (qx[q], qy[q]) = (w.x, w.y);
            // (`b_pdf_located_batch`'s test: NaN z is evaluated.)
            lanes |= u16::from(!(w.z <= 0.0)) << q;
        }
        let all = lights.locate16_lanes(&qx, &qy, lanes);
        let mut located = [(0usize, [0f32; 3]); BATCH];
        for (q, l) in located[..wo.len()].iter_mut().enumerate() {
            *l = all.lane(q);
        }
        located
    }

    /// [`PlmcBsdf::eval_pdf_located`] of up to [`BATCH`] (hit, ω_l, light triangle) triples at
    /// once (the pdf only where `want_pdf[q]`; ω_l below the horizon gives (0, 0)).
    fn eval_pdf_located_batch(
        &self,
        hits: &[PlmcHit],
        wo: &[Vec3],
        located: &[(usize, [f32; 3])],
        want_pdf: &[bool],
        out: &mut [(Spectrum, f32)],
    ) {
        let n = hits.len();
        assert!(out.len() == n);
        let mut b = [([0f32; 3], 0f32); BATCH];
        self.b_pdf_located_batch(hits, wo, located, want_pdf, &mut b[..n]);
        for (o, (b, pdf)) in out.iter_mut().zip(&b[..n]) {
            *o = (Spectrum::from(*b) * INV_PI, *pdf);
        }
    }

    /// B and pdf of up to [`BATCH`] (hit, ω_l, light triangle) triples (the pdf only where
    /// `want_pdf[q]`; ω_l below the horizon gives (0, 0)): the model evaluations of
    /// nearest-texel hits as one pass of the 16-lane kernel, the rest one by one.
    fn b_pdf_located_batch(
        &self,
        hits: &[PlmcHit],
        wo: &[Vec3],
        located: &[(usize, [f32; 3])],
        want_pdf: &[bool],
        out: &mut [([f32; 3], f32)],
    ) {
        let n = hits.len();
        assert!(n <= BATCH && wo.len() == n && located.len() == n && want_pdf.len() == n);
        assert!(out.len() == n);
        let m = &*self.material;
        let lights = m.sampler.light_interp();
        // (Left uninitialised: only the first `nq` are written and read; zeroing all 16 cost a
        // 1 KB memset per call.)
        let mut queries = [MaybeUninit::<BatchQuery>::uninit(); BATCH];
        let mut slot = [0usize; BATCH];
        let mut nq = 0;
        let batches = m.batches();
        for q in 0..n {
            let (h, w) = (&hits[q], wo[q]);
            if w.z <= 0.0 {
                out[q] = ([0.0; 3], 0.0);
                continue;
            }
            let located = located[q];
            let (li, lw) = lights.interpolation(located.0, located.1);
            let pdf = if want_pdf[q] {
                h.lobes
                    .mix_pdf(w, m.sampler.pdf_located(TABLE_SET, h.vi, h.vw, w, located))
            } else {
                0.0
            };
            if batches && h.n == 1 && h.texels[0].1 == 1.0 {
                queries[nq] = MaybeUninit::new(BatchQuery {
                    texel: h.texels[0].0 as u32,
                    vi: h.vi,
                    vw: h.vw,
                    li,
                    lw,
                    wo: [w.x, w.y, w.z],
                });
                slot[nq] = q;
                nq += 1;
                out[q] = ([0.0; 3], pdf);
            } else {
                let t = &h.texels[..h.n as usize];
                out[q] = (m.eval_b_with(h.vi, h.vw, li, lw, w, t), pdf);
            }
        }
        if nq > 0 {
            // SAFETY: queries 0..nq were written above (MaybeUninit<T> has T's layout).
            let queries =
                unsafe { std::slice::from_raw_parts(queries.as_ptr() as *const BatchQuery, nq) };
            let mut b = [[0f32; 3]; BATCH];
            m.eval_b_batch(queries, &mut b[..nq]);
            for j in 0..nq {
                out[slot[j]].0 = b[j];
            }
        }
    }

    /// The name of the sampling-mixture component that the lobe number `sample1` of
    /// [`PlmcBsdf::sample`] picks at `si` ("lobes", "uniform" or "table"; "-" below the
    /// horizon), for statistics tools.
    pub fn sampling_component(&self, si: &SurfaceInteraction, sample1: f32) -> &'static str {
        let rest = match self.hit_at(si, false).map(|h| h.lobes.split(sample1)) {
            Some(Ok(_)) => return "lobes",
            Some(Err(u)) => u,
            None => return "-",
        };
        if rest < crate::bsdf::btf_sampler::DEFENSIVE_FRACTION {
            "uniform"
        } else {
            "table"
        }
    }

    /// Samples a light direction from the tabulated mixture; weight = eval / pdf.
    pub fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        self.sample_hit(&self.hit_at(si, false)?, sample1, sample2)
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
        let (wo, tri) = match hit.lobes.split(sample1) {
            Ok(u) => (hit.lobes.sample(u, sample2), None),
            Err(u) => m.sampler.sample(TABLE_SET, hit.vi, hit.vw, u, sample2),
        };
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

    /// [`PlmcBsdf::sample_hit`] of up to [`BATCH`] hits at once, the same samples and weights
    /// (`None` where it returns `None`): the directions drawn one by one from the light sampler,
    /// their model evaluations as one pass of the 16-lane kernel where the hits allow it.
    pub fn sample_batch(
        &self,
        hits: &[PlmcHit],
        sample1: &[f32],
        sample2: &[Vec2],
        out: &mut [Option<(BsdfSample, Spectrum)>],
    ) {
        let n = hits.len();
        assert!(n <= BATCH && sample1.len() == n && sample2.len() == n && out.len() == n);
        let m = &*self.material;
        let lights = m.sampler.light_interp();
        let mut wo = [Vec3::Z; BATCH];
        let mut located = [(0usize, [0f32; 3]); BATCH];
        // Directions drawn outside the triangle table (the defensive part, the grazing band)
        // are searched for all at once, as `eval_pdf_batch` does.
        let (mut qx, mut qy) = ([0f32; LOCATE_LANES], [0f32; LOCATE_LANES]);
        let mut search = 0u16;
        // The lanes that draw from their lobes draw here; the others' tabulated draws run as
        // one batch (packed: table lane j is query `slot[j]`).
        let (mut vi, mut vw) = ([[0u32; 3]; BATCH], [[0f32; 3]; BATCH]);
        let (mut u1, mut u2) = ([0f32; BATCH], [Vec2::ZERO; BATCH]);
        let mut slot = [0usize; BATCH];
        let mut nt = 0;
        let mut drawn = [(Vec3::Z, None); BATCH];
        for q in 0..n {
            match hits[q].lobes.split(sample1[q]) {
                Ok(u) => drawn[q] = (hits[q].lobes.sample(u, sample2[q]), None),
                Err(u) => {
                    (vi[nt], vw[nt]) = (hits[q].vi, hits[q].vw);
                    (u1[nt], u2[nt], slot[nt]) = (u, sample2[q], q);
                    nt += 1;
                }
            }
        }
        let mut table = [(Vec3::Z, None); BATCH];
        let sets = [TABLE_SET; BATCH];
        m.sampler.sample_batch(
            &sets[..nt],
            &vi[..nt],
            &vw[..nt],
            &u1[..nt],
            &u2[..nt],
            &mut table[..nt],
        );
        for j in 0..nt {
            drawn[slot[j]] = table[j];
        }
        for q in 0..n {
            let (w, tri) = drawn[q];
            // (Below the horizon: the evaluation returns (0, 0) and the sample fails.)
            wo[q] = w;
            if w.z > 0.0 {
                // As in `sample_hit`: the triangle it was drawn in, else the search.
                match tri {
                    Some(t) => located[q] = (t, lights.triangle_weights(t, [w.x, w.y])),
                    None => {
                        (qx[q], qy[q]) = (w.x, w.y);
                        search |= 1 << q;
                    }
                }
            }
        }
        if search != 0 {
            let all = lights.locate16_lanes(&qx, &qy, search);
            while search != 0 {
                let q = search.trailing_zeros() as usize;
                search &= search - 1;
                located[q] = all.lane(q);
            }
        }
        let mut fp = [(Spectrum::ZERO, 0.0); BATCH];
        let want = [true; BATCH];
        self.eval_pdf_located_batch(hits, &wo[..n], &located[..n], &want[..n], &mut fp[..n]);
        for q in 0..n {
            let (f, pdf) = fp[q];
            out[q] = if wo[q].z <= 0.0 || pdf.is_nan() || pdf <= 0.0 {
                None
            } else {
                let s = BsdfSample {
                    wo: wo[q],
                    pdf,
                    eta: 1.0,
                    sampled: BsdfFlags::GLOSSY_REFLECTION,
                };
                Some((s, f / pdf))
            };
        }
    }
}

/// What every BSDF call at one shading point shares, computed once per hit by
/// [`PlmcBsdf::prepare`]: the 3 measured views around wi with their weights and the texels
/// that filter uv. Saves a view-triangulation search and the texel addressing per call (a path
/// vertex makes two: emitter sampling's `eval_pdf` and `sample`). Plain data on the stack.
#[derive(Clone, Copy, Debug)]
pub struct PlmcHit {
    pub(super) vi: [u32; 3],
    pub(super) vw: [f32; 3],
    pub(super) texels: [(usize, f32); 4],
    pub(super) n: u8,
    /// The texel's own lobes as a sampling mixture (see `lobes.rs`).
    pub(super) lobes: HitLobes,
}

/// `x.floor()` without the libm call the x86_64 baseline makes of it (no SSE4.1 `roundss`):
/// truncation, one down for negative non-integers; |x| ≥ 2^23 (already integers), infinities
/// and NaN take `floor` itself. Equal to `x.floor()` for every f32.
#[inline(always)]
pub(super) fn floor_fast(x: f32) -> f32 {
    if x.abs() < 8_388_608.0 {
        // copysign: floor(−0) = −0.
        let t = (x as i32 as f32).copysign(x);
        if t > x { t - 1.0 } else { t }
    } else {
        x.floor()
    }
}

/// The `Bsdf` enum's calls, answered by the methods above (which the batched kernel and the
/// Python module also call directly).
impl Bxdf for PlmcBsdf {
    fn flags(&self) -> BsdfFlags {
        PlmcBsdf::flags(self)
    }

    fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        PlmcBsdf::eval(self, si, wo)
    }

    fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        PlmcBsdf::pdf(self, si, wo)
    }

    fn eval_pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> (Spectrum, f32) {
        PlmcBsdf::eval_pdf(self, si, wo)
    }

    fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        PlmcBsdf::sample(self, si, sample1, sample2)
    }

    #[inline]
    fn prefetch(&self, si: &SurfaceInteraction) {
        PlmcBsdf::prefetch(self, si)
    }
}
