//! Thin dielectric sheet (Mitsuba `thindielectric`): a slab whose inter-reflections are summed in
//! closed form; transmission passes straight through (no refraction, no η² scaling).

use super::dielectric::smooth_interface;
use super::fresnel::{fresnel_dielectric, reflect};
use super::plugin::BsdfProperties;
use super::{BsdfFlags, BsdfSample, Bxdf, Texture};
use crate::Result;
use crate::geometry::SurfaceInteraction;
use crate::math::{Spectrum, Vec2, Vec3};

/// Thin dielectric sheet (Mitsuba `thindielectric`), eta = int_ior / ext_ior.
#[derive(Clone, Debug)]
pub struct ThinDielectric {
    /// Relative IOR of the sheet material to its surroundings.
    pub eta: f32,
    /// Multiplier on reflection (Mitsuba default 1).
    pub specular_reflectance: Texture,
    /// Multiplier on transmission (Mitsuba default 1).
    pub specular_transmittance: Texture,
}

impl ThinDielectric {
    /// Mitsuba's `thindielectric`: the parameters of `dielectric`.
    pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Self> {
        let (eta, specular_reflectance, specular_transmittance) = smooth_interface(p)?;
        Ok(ThinDielectric {
            eta,
            specular_reflectance,
            specular_transmittance,
        })
    }
}

impl ThinDielectric {
    /// Total reflectance of the slab, R' = R + T R T + … = 2R / (1 + R), at the incident angle.
    #[inline]
    pub fn slab_reflectance(&self, cos_theta_i: f32) -> f32 {
        let r = fresnel_dielectric(cos_theta_i.abs(), self.eta).r;
        r * 2.0 / (1.0 + r)
    }
}

impl Bxdf for ThinDielectric {
    /// Delta reflection and delta (straight-through) transmission. Mitsuba tags the latter
    /// `Null`; for a path tracer that is a delta transmission with eta 1.
    fn flags(&self) -> BsdfFlags {
        let f = BsdfFlags::DELTA_REFLECTION | BsdfFlags::DELTA_TRANSMISSION;
        f.varying_if(
            self.specular_reflectance.is_spatially_varying()
                || self.specular_transmittance.is_spatially_varying(),
        )
    }

    /// Always 0 (delta lobes).
    fn eval(&self, _si: &SurfaceInteraction, _wo: Vec3) -> Spectrum {
        Spectrum::ZERO
    }

    /// Always 0 (delta lobes).
    fn pdf(&self, _si: &SurfaceInteraction, _wo: Vec3) -> f32 {
        0.0
    }

    /// Reflects with probability R' (weight specular_reflectance) or continues along −wi with
    /// probability 1 − R' (weight specular_transmittance), from either side.
    fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        _sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        let r = self.slab_reflectance(si.wi.z);
        if sample1 <= r {
            let bs = BsdfSample {
                wo: reflect(si.wi),
                pdf: r,
                eta: 1.0,
                sampled: BsdfFlags::DELTA_REFLECTION,
            };
            Some((bs, self.specular_reflectance.eval(si.uv)))
        } else {
            let bs = BsdfSample {
                wo: -si.wi,
                pdf: 1.0 - r,
                eta: 1.0,
                sampled: BsdfFlags::DELTA_TRANSMISSION,
            };
            Some((bs, self.specular_transmittance.eval(si.uv)))
        }
    }
}
