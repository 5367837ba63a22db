//! The batched BSDF interface: up to [`L`] shading points that share one BSDF kind, evaluated
//! and sampled in structure-of-arrays, as the packet integrator shades them (pbrt-v4's
//! wavefront kernels are generic over the material in the same way). A kind with a batched
//! kernel runs it — SoA twins of the scalar code for `diffuse` (and `twosided` over two
//! diffuse sides), 16 evaluations per pass for a fitted BTF — and every other BSDF falls back
//! to the scalar code lane by lane through [`BsdfAt`], so a lane's result is always the same
//! bits as [`Bsdf::at`] followed by its scalar calls.
//!
//! Methods are `#[inline(always)]`: they are compiled into each instruction-set build of the
//! integrator's kernel that calls them.

use super::diffuse::{eval_local_x, pdf_local_x, sample_local_x};
use super::plmc::{PREPARE_LANES, PlmcBsdf};
use super::{Bsdf, BsdfAt, BsdfFlags, BsdfSample, Texture};
use crate::geometry::SurfaceInteraction;
use crate::math::simd::wide::{Fx, Mx, V2x, V3x};
use crate::math::{Spectrum, Vec2, Vec3};

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
    /// Per lane: the BSDF at its hit, for the lanes that go through the scalar code or the
    /// fitted-BTF kernel.
    at: [Option<BsdfAt<'a>>; L],
    /// Diffuse lanes: albedo, lanes seen from below a `twosided` (directions z-mirrored), and
    /// lanes seen edge-on (wi.z neither > 0 nor < 0: black, no sample).
    albedo: V3x,
    flip: Mx,
    edge_on: Mx,
}

/// BSDF samples of a batch, per lane.
#[derive(Clone, Copy, Debug)]
pub struct BatchSample {
    /// Sampled direction in the local frame.
    pub wo: V3x,
    /// Its solid-angle density.
    pub pdf: Fx,
    /// eval · |cos θ_o| / pdf.
    pub weight: V3x,
    /// Relative index of refraction of the sampled event (1 for reflection).
    pub eta: Fx,
    /// The sample came from a delta lobe.
    pub delta: Mx,
    /// False where sampling failed (the path ends).
    pub ok: Mx,
}

/// The albedo textures of a BSDF the diffuse SoA stages run: (front, back) of a `twosided`
/// over two `diffuse` models, (albedo, None) of a `diffuse` one, None for any other model.
#[inline]
fn diffuse_sides(b: &Bsdf) -> Option<(&Texture, Option<&Texture>)> {
    match b {
        Bsdf::Diffuse(d) => Some((&d.reflectance, None)),
        Bsdf::TwoSided(t) => match (&*t.front, &*t.back) {
            (Bsdf::Diffuse(f), Bsdf::Diffuse(k)) => Some((&f.reflectance, Some(&k.reflectance))),
            _ => None,
        },
        _ => None,
    }
}

