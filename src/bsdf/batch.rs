//! The batched BSDF interface: up to [`L`] shading points that share one BSDF kind, evaluated
//! and sampled in structure-of-arrays, as the packet integrator shades them (pbrt-v4's
//! wavefront kernels are generic over the material in the same way). A kind with a batched
//! kernel runs it — the scalar code's SoA twins (mostly the same helpers, generic over
//! [`crate::math::simd::real::Real`]) for `diffuse` (and `twosided` over two diffuse sides),
//! `plastic`, `roughplastic`, `conductor`, `roughconductor`, `dielectric` and
//! `roughdielectric`, with their textures looked up 16 lanes per call; 16 evaluations per pass
//! for a fitted BTF — and every other BSDF falls back to the scalar code lane by lane through
//! [`BsdfAt`], so a lane's result is always the same bits as [`Bsdf::at`] followed by its
//! scalar calls.
//!
//! Methods are `#[inline(always)]`: they are compiled into each instruction-set build of the
//! integrator's kernel that calls them.

use super::diffuse::{eval_local_x, pdf_local_x, sample_local_x};
use super::plmc::{PREPARE_LANES, PlmcBsdf, PlmcHit};
use super::roughconductor::RoughConductorAt;
use super::roughdielectric::RoughDielectricAt;
use super::{
    Bsdf, BsdfAt, BsdfFlags, BsdfSample, Conductor, Dielectric, Plastic, RoughConductor,
    RoughDielectric, RoughPlastic, Texture,
};
use crate::geometry::SurfaceInteraction;
use crate::math::simd::f16::{F16, M16, V2x, V3x};
use crate::math::{Spectrum, Vec2, Vec3};
use std::mem::MaybeUninit;

/// Lanes of a batch.
pub const L: usize = 16;
// One batched view lookup of a fitted BTF serves a batch.
const _: () = assert!(L == PREPARE_LANES);

