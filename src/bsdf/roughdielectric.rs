//! Rough dielectric interface (Mitsuba `roughdielectric`, Beckmann or GGX): Walter et al. 2007 microfacet
//! reflection and refraction on both sides, lobe chosen with probability F(wi·m), radiance
//! transport (1/η² on refraction), optional texture-driven anisotropic roughness.

use super::fresnel::{fresnel_dielectric, reflect_about, refract_about};
use super::microfacet::{Microfacet, MicrofacetType};
use super::{BsdfFlags, BsdfSample, Texture};
use crate::geometry::SurfaceInteraction;
use crate::math::{Spectrum, Vec2, Vec3};

/// Rough dielectric, eta = int_ior / ext_ior (the normal points to the exterior).
#[derive(Clone, Debug)]
pub struct RoughDielectric {
    /// Normal distribution (Mitsuba default Beckmann).
    pub distribution: MicrofacetType,
    /// Roughness along s (a texture read with Mitsuba's `eval_1`: a bitmap's luminance).
    pub alpha_u: Texture,
    /// Roughness along t.
    pub alpha_v: Texture,
    /// Relative IOR int_ior / ext_ior.
    pub eta: f32,
    /// Multiplier on reflection (Mitsuba default 1).
    pub specular_reflectance: Texture,
    /// Multiplier on transmission (Mitsuba default 1).
    pub specular_transmittance: Texture,
    /// Sample visible normals (Mitsuba default true); otherwise Walter's widened D(m) cos θ_m.
    pub sample_visible: bool,
}

/// −v if `s` < 0 (Mitsuba `mulsign`, with +0 and −0 distinguished as there).
#[inline]
fn mulsign(v: Vec3, s: f32) -> Vec3 {
    if s.is_sign_negative() { -v } else { v }
}

impl RoughDielectric {
    #[inline]
    fn distr(&self, uv: Vec2) -> Microfacet {
        Microfacet::new(
            self.distribution,
            self.alpha_u.eval_1(uv),
            self.alpha_v.eval_1(uv),
            self.sample_visible,
        )
    }

    /// The distribution that sampling uses: non-visible sampling widens it by 1.2 − 0.2 √|cos θ_i|.
    #[inline]
    fn sample_distr(&self, d: Microfacet, cos_theta_i: f32) -> Microfacet {
        if d.sample_visible {
            d
        } else {
            let s = 1.2 - 0.2 * cos_theta_i.abs().sqrt();
            Microfacet {
                kind: d.kind,
                alpha_u: d.alpha_u * s,
                alpha_v: d.alpha_v * s,
                sample_visible: false,
            }
        }
    }

    /// Glossy reflection and transmission.
    pub fn flags(&self) -> BsdfFlags {
        let f = BsdfFlags::GLOSSY_REFLECTION | BsdfFlags::GLOSSY_TRANSMISSION;
        if self.specular_reflectance.is_spatially_varying()
            || self.specular_transmittance.is_spatially_varying()
            || self.alpha_u.is_spatially_varying()
            || self.alpha_v.is_spatially_varying()
        {
            f | BsdfFlags::SPATIALLY_VARYING
        } else {
            f
        }
    }

    /// f · |cos θ_o| for reflection or refraction.
    pub fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        self.eval_pdf(si, wo).0
    }

    /// Density of [`RoughDielectric::sample`].
    pub fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        self.eval_pdf(si, wo).1
    }

    /// `eval` and `pdf` sharing the generalised half vector (Mitsuba `eval_pdf`).
    pub fn eval_pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> (Spectrum, f32) {
        let wi = si.wi;
        let (cos_i, cos_o) = (wi.z, wo.z);
        if cos_i == 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let reflect = cos_i * cos_o > 0.0;
        let (eta, inv_eta) = if cos_i > 0.0 {
            (self.eta, 1.0 / self.eta)
        } else {
            (1.0 / self.eta, self.eta)
        };
        let m = (wi + wo * if reflect { 1.0 } else { eta }).normalize();
        let m = mulsign(m, m.z);
        let (dot_wi_m, dot_wo_m) = (wi.dot(m), wo.dot(m));
        let active = dot_wi_m * cos_i > 0.0 && dot_wo_m * cos_o > 0.0;
        let distr = self.distr(si.uv);
        let d = distr.eval(m);
        let f = fresnel_dielectric(dot_wi_m, self.eta).r;
        let g = distr.g(wi, wo, m);
        let value = if reflect {
            self.specular_reflectance.eval(si.uv) * (f * d * g / (4.0 * cos_i.abs()))
        } else {
            let scale = inv_eta * inv_eta;
            let v = (scale * (1.0 - f) * d * g * eta * eta * dot_wi_m * dot_wo_m)
                / (cos_i * (dot_wi_m + eta * dot_wo_m).powi(2));
            self.specular_transmittance.eval(si.uv) * v.abs()
        };
        let value = if value.is_finite() {
            value
        } else {
            Spectrum::ZERO
        };
        if !active {
            return (value, 0.0);
        }
        let sd = self.sample_distr(distr, cos_i);
        let mut pdf = sd.pdf(mulsign(wi, cos_i), m);
        pdf *= if reflect { f } else { 1.0 - f };
        let dwh_dwo = if reflect {
            1.0 / (4.0 * dot_wo_m)
        } else {
            (eta * eta * dot_wo_m) / (dot_wi_m + eta * dot_wo_m).powi(2)
        };
        (value, pdf * dwh_dwo.abs())
    }

    /// Samples a microfacet normal, then reflects with probability F or refracts.
    pub fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        let wi = si.wi;
        let cos_i = wi.z;
        if cos_i == 0.0 {
            return None;
        }
        let distr = self.distr(si.uv);
        let sd = self.sample_distr(distr, cos_i);
        let (m, pdf_m) = sd.sample(mulsign(wi, cos_i), sample2);
        if pdf_m == 0.0 {
            return None;
        }
        let fr = fresnel_dielectric(wi.dot(m), self.eta);
        let selected_r = sample1 <= fr.r;
        let (wo, pdf_lobe, eta, sampled, mut weight, dwh_dwo) = if selected_r {
            let wo = reflect_about(wi, m);
            (
                wo,
                fr.r,
                1.0,
                BsdfFlags::GLOSSY_REFLECTION,
                self.specular_reflectance.eval(si.uv),
                1.0 / (4.0 * wo.dot(m)),
            )
        } else {
            let wo = refract_about(wi, m, fr.cos_theta_t, fr.eta_ti);
            let e = fr.eta_it;
            (
                wo,
                1.0 - fr.r,
                e,
                BsdfFlags::GLOSSY_TRANSMISSION,
                self.specular_transmittance.eval(si.uv) * (fr.eta_ti * fr.eta_ti),
                (e * e * wo.dot(m)) / (wi.dot(m) + e * wo.dot(m)).powi(2),
            )
        };
        weight *= if distr.sample_visible {
            distr.smith_g1(wo, m)
        } else {
            distr.g(wi, wo, m) * wi.dot(m) / (cos_i * m.z)
        };
        let pdf = pdf_m * pdf_lobe * dwh_dwo.abs();
        if !(pdf > 0.0 && pdf.is_finite() && weight.is_finite()) {
            return None;
        }
        let bs = BsdfSample {
            wo,
            pdf,
            eta,
            sampled,
        };
        Some((bs, weight))
    }
}
