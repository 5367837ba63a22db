//! Lambertian reflection (Mitsuba `diffuse`): one-sided, black when seen from below.

use super::plugin::BsdfProperties;
use super::{BsdfFlags, BsdfSample, Bxdf, Texture};
use crate::Result;
use crate::geometry::SurfaceInteraction;
use crate::math::simd::f16::{F16, M16, V2x, V3x};
use crate::math::{INV_PI, Spectrum, Vec2, Vec3, warp};

/// Ideal diffuse reflector with a (possibly textured) albedo.
#[derive(Clone, Debug)]
pub struct Diffuse {
    pub reflectance: Texture,
}

impl Diffuse {
    /// Mitsuba's `diffuse`: `reflectance` (colour or texture, 0.5).
    pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Self> {
        Ok(Diffuse {
            reflectance: p.texture("reflectance", Vec3::splat(0.5))?,
        })
    }
}

impl Bxdf for Diffuse {
    fn flags(&self) -> BsdfFlags {
        let f = BsdfFlags::DIFFUSE_REFLECTION;
        f.varying_if(self.reflectance.is_spatially_varying())
    }

    fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        eval_local(self.reflectance.eval_at(si), si.wi, wo)
    }

    fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        pdf_local(si.wi, wo)
    }

    fn sample(
        &self,
        si: &SurfaceInteraction,
        _sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        let (wo, pdf) = sample_local(si.wi, sample2)?;
        let s = BsdfSample {
            wo,
            pdf,
            eta: 1.0,
            sampled: BsdfFlags::DIFFUSE_REFLECTION,
        };
        Some((s, self.reflectance.eval_at(si)))
    }
}

/// f · cos θ_o of albedo `r` for local directions `wi` (toward the viewer) and `wo` (black
/// from below). The arithmetic of [`Diffuse::eval`], which the packet kernel runs per lane.
#[inline(always)]
pub fn eval_local(r: Spectrum, wi: Vec3, wo: Vec3) -> Spectrum {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return Spectrum::ZERO;
    }
    r * (INV_PI * wo.z)
}

/// Solid-angle pdf of [`sample_local`] producing `wo` seen from `wi` (local directions).
#[inline(always)]
pub fn pdf_local(wi: Vec3, wo: Vec3) -> f32 {
    if wi.z <= 0.0 {
        return 0.0;
    }
    warp::square_to_cosine_hemisphere_pdf(wo)
}

/// Cosine-weighted direction and its pdf from the unit square sample `u`; None from below the
/// surface (the weight is the albedo).
#[inline(always)]
pub fn sample_local(wi: Vec3, u: Vec2) -> Option<(Vec3, f32)> {
    if wi.z <= 0.0 {
        return None;
    }
    let wo = warp::square_to_cosine_hemisphere(u);
    let pdf = warp::square_to_cosine_hemisphere_pdf(wo);
    if pdf <= 0.0 {
        return None;
    }
    Some((wo, pdf))
}

/// [`eval_local`] per lane.
#[inline(always)]
pub fn eval_local_x(r: V3x, wi: V3x, wo: V3x) -> V3x {
    let zero = F16::splat(0.0);
    let below = wi.z.le(zero).or(wo.z.le(zero));
    V3x::select(below, V3x::ZERO, r.scale(INV_PI * wo.z))
}

/// [`pdf_local`] per lane.
#[inline(always)]
pub fn pdf_local_x(wi: V3x, wo: V3x) -> F16 {
    let zero = F16::splat(0.0);
    F16::select(
        wi.z.le(zero),
        zero,
        warp::square_to_cosine_hemisphere_pdf_x(wo),
    )
}

/// [`sample_local`] per lane: (wo, pdf, valid), valid false where that returns None.
#[inline(always)]
pub fn sample_local_x(wi: V3x, u: V2x) -> (V3x, F16, M16) {
    let zero = F16::splat(0.0);
    let wo = warp::square_to_cosine_hemisphere_x(u);
    let pdf = warp::square_to_cosine_hemisphere_pdf_x(wo);
    let ok = wi.z.le(zero).not().and(pdf.le(zero).not());
    (wo, pdf, ok)
}