/// The batched form a BSDF's stages take.
#[derive(Clone, Copy)]
enum Kind<'a> {
    /// SoA twins of the scalar diffuse code; each lane reads its own BSDF's albedo texture
    /// (see [`BsdfBatch::shares_diffuse_batch`]); a `twosided` diffuse lane seen from below runs
    /// them on z-mirrored directions with its back albedo, as [`crate::bsdf::TwoSided`].
    Diffuse,
    /// Smooth plastic: SoA twins of its scalar code.
    Plastic(&'a Plastic),
    /// Rough plastic: SoA twins of its scalar code.
    RoughPlastic(&'a RoughPlastic),
    /// Smooth conductor (sampling only: a delta lobe).
    Conductor(&'a Conductor),
    /// Rough conductor, with its textures at the lanes' hits.
    RoughConductor(&'a RoughConductor, RoughConductorAt<F16>),
    /// Smooth dielectric (sampling only: delta lobes).
    Dielectric(&'a Dielectric),
    /// Rough dielectric, with its textures at the lanes' hits.
    RoughDielectric(&'a RoughDielectric, RoughDielectricAt<F16>),
    /// A fitted BTF: per-hit states 16 view lookups at once, emitter evaluations and BSDF
    /// samples 16 per pass of its batched kernel.
    Plmc(&'a PlmcBsdf),
    /// Lane by lane through the scalar code.
    Scalar,
}

/// One batch of shading points and their per-hit states.
pub struct BsdfBatch<'a> {
    kind: Kind<'a>,
    bsdf: &'a Bsdf,
    /// Per lane: the BSDF at its hit, for the lanes that go through the scalar code.
    at: [Option<BsdfAt<'a>>; L],
    /// A fitted BTF's lanes with per-hit state: hit j is lane `plmc_lane[j]`'s, j <
    /// `plmc_n`, packed so the batched calls take them as they are (see
    /// [`Self::plmc_hits`]; left uninitialised past `plmc_n`: other kinds' batches would pay a
    /// 1.5 KB memset each).
    plmc_hits: [MaybeUninit<PlmcHit>; L],
    plmc_lane: [u8; L],
    plmc_n: usize,
    /// Diffuse lanes: the albedo texture of each started lane (looked up in [`Self::prepare`]);
    /// None for a constant albedo, set in `albedo` as the lane starts.
    tex: [Option<&'a Texture>; L],
    /// The lanes' surface coordinates (set by [`Self::prepare`]).
    uv: V2x,
    /// Diffuse lanes: albedo, lanes seen from below a `twosided` (directions z-mirrored), and
    /// lanes seen edge-on (wi.z neither > 0 nor < 0: black, no sample).
    albedo: V3x,
    flip: M16,
    edge_on: M16,
    /// Plastic lanes: the specular reflectance (the base's albedo is in `albedo`).
    specular: V3x,
}

/// A diffuse batch's lanes whose albedo texture is one of at most this many evaluate it lane
/// by lane; more share one 16-lane lookup.
const FEW_LANES: u32 = 4;

/// BSDF samples of a batch, per lane.
#[derive(Clone, Copy, Debug)]
pub struct BatchSample {
    /// Sampled direction in the local frame.
    pub wo: V3x,
    /// Its solid-angle density.
    pub pdf: F16,
    /// eval · |cos θ_o| / pdf.
    pub weight: V3x,
    /// Relative index of refraction of the sampled event (1 for reflection).
    pub eta: F16,
    /// The sample came from a delta lobe.
    pub delta: M16,
    /// False where sampling failed (the path ends).
    pub ok: M16,
}

impl BatchSample {
    /// Lane `l` set to the scalar sample `bs` with weight `weight`.
    #[inline(always)]
    fn set(&mut self, l: usize, (bs, weight): (BsdfSample, Spectrum)) {
        self.wo.set(l, bs.wo);
        self.pdf.0[l] = bs.pdf;
        self.weight.set(l, weight);
        self.eta.0[l] = bs.eta;
        self.delta.0[l] = bs.sampled.has(BsdfFlags::DELTA);
        self.ok.0[l] = true;
    }
}

/// The albedo textures of a BSDF the diffuse SoA stages run: (front, back) of a `twosided`
/// over two `diffuse` models, (albedo, None) of a `diffuse` one, None for any other model and
/// for an albedo that is a mesh attribute (looked up per hit, lane by lane).
#[inline]
fn diffuse_sides(b: &Bsdf) -> Option<(&Texture, Option<&Texture>)> {
    let by_uv = |t: &Texture| !matches!(t, Texture::MeshAttribute(_));
    match b {
        Bsdf::Diffuse(d) if by_uv(&d.reflectance) => Some((&d.reflectance, None)),
        Bsdf::TwoSided(t) => match (&*t.front, &*t.back) {
            (Bsdf::Diffuse(f), Bsdf::Diffuse(k))
                if by_uv(&f.reflectance) && by_uv(&k.reflectance) =>
            {
                Some((&f.reflectance, Some(&k.reflectance)))
            }
            _ => None,
        },
        _ => None,
    }
}

/// `v` with z negated in the lanes of `m` (`twosided`'s mirror through the surface).
#[inline(always)]
fn mirror_z(m: M16, v: V3x) -> V3x {
    V3x::new(v.x, v.y, F16::select(m, -v.z, v.z))
}

impl<'a> BsdfBatch<'a> {
    /// True for BSDFs whose lanes may share one batch with any other such BSDF (every
    /// `diffuse`, and every `twosided` of two): the diffuse stages read each lane's own albedo.
    /// Other BSDFs batch only with lanes of the same BSDF.
    pub fn shares_diffuse_batch(b: &Bsdf) -> bool {
        diffuse_sides(b).is_some()
    }

    /// An empty batch of lanes whose BSDF is `bsdf` (or, for a diffuse one, any BSDF that
    /// [`Self::shares_diffuse_batch`]).
    #[inline(always)]
    pub fn new(bsdf: &'a Bsdf) -> BsdfBatch<'a> {
        let kind = match bsdf {
            b if diffuse_sides(b).is_some() => Kind::Diffuse,
            Bsdf::Plmc(b) => Kind::Plmc(b),
            Bsdf::Plastic(p) => Kind::Plastic(p),
            Bsdf::RoughPlastic(p) => Kind::RoughPlastic(p),
            Bsdf::Conductor(c) => Kind::Conductor(c),
            Bsdf::RoughConductor(c) => Kind::RoughConductor(c, c.at(V2x::ZERO.into())),
            Bsdf::Dielectric(d) => Kind::Dielectric(d),
            Bsdf::RoughDielectric(d) => Kind::RoughDielectric(d, d.at(V2x::ZERO.into())),
            _ => Kind::Scalar,
        };
        BsdfBatch {
            kind,
            bsdf,
            at: [None; L],
            plmc_hits: [MaybeUninit::uninit(); L],
            plmc_lane: [0; L],
            plmc_n: 0,
            tex: [None; L],
            uv: V2x::ZERO,
            albedo: V3x::ZERO,
            flip: M16::splat(false),
            edge_on: M16::splat(false),
            specular: V3x::ZERO,
        }
    }

    /// Starts lane `l`, a shading point of a surface whose BSDF is `own` (the batch's, or for a
    /// diffuse batch the lane's own diffuse BSDF), with local incident direction `wi` (the
    /// textures at its surface coordinates `_uv` are looked up in [`Self::prepare`]); `si`
    /// builds the lane's full surface interaction where the scalar code needs it. Returns
    /// whether the BSDF has a smooth lobe (emitter sampling).
    #[inline(always)]
    pub fn start_lane(
        &mut self,
        l: usize,
        own: &'a Bsdf,
        wi: Vec3,
        _uv: Vec2,
        si: impl FnOnce() -> SurfaceInteraction,
    ) -> bool {
        match self.kind {
            Kind::Diffuse => {
                // (The integrator's sort puts only diffuse BSDFs in a diffuse batch.)
                let sides = diffuse_sides(own)
                    .or_else(|| diffuse_sides(self.bsdf).map(|(front, _)| (front, None)));
                let tex = match sides {
                    Some((front, None)) => front,
                    Some((front, Some(back))) => {
                        let z = wi.z;
                        self.flip.0[l] = z < 0.0;
                        self.edge_on.0[l] = !(z > 0.0) && !(z < 0.0);
                        if z < 0.0 { back } else { front }
                    }
                    None => return false,
                };
                // A constant albedo (most scenes' diffuse) is the lane's value at once; only
                // the other textures wait for `prepare`'s 16-lane lookups.
                if let Texture::Constant(c) = tex {
                    self.albedo.set(l, *c);
                } else {
                    self.tex[l] = Some(tex);
                }
                true
            }
            // (Their textures are looked up in `prepare`, for all lanes at once.)
            Kind::Plastic(_)
            | Kind::RoughPlastic(_)
            | Kind::Conductor(_)
            | Kind::RoughConductor(..)
            | Kind::Dielectric(_)
            | Kind::RoughDielectric(..) => self.bsdf.flags().has(BsdfFlags::SMOOTH),
            // (Its per-hit states follow in `prepare`, for all lanes at once.)
            Kind::Plmc(b) => b.flags().has(BsdfFlags::SMOOTH),
            Kind::Scalar => {
                let at = self.bsdf.at(&si());
                self.at[l] = Some(at);
                at.flags().has(BsdfFlags::SMOOTH)
            }
        }
    }

    /// Finishes the per-hit states of the lanes in `live` (bit l = lane l) after
    /// [`Self::start_lane`]: the textures at the lanes' `uv`, 16 lanes per lookup; a fitted
    /// BTF's 16 view lookups at once, what [`Bsdf::at`] finds lane by lane.
    #[inline(always)]
    pub fn prepare(&mut self, live: u16, wi: &V3x, uv: &V2x) {
        self.uv = *uv;
        if !matches!(self.kind, Kind::Plmc(_) | Kind::Scalar) {
            self.look_up_textures(live);
        }
        if let Kind::Plmc(b) = self.kind {
            let w = [&wi.x.0, &wi.y.0, &wi.z.0];
            let n = b.prepare16(
                w,
                [&uv.x.0, &uv.y.0],
                live,
                &mut self.plmc_hits,
                &mut self.plmc_lane,
            );
            self.plmc_n = n;
            let with_hit = self.plmc_lane[..n].iter().fold(0u16, |m, &l| m | 1 << l);
            let mut below = live & !with_hit;
            while below != 0 {
                let l = below.trailing_zeros() as usize;
                below &= below - 1;
                self.at[l] = Some(BsdfAt::Stateless(self.bsdf));
            }
        }
    }

    /// The textures at the lanes' hits, 16 lanes per lookup. (Like the other SoA stages of
    /// the BSDFs below, compiled once rather than into each instruction-set build of the
    /// integrator's kernel: their code is large, and the baseline build still runs 4 lanes per
    /// instruction.)
    #[inline(never)]
    fn look_up_textures(&mut self, live: u16) {
        let (uv, uvt) = (self.uv, self.uv.into());
        match &mut self.kind {
            Kind::Diffuse => self.diffuse_albedo(live),
            Kind::Plastic(p) => {
                self.albedo = p.base_t(uvt).into();
                self.specular = p.specular_reflectance.eval_x(uv);
            }
            Kind::RoughPlastic(p) => {
                let (spec, base) = p.at(uvt);
                (self.specular, self.albedo) = (spec.into(), base.into());
            }
            Kind::RoughConductor(c, at) => *at = c.at(uvt),
            Kind::RoughDielectric(d, at) => *at = d.at(uvt),
            _ => {}
        }
    }

    /// The textured diffuse lanes' albedos: each texture that several lanes of `live` share
    /// looked up for all 16 lanes in one call, the others lane by lane.
    #[inline(always)]
    fn diffuse_albedo(&mut self, live: u16) {
        let mut todo = live;
        while todo != 0 {
            let first = todo.trailing_zeros() as usize;
            let Some(tex) = self.tex[first] else {
                todo &= !(1 << first);
                continue;
            };
            let mut same = M16::splat(false);
            let mut bits = 0u16;
            for l in 0..L {
                if todo & (1 << l) != 0 && self.tex[l].is_some_and(|t| std::ptr::eq(t, tex)) {
                    same.0[l] = true;
                    bits |= 1 << l;
                }
            }
            todo &= !bits;
            // (Constant albedos never get here: `start_lane` set them.)
            if bits.count_ones() <= FEW_LANES {
                for l in (0..L).filter(|&l| bits & (1 << l) != 0) {
                    self.albedo.set(l, tex.eval(self.uv.get(l)));
                }
            } else {
                self.albedo = V3x::select(same, tex.eval_x(self.uv), self.albedo);
            }
        }
    }

    /// (f · |cos θ_o|, pdf) toward the emitter samples' local directions `wo` for the lanes of
    /// `want` (zero elsewhere), as next-event estimation needs them: the pdf is 0 for delta
    /// lights (`delta`). `si` builds a lane's surface interaction for the scalar code.
    #[inline(always)]
    pub fn eval_for_light(
        &self,
        want: M16,
        wi: V3x,
        wo: V3x,
        delta: M16,
        si: impl Fn(usize) -> SurfaceInteraction,
    ) -> (V3x, F16) {
        let zero = F16::splat(0.0);
        if let Kind::Diffuse = self.kind {
            let (flip, edge_on) = (self.flip, self.edge_on);
            let (wi, wo) = (mirror_z(flip, wi), mirror_z(flip, wo));
            return (
                V3x::select(edge_on, V3x::ZERO, eval_local_x(self.albedo, wi, wo)),
                F16::select(delta.or(edge_on), zero, pdf_local_x(wi, wo)),
            );
        }
        let batched = match &self.kind {
            Kind::Plastic(p) => Some(p.eval_pdf_x(self.albedo, wi, wo)),
            Kind::Plmc(_) | Kind::Scalar | Kind::Diffuse => None,
            _ => self.eval_batched(wi, wo),
        };
        if let Some((f, pdf)) = batched {
            return (f, F16::select(delta, zero, pdf));
        }
        let (mut f, mut pdf) = match self.kind {
            Kind::Plmc(b) => self.eval_plmc(b, want, wo, delta),
            _ => (V3x::ZERO, zero),
        };
        for l in 0..L {
            // (A fitted BTF's lanes with per-hit state were evaluated in the batch.)
            if let (true, Some(at)) = (want.0[l], &self.at[l]) {
                let (fl, pl) = at.eval_for_light(&si(l), wo.get(l), delta.0[l]);
                f.set(l, fl);
                pdf.0[l] = pl;
            }
        }
        (f, pdf)
    }

    /// BSDF samples of the started lanes for the local incident directions `wi` and the random
    /// numbers `u_lobe`, `u_bsdf`; `si` builds a lane's surface interaction for the scalar code.
    #[inline(always)]
    pub fn sample(
        &self,
        wi: V3x,
        u_lobe: F16,
        u_bsdf: V2x,
        si: impl Fn(usize) -> SurfaceInteraction,
    ) -> BatchSample {
        if let Kind::Diffuse = self.kind {
            let (flip, edge_on) = (self.flip, self.edge_on);
            let (wo, pdf, ok) = sample_local_x(mirror_z(flip, wi), u_bsdf);
            let (wo, ok) = (mirror_z(flip, wo), ok.and(edge_on.not()));
            // The albedo is the weight; a diffuse sample keeps η (× 1) and is not a delta lobe.
            return BatchSample {
                wo,
                pdf,
                weight: self.albedo,
                eta: F16::splat(1.0),
                delta: M16::splat(false),
                ok,
            };
        }
        match self.kind {
            Kind::Plastic(p) => {
                let (wo, pdf, weight, delta, ok) =
                    p.sample_x(self.albedo, self.specular, wi, u_lobe, u_bsdf);
                return BatchSample {
                    wo,
                    pdf,
                    weight,
                    eta: F16::splat(1.0),
                    delta,
                    ok,
                };
            }
            Kind::Plmc(_) | Kind::Scalar => {}
            _ => {
                if let Some(s) = self.sample_batched(wi, u_lobe, u_bsdf) {
                    return s;
                }
            }
        }
        let mut out = BatchSample {
            wo: V3x::splat(Vec3::Z),
            pdf: F16::splat(1.0),
            weight: V3x::ZERO,
            eta: F16::splat(1.0),
            delta: M16::splat(false),
            ok: M16::splat(false),
        };
        if let Kind::Plmc(b) = self.kind {
            self.sample_plmc(b, u_lobe, u_bsdf, &mut out);
        }
        for l in 0..L {
            let Some(at) = &self.at[l] else { continue };
            if let Some(s) = at.sample(&si(l), u_lobe.0[l], u_bsdf.get(l)) {
                out.set(l, s);
            }
        }
        out
    }

    /// (f, pdf) of the kinds with SoA twins but plastic's (None for the others).
    #[inline(never)]
    fn eval_batched(&self, wi: V3x, wo: V3x) -> Option<(V3x, F16)> {
        let (wit, wot) = (wi.into(), wo.into());
        match &self.kind {
            Kind::RoughPlastic(p) => Some((
                p.eval_t(self.specular.into(), self.albedo.into(), wit, wot)
                    .into(),
                p.pdf_t(wit, wot),
            )),
            Kind::RoughConductor(c, at) => {
                let (f, pdf) = c.eval_pdf_t(at, wit, wot);
                Some((f.into(), pdf))
            }
            Kind::RoughDielectric(d, at) => {
                let (f, pdf) = d.eval_pdf_t(at, wit, wot);
                Some((f.into(), pdf))
            }
            // Delta lobes only: nothing for an emitter sample to see.
            Kind::Conductor(_) | Kind::Dielectric(_) => Some((V3x::ZERO, F16::splat(0.0))),
            _ => None,
        }
    }

    /// BSDF samples of the kinds with SoA twins but plastic's (None for the others).
    #[inline(never)]
    fn sample_batched(&self, wi: V3x, u_lobe: F16, u_bsdf: V2x) -> Option<BatchSample> {
        let (one, no) = (F16::splat(1.0), M16::splat(false));
        let (wit, ut) = (wi.into(), u_bsdf.into());
        let (wo, pdf, weight, eta, delta, ok) = match &self.kind {
            Kind::RoughPlastic(p) => {
                let (spec, base) = (self.specular.into(), self.albedo.into());
                let (wo, pdf, weight, _, ok) = p.sample_t(spec, base, wit, u_lobe, ut);
                (wo.into(), pdf, weight.into(), one, no, ok)
            }
            Kind::Conductor(c) => {
                let ok = wi.z.gt(F16::splat(0.0));
                let wo = V3x::new(-wi.x, -wi.y, wi.z);
                let weight = c.weight_t(wi.z, self.uv.into()).into();
                (wo, one, weight, one, M16::splat(true), ok)
            }
            Kind::RoughConductor(c, at) => {
                let (wo, pdf, weight, ok) = c.sample_t(at, wit, ut);
                (wo.into(), pdf, weight.into(), one, no, ok)
            }
            Kind::Dielectric(d) => {
                let (wo, pdf, weight, eta, _) = d.sample_t(wit, self.uv.into(), u_lobe);
                (
                    wo.into(),
                    pdf,
                    weight.into(),
                    eta,
                    M16::splat(true),
                    M16::splat(true),
                )
            }
            Kind::RoughDielectric(d, at) => {
                let s = d.sample_t(at, wit, u_lobe, ut);
                (s.wo.into(), s.pdf, s.weight.into(), s.eta, no, s.ok)
            }
            _ => return None,
        };
        Some(BatchSample {
            wo,
            pdf,
            weight,
            eta,
            delta,
            ok,
        })
    }

    /// The per-hit states of a fitted-BTF batch, packed (lane `plmc_lane[j]`'s is the j-th).
    #[inline(always)]
    fn plmc_hits(&self) -> &[PlmcHit] {
        assert!(self.plmc_n <= L);
        // SAFETY: `prepare` wrote entries 0..plmc_n before raising plmc_n past them, and
        // MaybeUninit<T> has T's layout.
        unsafe {
            std::slice::from_raw_parts(self.plmc_hits.as_ptr() as *const PlmcHit, self.plmc_n)
        }
    }

    /// The emitter evaluations of a fitted-BTF batch: (f, pdf) per lane for the lanes in `want`
    /// whose BSDF kept its per-hit state (the rest through the scalar code), 16 per pass of the
    /// batched kernel; the pdf is 0 for delta lights.
    #[inline(always)]
    fn eval_plmc(&self, b: &PlmcBsdf, want: M16, wo: V3x, delta: M16) -> (V3x, F16) {
        let (mut f, mut pdf) = (V3x::ZERO, F16::splat(0.0));
        let n = self.plmc_n;
        if n == 0 {
            return (f, pdf);
        }
        // Lanes not in `want` get ω_l = 0, which the batch skips like any ω_l below the
        // horizon (and returns (0, 0) for, as for the lanes it does not evaluate).
        let mut wq = [Vec3::ZERO; L];
        let mut want_pdf = [false; L];
        for j in 0..n {
            let l = self.plmc_lane[j] as usize;
            if want.0[l] {
                wq[j] = wo.get(l);
                want_pdf[j] = !delta.0[l];
            }
        }
        let mut out = [(Spectrum::ZERO, 0.0); L];
        b.eval_pdf_batch(self.plmc_hits(), &wq[..n], &want_pdf[..n], &mut out[..n]);
        for j in 0..n {
            let l = self.plmc_lane[j] as usize;
            f.set(l, out[j].0);
            pdf.0[l] = out[j].1;
        }
        (f, pdf)
    }

    /// The BSDF samples of a fitted-BTF batch's lanes that kept their per-hit state, written
    /// into `out` where sampling succeeds, their model evaluations 16 per pass of the batched
    /// kernel: [`PlmcBsdf::sample_batch`], the same samples as the scalar `sample_hit`.
    #[inline(always)]
    fn sample_plmc(&self, b: &PlmcBsdf, u_lobe: F16, u_bsdf: V2x, out: &mut BatchSample) {
        let n = self.plmc_n;
        if n == 0 {
            return;
        }
        let (mut u1, mut u2) = ([0f32; L], [Vec2::ZERO; L]);
        for j in 0..n {
            let l = self.plmc_lane[j] as usize;
            (u1[j], u2[j]) = (u_lobe.0[l], u_bsdf.get(l));
        }
        let mut got = [None; L];
        b.sample_batch(self.plmc_hits(), &u1[..n], &u2[..n], &mut got[..n]);
        for j in 0..n {
            if let Some(s) = got[j] {
                out.set(self.plmc_lane[j] as usize, s);
            }
        }
    }
}
