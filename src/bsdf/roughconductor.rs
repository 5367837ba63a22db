//! Rough conductor (Mitsuba `roughconductor`): Cook–Torrance with a Beckmann or GGX normal
//! distribution, Smith masking and complex-IOR Fresnel. One-sided.

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
    /// Roughness along the tangent s (clamped to 1e-4 like Mitsuba).
    pub alpha_u: f32,
    /// Roughness along the bitangent t.
    pub alpha_v: f32,
    /// Real part of the relative IOR per channel.
    pub eta: Spectrum,
    /// Extinction coefficient per channel.
    pub k: Spectrum,
    /// Multiplier on the reflectance (Mitsuba default 1).
    pub specular_reflectance: Texture,
    /// Sample visible normals (Mitsuba default true).
    pub sample_visible: bool,
}

impl RoughConductor {
    #[inline]
    fn distr(&self) -> Microfacet {
        Microfacet::new(
            self.distribution,
            self.alpha_u,
            self.alpha_v,
            self.sample_visible,
        )
    }

    /// Glossy reflection.
    pub fn flags(&self) -> BsdfFlags {
        let f = BsdfFlags::GLOSSY_REFLECTION;
        if self.specular_reflectance.is_spatially_varying() {
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
        let d = self.distr();
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
        let d = self.distr();
        let dm = d.eval(h);
        if dm == 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let g1_wi = d.smith_g1(wi, h);
        let g = g1_wi * d.smith_g1(wo, h);
        let f = fresnel_conductor_rgb(wi.dot(h), self.eta, self.k);
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
        let d = self.distr();
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
        let f = fresnel_conductor_rgb(wi.dot(m), self.eta, self.k);
        let bs = BsdfSample {
            wo,
            pdf,
            eta: 1.0,
            sampled: BsdfFlags::GLOSSY_REFLECTION,
        };
        Some((bs, self.specular_reflectance.eval(si.uv) * f * weight))
    }
}
