//! Smooth dielectric interface (Mitsuba `dielectric`): delta reflection and refraction on both
//! sides, lobe chosen with probability F, radiance transport (η² scaling on refraction).

use super::fresnel::fresnel_dielectric_t;
use super::ior::ior;
use super::plugin::BsdfProperties;
use super::{BsdfFlags, BsdfSample, Bxdf, Texture};
use crate::Result;
use crate::geometry::SurfaceInteraction;
use crate::math::simd::real::{Real, V2, V3};
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
    /// Mitsuba's `dielectric`: `int_ior`, `ext_ior`, `specular_reflectance`,
    /// `specular_transmittance`.
    pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Self> {
        let (eta, specular_reflectance, specular_transmittance) = smooth_interface(p)?;
        Ok(Dielectric {
            eta,
            specular_reflectance,
            specular_transmittance,
        })
    }
}

/// The parameters of a smooth interface (`dielectric`, `thindielectric`): eta = int_ior /
/// ext_ior and the reflectance and transmittance scales.
pub(super) fn smooth_interface(p: &mut dyn BsdfProperties) -> Result<(f32, Texture, Texture)> {
    let int_ior = ior(p, "int_ior", "bk7")?;
    let ext_ior = ior(p, "ext_ior", "air")?;
    if int_ior < 0.0 || ext_ior < 0.0 {
        return Err(p.err("the interior and exterior indices of refraction must be positive"));
    }
    let specular_reflectance = p.texture("specular_reflectance", Vec3::ONE)?;
    let specular_transmittance = p.texture("specular_transmittance", Vec3::ONE)?;
    Ok((
        int_ior / ext_ior,
        specular_reflectance,
        specular_transmittance,
    ))
}

impl Dielectric {
    /// [`Self::sample`] for one lane or sixteen: (wo, pdf, weight, eta, reflected).
    #[inline(always)]
    pub fn sample_t<T: Real>(
        &self,
        wi: V3<T>,
        uv: V2<T>,
        sample1: T,
    ) -> (V3<T>, T, V3<T>, T, T::Mask) {
        let fr = fresnel_dielectric_t(wi.z, self.eta);
        let r_i = fr.r;
        let reflected = sample1.le(r_i);
        let wr = V3::new(-wi.x, -wi.y, wi.z);
        let wt = V3::new(-fr.eta_ti * wi.x, -fr.eta_ti * wi.y, fr.cos_theta_t);
        // Radiance is compressed into a smaller solid angle when crossing the interface.
        let w_t = self
            .specular_transmittance
            .eval_t(uv)
            .scale(fr.eta_ti * fr.eta_ti);
        let w_r = self.specular_reflectance.eval_t(uv);
        (
            V3::select(reflected, wr, wt),
            T::select(reflected, r_i, T::splat(1.0) - r_i),
            V3::select(reflected, w_r, w_t),
            T::select(reflected, T::splat(1.0), fr.eta_it),
            reflected,
        )
    }
}

impl Bxdf for Dielectric {
    /// Delta reflection and delta transmission.
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

    /// Reflects with probability F (pdf = F, weight = specular_reflectance), else refracts
    /// (pdf = 1 − F, weight = specular_transmittance · (η_t→i)², `eta` = η_i→t). Works from both
    /// sides of the surface, exactly as Mitsuba in radiance mode.
    fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        _sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        let (wo, pdf, weight, eta, reflected) = self.sample_t(si.wi.into(), si.uv.into(), sample1);
        let sampled = if reflected {
            BsdfFlags::DELTA_REFLECTION
        } else {
            BsdfFlags::DELTA_TRANSMISSION
        };
        let bs = BsdfSample {
            wo: wo.into(),
            pdf,
            eta,
            sampled,
        };
        Some((bs, weight.into()))
    }
}
