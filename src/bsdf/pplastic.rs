//! Polarized plastic (Mitsuba `pplastic`) as Mitsuba 3.9.1's unpolarized (RGB) variants evaluate
//! it: a rough dielectric coating (Beckmann or GGX, Smith masking, unpolarized Fresnel) over a
//! diffuse base seen through two Fresnel transmissions, (1 − F(cos θ_i)) ρ (1 − F(cos θ_o)) / π.
//! Unlike `roughplastic` there is no internal scattering and no table: the intensity part of the
//! plugin's Mueller matrices. One-sided; anisotropic roughness allowed.

// `!(x > 0.0)` deliberately also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::fresnel::fresnel_dielectric;
use super::ior::ior;
use super::microfacet::{Microfacet, MicrofacetType, roughness};
use super::plugin::BsdfProperties;
use super::{BsdfFlags, BsdfSample, Bxdf, Texture};
use crate::Result;
use crate::geometry::SurfaceInteraction;
use crate::math::cie1931::SpectrumUse;
use crate::math::{Spectrum, Vec2, Vec3, warp};

/// Polarized plastic's unpolarized response (Mitsuba `pplastic`).
#[derive(Clone, Debug)]
pub struct PPlastic {
    /// Albedo of the diffuse base (Mitsuba default 0.5).
    pub diffuse_reflectance: Texture,
    /// Multiplier on the coating's reflection; None when the scene gives none (then 1, and
    /// the specular sampling weight's mean is 1).
    pub specular_reflectance: Option<Texture>,
    /// Relative IOR of the coating, read with `eval_1` (int_ior / ext_ior by default).
    pub eta: Texture,
    /// Normal distribution (Mitsuba default Beckmann).
    pub distribution: MicrofacetType,
    /// Roughness along s (`eval_1` at the hit).
    pub alpha_u: Texture,
    /// Roughness along t (`eval_1` at the hit).
    pub alpha_v: Texture,
    /// Sample visible normals (Mitsuba default true).
    pub sample_visible: bool,
    /// Probability of sampling the coating: s_mean / (d_mean + s_mean).
    pub specular_sampling_weight: f32,
}

impl PPlastic {
    /// Mitsuba's `pplastic`: `diffuse_reflectance`, `specular_reflectance`, `eta` or
    /// `int_ior`/`ext_ior` (polypropylene / air), `distribution`, `alpha` or
    /// `alpha_u`/`alpha_v`, `sample_visible`.
    pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Self> {
        let diffuse_reflectance = p.texture("diffuse_reflectance", Vec3::splat(0.5))?;
        let specular_reflectance = if p.has("specular_reflectance") {
            Some(p.texture("specular_reflectance", Vec3::ONE)?)
        } else {
            None
        };
        let eta = if p.has("eta") {
            if p.has("int_ior") || p.has("ext_ior") {
                return Err(
                    p.err("specify either \"eta\" or \"int_ior\" and \"ext_ior\", not both")
                );
            }
            let eta = p.texture_as("eta", Vec3::ZERO, SpectrumUse::Unbounded)?;
            if let Texture::Constant(c) = &eta
                && !(c.min_element() > 0.0 && c.is_finite())
            {
                return Err(p.err_at("eta", &format!("\"eta\" must be positive, got {c}")));
            }
            eta
        } else {
            let int_ior = ior(p, "int_ior", "polypropylene")?;
            let ext_ior = ior(p, "ext_ior", "air")?;
            if !(int_ior > 0.0 && ext_ior > 0.0) || int_ior == ext_ior {
                return Err(p.err(
                    "the interior and exterior indices of refraction must be positive and differ",
                ));
            }
            Texture::uniform(int_ior / ext_ior)
        };
        let distribution = MicrofacetType::from_props(p)?;
        let sample_visible = p.bool("sample_visible", true)?;
        let (alpha_u, alpha_v) = roughness(p)?;
        Ok(PPlastic::new(
            diffuse_reflectance,
            specular_reflectance,
            eta,
            distribution,
            alpha_u,
            alpha_v,
            sample_visible,
        ))
    }

