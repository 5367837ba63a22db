//! Smooth dielectric interface (Mitsuba `dielectric`): delta reflection and refraction on both
//! sides, lobe chosen with probability F, radiance transport (η² scaling on refraction).

use super::fresnel::{fresnel_dielectric, reflect, refract};
use super::{BsdfFlags, BsdfSample, Texture};
use crate::geometry::SurfaceInteraction;
use crate::math::{Spectrum, Vec2, Vec3};

/// Smooth dielectric interface (Mitsuba `dielectric`), eta = int_ior / ext_ior.
#[derive(Clone, Debug)]
pub struct Dielectric {
    /// Relative IOR int_ior / ext_ior (the normal points to the exterior).
    pub eta: f32,
    /// Multiplier on reflection (Mitsuba default 1; not physical unless 1).
    pub specular_reflectance: Texture,
    /// Multiplier on transmission (Mitsuba default 1; not physical unless 1).
    pub specular_transmittance: Texture,
}

impl Dielectric {
    /// Delta reflection and delta transmission.
    pub fn flags(&self) -> BsdfFlags {
        let f = BsdfFlags::DELTA_REFLECTION | BsdfFlags::DELTA_TRANSMISSION;
        if self.specular_reflectance.is_spatially_varying()
            || self.specular_transmittance.is_spatially_varying()
        {
            f | BsdfFlags::SPATIALLY_VARYING
        } else {
            f
        }
    }

    /// Always 0 (delta lobes).
    pub fn eval(&self, _si: &SurfaceInteraction, _wo: Vec3) -> Spectrum {
        Spectrum::ZERO
    }

    /// Always 0 (delta lobes).
    pub fn pdf(&self, _si: &SurfaceInteraction, _wo: Vec3) -> f32 {
        0.0
    }

    /// Reflects with probability F (pdf = F, weight = specular_reflectance), else refracts
    /// (pdf = 1 − F, weight = specular_transmittance · (η_t→i)², `eta` = η_i→t). Works from both
    /// sides of the surface, exactly as Mitsuba in radiance mode.
    pub fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        _sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        let fr = fresnel_dielectric(si.wi.z, self.eta);
        let r_i = fr.r;
        if sample1 <= r_i {
            let bs = BsdfSample {
                wo: reflect(si.wi),
                pdf: r_i,
                eta: 1.0,
                sampled: BsdfFlags::DELTA_REFLECTION,
            };
            Some((bs, self.specular_reflectance.eval(si.uv)))
        } else {
            let bs = BsdfSample {
                wo: refract(si.wi, fr.cos_theta_t, fr.eta_ti),
                pdf: 1.0 - r_i,
                eta: fr.eta_it,
                sampled: BsdfFlags::DELTA_TRANSMISSION,
            };
            // Radiance is compressed into a smaller solid angle when crossing the interface.
            let w = self.specular_transmittance.eval(si.uv) * (fr.eta_ti * fr.eta_ti);
            Some((bs, w))
        }
    }
}
