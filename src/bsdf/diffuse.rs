//! Lambertian reflection (Mitsuba `diffuse`): one-sided, black when seen from below.

use super::{BsdfFlags, BsdfSample, Texture};
use crate::geometry::SurfaceInteraction;
use crate::math::{INV_PI, Spectrum, Vec2, Vec3, warp};

/// Ideal diffuse reflector with a (possibly textured) albedo.
#[derive(Clone, Debug)]
pub struct Diffuse {
    pub reflectance: Texture,
}

impl Diffuse {
    pub fn flags(&self) -> BsdfFlags {
        let f = BsdfFlags::DIFFUSE_REFLECTION;
        if self.reflectance.is_spatially_varying() {
            f | BsdfFlags::SPATIALLY_VARYING
        } else {
            f
        }
    }

    pub fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        if si.wi.z <= 0.0 || wo.z <= 0.0 {
            return Spectrum::ZERO;
        }
        self.reflectance.eval(si.uv) * (INV_PI * wo.z)
    }

    pub fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        if si.wi.z <= 0.0 {
            return 0.0;
        }
        warp::square_to_cosine_hemisphere_pdf(wo)
    }

    pub fn sample(
        &self,
        si: &SurfaceInteraction,
        _sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        if si.wi.z <= 0.0 {
            return None;
        }
        let wo = warp::square_to_cosine_hemisphere(sample2);
        let pdf = warp::square_to_cosine_hemisphere_pdf(wo);
        if pdf <= 0.0 {
            return None;
        }
        let s = BsdfSample {
            wo,
            pdf,
            eta: 1.0,
            sampled: BsdfFlags::DIFFUSE_REFLECTION,
        };
        Some((s, self.reflectance.eval(si.uv)))
    }
}