    /// A polarized plastic with its sampling weight computed from the textures' means.
    pub fn new(
        diffuse_reflectance: Texture,
        specular_reflectance: Option<Texture>,
        eta: Texture,
        distribution: MicrofacetType,
        alpha_u: Texture,
        alpha_v: Texture,
        sample_visible: bool,
    ) -> PPlastic {
        let d_mean = diffuse_reflectance.mean();
        let s_mean = specular_reflectance.as_ref().map_or(1.0, Texture::mean);
        PPlastic {
            diffuse_reflectance,
            specular_reflectance,
            eta,
            distribution,
            alpha_u,
            alpha_v,
            sample_visible,
            specular_sampling_weight: s_mean / (d_mean + s_mean),
        }
    }

    fn distr(&self, uv: Vec2) -> Microfacet {
        Microfacet::new(
            self.distribution,
            self.alpha_u.eval_1(uv),
            self.alpha_v.eval_1(uv),
            self.sample_visible,
        )
    }
}

impl Bxdf for PPlastic {
    /// Glossy and diffuse reflection.
    fn flags(&self) -> BsdfFlags {
        let f = BsdfFlags::GLOSSY_REFLECTION | BsdfFlags::DIFFUSE_REFLECTION;
        f.varying_if(
            self.diffuse_reflectance.is_spatially_varying()
                || self
                    .specular_reflectance
                    .as_ref()
                    .is_some_and(Texture::is_spatially_varying)
                || self.eta.is_spatially_varying()
                || self.alpha_u.is_spatially_varying()
                || self.alpha_v.is_spatially_varying(),
        )
    }

    /// s · F(wi·h) D G / (4 cos θ_i) + (1 − F(cos θ_o)) ρ (1 − F(cos θ_i)) cos θ_o / π; 0 unless
    /// both directions are above the surface.
    fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        let wi = si.wi;
        if !(wi.z > 0.0 && wo.z > 0.0) {
            return Spectrum::ZERO;
        }
        let eta = self.eta.eval_1(si.uv);
        let distr = self.distr(si.uv);
        let h = (wo + wi).normalize();
        let d = distr.eval(h);
        let f = fresnel_dielectric(wi.dot(h), eta).r;
        let g = distr.g(wi, wo, h);
        let value = d * g / (4.0 * wi.z);
        let spec = self
            .specular_reflectance
            .as_ref()
            .map_or(Spectrum::ONE, |t| t.eval(si.uv));
        let specular = spec * f * value;
        let r_i = fresnel_dielectric(wi.z, eta).r;
        let r_o = fresnel_dielectric(wo.z, eta).r;
        let diffuse = (1.0 - r_o) * self.diffuse_reflectance.eval(si.uv) * (1.0 - r_i);
        specular + diffuse * std::f32::consts::FRAC_1_PI * wo.z
    }

    /// p_s · (visible-normal or D(h) cos θ_h pdf) / (4 wo·h) + (1 − p_s) cos θ_o / π.
    fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        let wi = si.wi;
        if !(wi.z > 0.0 && wo.z > 0.0) {
            return 0.0;
        }
        let prob_specular = self.specular_sampling_weight;
        let prob_diffuse = 1.0 - prob_specular;
        let h = (wo + wi).normalize();
        let distr = self.distr(si.uv);
        let mut p_specular = if distr.sample_visible {
            distr.eval(h) * distr.smith_g1(wi, h) / (4.0 * wi.z)
        } else {
            distr.pdf(wi, h) / (4.0 * wo.dot(h))
        };
        if wi.dot(h) <= 0.0 || wo.dot(h) <= 0.0 {
            p_specular = 0.0;
        }
        let p_diffuse = warp::square_to_cosine_hemisphere_pdf(wo);
        prob_specular * p_specular + prob_diffuse * p_diffuse
    }

    /// The coating (a reflected microfacet normal) with probability p_s, else a cosine-weighted
    /// direction; weight eval / pdf of the mixture, as Mitsuba.
    fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        let wi = si.wi;
        if !(wi.z > 0.0) {
            return None;
        }
        let (wo, sampled) = if sample1 < self.specular_sampling_weight {
            let (m, _) = self.distr(si.uv).sample(wi, sample2);
            (m * (2.0 * wi.dot(m)) - wi, BsdfFlags::GLOSSY_REFLECTION)
        } else {
            (
                warp::square_to_cosine_hemisphere(sample2),
                BsdfFlags::DIFFUSE_REFLECTION,
            )
        };
        let pdf = self.pdf(si, wo);
        if !(pdf > 0.0) {
            return None;
        }
        let bs = BsdfSample {
            wo,
            pdf,
            eta: 1.0,
            sampled,
        };
        Some((bs, self.eval(si, wo) / pdf))
    }
}
