//! Rough conductor (Mitsuba `roughconductor`): Cook–Torrance with a Beckmann or GGX normal
//! distribution, Smith masking and complex-IOR Fresnel. One-sided. Roughness and IOR are
//! textures evaluated at the hit, as in Mitsuba 3.9.1 (`alpha_u->eval_1(si)`, `eta->eval(si)`).

use super::fresnel::{fresnel_conductor_rgb, reflect_about};
use super::microfacet::{Microfacet, MicrofacetType};
use super::{BsdfFlags, BsdfSample, Texture};
use crate::geometry::SurfaceInteraction;
use crate::math::{Spectrum, Vec2, Vec3};

/// Rough conductor (Mitsuba `roughconductor`): alpha_u along s, alpha_v along t.
#[derive(Clone, Debug)]
pub struct RoughConductor {
    /// Normal distribution (Mitsuba default Beckmann).
    pub distribution: MicrofacetType,
    /// Roughness along the tangent s: a texture read with Mitsuba's `eval_1` at the hit,
    /// clamped to 1e-4 like Mitsuba.
    pub alpha_u: Texture,
    /// Roughness along the bitangent t (`eval_1` at the hit).
    pub alpha_v: Texture,
    /// Real part of the relative IOR per channel (a texture, unbounded, as Mitsuba's `eta`).
    pub eta: Texture,
    /// Extinction coefficient per channel (a texture, as Mitsuba's `k`).
    pub k: Texture,
    /// Multiplier on the reflectance (Mitsuba default 1).
    pub specular_reflectance: Texture,
    /// Sample visible normals (Mitsuba default true).
    pub sample_visible: bool,
}

impl RoughConductor {
    /// The distribution at `uv` (roughness textures evaluated there).
    #[inline]
    fn distr(&self, uv: Vec2) -> Microfacet {
        Microfacet::new(
            self.distribution,
            self.alpha_u.eval_1(uv),
            self.alpha_v.eval_1(uv),
            self.sample_visible,
        )
    }

    /// Fresnel reflectance at `cos_theta_i` with the IOR textures evaluated at `uv`.
    #[inline]
    fn fresnel(&self, cos_theta_i: f32, uv: Vec2) -> Spectrum {
        fresnel_conductor_rgb(cos_theta_i, self.eta.eval(uv), self.k.eval(uv))
    }

    /// Glossy reflection.
    pub fn flags(&self) -> BsdfFlags {
        let f = BsdfFlags::GLOSSY_REFLECTION;
        if self.specular_reflectance.is_spatially_varying()
            || self.alpha_u.is_spatially_varying()
            || self.alpha_v.is_spatially_varying()
            || self.eta.is_spatially_varying()
            || self.k.is_spatially_varying()
        {
            f | BsdfFlags::SPATIALLY_VARYING
        } else {
            f
        }
    }

    /// D G F / (4 cos θ_i) (= f · cos θ_o); 0 unless both directions are above the surface.
    pub fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        self.eval_pdf(si, wo).0
    }

    /// Density of [`RoughConductor::sample`] (reflection Jacobian 1/(4 wo·m) included).
    pub fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        let wi = si.wi;
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let m = (wo + wi).normalize();
        if wi.dot(m) <= 0.0 || wo.dot(m) <= 0.0 {
            return 0.0;
        }
        let d = self.distr(si.uv);
        if d.sample_visible {
            d.eval(m) * d.smith_g1(wi, m) / (4.0 * wi.z)
        } else {
            d.pdf(wi, m) / (4.0 * wo.dot(m))
        }
    }

    /// `eval` and `pdf` together, sharing the half vector and D (Mitsuba `eval_pdf`).
    pub fn eval_pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> (Spectrum, f32) {
        let wi = si.wi;
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let h = (wo + wi).normalize();
        let d = self.distr(si.uv);
        let dm = d.eval(h);
        if dm == 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let g1_wi = d.smith_g1(wi, h);
        let g = g1_wi * d.smith_g1(wo, h);
        let f = self.fresnel(wi.dot(h), si.uv);
        let value = self.specular_reflectance.eval(si.uv) * f * (dm * g / (4.0 * wi.z));
        let pdf = if wi.dot(h) <= 0.0 || wo.dot(h) <= 0.0 {
            0.0
        } else if d.sample_visible {
            dm * g1_wi / (4.0 * wi.z)
        } else {
            d.pdf(wi, h) / (4.0 * wo.dot(h))
        };
        (value, pdf)
    }

    /// Samples a microfacet normal and reflects `wi` about it. Weight: G1(wo) F (visible
    /// sampling) or G F (wi·m) / (cos θ_i cos θ_m); None if the reflection goes below.
    pub fn sample(
        &self,
        si: &SurfaceInteraction,
        _sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        let wi = si.wi;
        if wi.z <= 0.0 {
            return None;
        }
        let d = self.distr(si.uv);
        let (m, pdf_m) = d.sample(wi, sample2);
        let wo = reflect_about(wi, m);
        if !(pdf_m != 0.0 && wo.z > 0.0) {
            return None;
        }
        let weight = if d.sample_visible {
            d.smith_g1(wo, m)
        } else {
            d.g(wi, wo, m) * wi.dot(m) / (wi.z * m.z)
        };
        let pdf = pdf_m / (4.0 * wo.dot(m));
        if !(pdf.is_finite() && pdf > 0.0) {
            return None;
        }
        let f = self.fresnel(wi.dot(m), si.uv);
        let bs = BsdfSample {
            wo,
            pdf,
            eta: 1.0,
            sampled: BsdfFlags::GLOSSY_REFLECTION,
        };
        Some((bs, self.specular_reflectance.eval(si.uv) * f * weight))
    }
}