/// `v` with z negated in the lanes of `m` (`twosided`'s mirror through the surface).
#[inline(always)]
fn mirror_z(m: Mx, v: V3x) -> V3x {
    V3x::new(v.x, v.y, Fx::select(m, -v.z, v.z))
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
            _ => Kind::Scalar,
        };
        BsdfBatch {
            kind,
            bsdf,
            at: [None; L],
            albedo: V3x::ZERO,
            flip: Mx::splat(false),
            edge_on: Mx::splat(false),
        }
    }

    /// Starts lane `l`, a shading point of a surface whose BSDF is `own` (the batch's, or for a
    /// diffuse batch the lane's own diffuse BSDF), with local incident direction `wi` and
    /// surface coordinates `uv`; `si` builds the lane's full surface interaction where the
    /// scalar code needs it. Returns whether the BSDF has a smooth lobe (emitter sampling).
    #[inline(always)]
    pub fn start_lane(
        &mut self,
        l: usize,
        own: &'a Bsdf,
        wi: Vec3,
        uv: Vec2,
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
                self.albedo.set(l, tex.eval(uv));
                true
            }
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
    /// [`Self::start_lane`]: a fitted BTF's 16 view lookups at once, what [`Bsdf::at`] finds
    /// lane by lane.
    #[inline(always)]
    pub fn prepare(&mut self, live: u16, wi: &V3x, uv: &V2x) {
        if let Kind::Plmc(b) = self.kind {
            let hits = b.prepare16([&wi.x.0, &wi.y.0, &wi.z.0], [&uv.x.0, &uv.y.0], live);
            for l in (0..L).filter(|&l| live & (1 << l) != 0) {
                self.at[l] = Some(match hits[l] {
                    Some(h) => BsdfAt::Plmc(b, h),
                    None => BsdfAt::Stateless(self.bsdf),
                });
            }
        }
    }

    /// (f · |cos θ_o|, pdf) toward the emitter samples' local directions `wo` for the lanes of
    /// `want` (zero elsewhere), as next-event estimation needs them: the pdf is 0 for delta
    /// lights (`delta`). `si` builds a lane's surface interaction for the scalar code.
    #[inline(always)]
    pub fn eval_for_light(
        &self,
        want: Mx,
        wi: V3x,
        wo: V3x,
        delta: Mx,
        si: impl Fn(usize) -> SurfaceInteraction,
    ) -> (V3x, Fx) {
        let zero = Fx::splat(0.0);
        if let Kind::Diffuse = self.kind {
            let (flip, edge_on) = (self.flip, self.edge_on);
            let (wi, wo) = (mirror_z(flip, wi), mirror_z(flip, wo));
            return (
                V3x::select(edge_on, V3x::ZERO, eval_local_x(self.albedo, wi, wo)),
                Fx::select(delta.or(edge_on), zero, pdf_local_x(wi, wo)),
            );
        }
        let (mut f, mut pdf) = match self.kind {
            Kind::Plmc(b) => self.eval_plmc(b, want, wo, delta),
            _ => (V3x::ZERO, zero),
        };
        for l in 0..L {
            // (A fitted BTF's lanes with per-hit state were evaluated in the batch.)
            if let (true, Some(at @ BsdfAt::Stateless(_))) = (want.0[l], &self.at[l]) {
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
        u_lobe: Fx,
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
                eta: Fx::splat(1.0),
                delta: Mx::splat(false),
                ok,
            };
        }
        let mut out = BatchSample {
            wo: V3x::splat(Vec3::Z),
            pdf: Fx::splat(1.0),
            weight: V3x::ZERO,
            eta: Fx::splat(1.0),
            delta: Mx::splat(false),
            ok: Mx::splat(false),
        };
        let mut batched = [None; L];
        if let Kind::Plmc(b) = self.kind {
            batched = self.sample_plmc(b, u_lobe, u_bsdf);
        }
        for l in 0..L {
            let Some(at) = &self.at[l] else { continue };
            let s = match at {
                // (Sampled in the batch.)
                BsdfAt::Plmc(..) => batched[l],
                _ => at.sample(&si(l), u_lobe.0[l], u_bsdf.get(l)),
            };
            if let Some((bs, wl)) = s {
                out.wo.set(l, bs.wo);
                out.pdf.0[l] = bs.pdf;
                out.weight.set(l, wl);
                out.eta.0[l] = bs.eta;
                out.delta.0[l] = bs.sampled.has(BsdfFlags::DELTA);
                out.ok.0[l] = true;
            }
        }
        out
    }

    /// The emitter evaluations of a fitted-BTF batch: (f, pdf) per lane for the lanes in `want`
    /// whose BSDF kept its per-hit state (the rest through the scalar code), 16 per pass of the
    /// batched kernel; the pdf is 0 for delta lights.
    #[inline(always)]
    fn eval_plmc(&self, b: &PlmcBsdf, want: Mx, wo: V3x, delta: Mx) -> (V3x, Fx) {
        let (mut f, mut pdf) = (V3x::ZERO, Fx::splat(0.0));
        let mut hits = [None; L];
        let mut at = [0usize; L];
        let mut wq = [Vec3::ZERO; L];
        let mut want_pdf = [false; L];
        let mut m = 0;
        for l in 0..L {
            if let (true, Some(BsdfAt::Plmc(_, h))) = (want.0[l], &self.at[l]) {
                hits[m] = Some(*h);
                at[m] = l;
                wq[m] = wo.get(l);
                want_pdf[m] = !delta.0[l];
                m += 1;
            }
        }
        if let Some(first) = hits[0] {
            let hits = hits.map(|h| h.unwrap_or(first));
            let mut out = [(Spectrum::ZERO, 0.0); L];
            b.eval_pdf_batch(&hits[..m], &wq[..m], &want_pdf[..m], &mut out[..m]);
            for j in 0..m {
                f.set(at[j], out[j].0);
                pdf.0[at[j]] = out[j].1;
            }
        }
        (f, pdf)
    }

    /// The BSDF samples of a fitted-BTF batch's lanes that kept their per-hit state (`None`
    /// elsewhere and where sampling fails), their model evaluations 16 per pass of the batched
    /// kernel: [`PlmcBsdf::sample_batch`], the same samples as the scalar `sample_hit`.
    #[inline(always)]
    fn sample_plmc(
        &self,
        b: &PlmcBsdf,
        u_lobe: Fx,
        u_bsdf: V2x,
    ) -> [Option<(BsdfSample, Spectrum)>; L] {
        let mut out = [None; L];
        let mut hits = [None; L];
        let mut at = [0usize; L];
        let (mut u1, mut u2) = ([0f32; L], [Vec2::ZERO; L]);
        let mut m = 0;
        for l in 0..L {
            if let Some(BsdfAt::Plmc(_, h)) = &self.at[l] {
                hits[m] = Some(*h);
                at[m] = l;
                (u1[m], u2[m]) = (u_lobe.0[l], u_bsdf.get(l));
                m += 1;
            }
        }
        if let Some(first) = hits[0] {
            let hits = hits.map(|h| h.unwrap_or(first));
            let mut got = [None; L];
            b.sample_batch(&hits[..m], &u1[..m], &u2[..m], &mut got[..m]);
            for j in 0..m {
                out[at[j]] = got[j];
            }
        }
        out
    }
}
