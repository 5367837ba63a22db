//! Smooth conductor (Mitsuba `conductor`): a one-sided mirror with complex-IOR Fresnel.

use super::conductor_materials::{CONDUCTOR_MATERIALS, conductor_material};
use super::fresnel::{fresnel_conductor_rgb_t, reflect};
use super::plugin::BsdfProperties;
use super::{BsdfFlags, BsdfSample, Bxdf, Texture};
use crate::Result;
use crate::geometry::SurfaceInteraction;
use crate::math::cie1931::SpectrumUse;
use crate::math::simd::real::{Real, V2, V3};
use crate::math::{Spectrum, Vec2, Vec3};

/// Smooth conductor (Mitsuba `conductor`): Fresnel of complex IOR eta + i·k per RGB channel.
/// Mitsuba's `material="none"` (ideal mirror) is eta = 0, k = 1; other names are Mitsuba's
/// named conductors.
#[derive(Clone, Debug)]
pub struct Conductor {
    /// Real part of the relative IOR per channel (a texture, unbounded, as Mitsuba's `eta`).
    pub eta: Texture,
    /// Extinction coefficient (imaginary part of the IOR) per channel (a texture).
    pub k: Texture,
    /// Multiplier on the reflectance (Mitsuba default 1).
    pub specular_reflectance: Texture,
}

impl Conductor {
    /// Mitsuba's `conductor`: `material` (a named conductor or "none") or `eta`/`k`,
    /// `specular_reflectance`.
    pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Self> {
        let (eta, k) = conductor_ior(p)?;
        Ok(Conductor {
            eta,
            k,
            specular_reflectance: p.texture("specular_reflectance", Vec3::ONE)?,
        })
    }
}

/// Complex IOR of a conductor as Mitsuba 3.9.1 reads it: explicit `eta`/`k` (colours or
/// textures, Mitsuba's unbounded textures; defaults eta 0, k 1: `material="none"`, the ideal
/// mirror) or one of Mitsuba's named conductors (`material="Au"`, ...: the RGB of its spectral
/// data, [`conductor_material`]). Giving `eta` beside a named material is an error, as in
/// Mitsuba; so is `k`, which Mitsuba would leave unreferenced.
pub(super) fn conductor_ior(p: &mut dyn BsdfProperties) -> Result<(Texture, Texture)> {
    const U: SpectrumUse = SpectrumUse::Unbounded;
    let material = p.string("material", "none")?;
    if material == "none" {
        return Ok((
            p.texture_as("eta", Vec3::ZERO, U)?,
            p.texture_as("k", Vec3::ONE, U)?,
        ));
    }
    if p.has("eta") || p.has("k") {
        return Err(p.err("should specify either (eta, k) or material, not both"));
    }
    let m = conductor_material(&material).ok_or_else(|| {
        let names: Vec<&str> = CONDUCTOR_MATERIALS.iter().map(|m| m.name).collect();
        p.err_at(
            "material",
            &format!(
                "unknown conductor material \"{material}\" (valid: none, {})",
                names.join(", ")
            ),
        )
    })?;
    Ok((
        Texture::Constant(Vec3::from(m.eta)),
        Texture::Constant(Vec3::from(m.k)),
    ))
}

impl Conductor {
    /// The weight of [`Self::sample`], F(cos θ_i) · specular_reflectance at `uv`, for one lane
    /// or sixteen.
    #[inline(always)]
    pub fn weight_t<T: Real>(&self, cos_theta_i: T, uv: V2<T>) -> V3<T> {
        let f = fresnel_conductor_rgb_t(cos_theta_i, self.eta.eval_t(uv), self.k.eval_t(uv));
        self.specular_reflectance.eval_t(uv).mul(f)
    }
}

impl Bxdf for Conductor {
    /// Delta reflection only.
    fn flags(&self) -> BsdfFlags {
        let f = BsdfFlags::DELTA_REFLECTION;
        f.varying_if(
            self.specular_reflectance.is_spatially_varying()
                || self.eta.is_spatially_varying()
                || self.k.is_spatially_varying(),
        )
    }

    /// Always 0: a delta lobe has no density that `eval` could see.
    fn eval(&self, _si: &SurfaceInteraction, _wo: Vec3) -> Spectrum {
        Spectrum::ZERO
    }

    /// Always 0 (delta lobe).
    fn pdf(&self, _si: &SurfaceInteraction, _wo: Vec3) -> f32 {
        0.0
    }

    /// The mirror direction with weight F(cos θ_i) · specular_reflectance; None from below.
    fn sample(
        &self,
        si: &SurfaceInteraction,
        _sample1: f32,
        _sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        if si.wi.z <= 0.0 {
            return None;
        }
        let bs = BsdfSample {
            wo: reflect(si.wi),
            pdf: 1.0,
            eta: 1.0,
            sampled: BsdfFlags::DELTA_REFLECTION,
        };
        Some((bs, self.weight_t(si.wi.z, si.uv.into()).into()))
    }
}
