//! Smooth plastic (Mitsuba `plastic`): a diffuse base under a smooth dielectric coating. Delta
//! specular reflection with Fresnel weight F(θ_i), plus the base seen through the interface,
//! (1 − F_i)(1 − F_o)/η² · ρ / (1 − F_dr) / π, where F_dr is the coating's internal diffuse
//! reflectance (`nonlinear` divides by 1 − ρ·F_dr instead). One-sided, as Mitsuba.

use super::fresnel::{fresnel_dielectric, fresnel_diffuse_reflectance, reflect};
use super::{BsdfFlags, BsdfSample, Texture};
use crate::geometry::SurfaceInteraction;
use crate::math::{Spectrum, Vec2, Vec3, warp};

/// Smooth plastic, eta = int_ior / ext_ior (Mitsuba defaults 1.49 / 1.000277).
#[derive(Clone, Debug)]
pub struct Plastic {
    /// Albedo of the diffuse base (Mitsuba default 0.5).
    pub diffuse_reflectance: Texture,
    /// Multiplier on the specular reflection (Mitsuba default 1).
    pub specular_reflectance: Texture,
    /// Account for colour shifts from internal scattering (Mitsuba `nonlinear`, default false).
    pub nonlinear: bool,
    eta: f32,
    inv_eta_2: f32,
    fdr_int: f32,
    /// Share of samples steered to the specular lobe before the Fresnel term.
    specular_sampling_weight: f32,
}

impl Plastic {
    /// A plastic with relative IOR `eta` = int_ior / ext_ior (must be positive and finite).
    pub fn new(
        eta: f32,
        diffuse_reflectance: Texture,
        specular_reflectance: Texture,
        nonlinear: bool,
    ) -> Plastic {
        let d_mean = diffuse_reflectance.mean();
        let s_mean = specular_reflectance.mean();
        Plastic {
            eta,
            inv_eta_2: 1.0 / (eta * eta),
            fdr_int: fresnel_diffuse_reflectance(1.0 / eta),
            specular_sampling_weight: s_mean / (d_mean + s_mean),
            diffuse_reflectance,
            specular_reflectance,
            nonlinear,
        }
    }

    /// Relative IOR of the coating.
    pub fn eta(&self) -> f32 {
        self.eta
    }

    /// Delta and diffuse reflection.
    pub fn flags(&self) -> BsdfFlags {
        let f = BsdfFlags::DELTA_REFLECTION | BsdfFlags::DIFFUSE_REFLECTION;
        if self.diffuse_reflectance.is_spatially_varying()
            || self.specular_reflectance.is_spatially_varying()
        {
            f | BsdfFlags::SPATIALLY_VARYING
        } else {
            f
        }
    }

    /// The base's albedo divided by what the coating's internal reflections keep in.
    #[inline]
    fn base(&self, uv: Vec2) -> Spectrum {
        let d = self.diffuse_reflectance.eval(uv);
        if self.nonlinear {
            d / (Spectrum::ONE - d * self.fdr_int)
        } else {
            d / (1.0 - self.fdr_int)
        }
    }

    /// Probability of sampling the diffuse lobe given F(θ_i).
    #[inline]
    fn prob_diffuse(&self, f_i: f32) -> f32 {
        let ps = f_i * self.specular_sampling_weight;
        let pd = (1.0 - f_i) * (1.0 - self.specular_sampling_weight);
        pd / (ps + pd)
    }

    /// The diffuse lobe only (the specular one is a delta).
    pub fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        if si.wi.z <= 0.0 || wo.z <= 0.0 {
            return Spectrum::ZERO;
        }
        let f_i = fresnel_dielectric(si.wi.z, self.eta).r;
        let f_o = fresnel_dielectric(wo.z, self.eta).r;
        self.base(si.uv)
            * (warp::square_to_cosine_hemisphere_pdf(wo)
                * self.inv_eta_2
                * (1.0 - f_i)
                * (1.0 - f_o))
    }

    /// Cosine-hemisphere pdf times the diffuse lobe's selection probability.
    pub fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        if si.wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let f_i = fresnel_dielectric(si.wi.z, self.eta).r;
        warp::square_to_cosine_hemisphere_pdf(wo) * self.prob_diffuse(f_i)
    }

    /// Chooses the specular lobe with probability ∝ F_i · w_s, else the diffuse one.
    pub fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        if si.wi.z <= 0.0 {
            return None;
        }
        let f_i = fresnel_dielectric(si.wi.z, self.eta).r;
        let prob_diffuse = self.prob_diffuse(f_i);
        let prob_specular = 1.0 - prob_diffuse;
        if sample1 < prob_specular {
            let bs = BsdfSample {
                wo: reflect(si.wi),
                pdf: prob_specular,
                eta: 1.0,
                sampled: BsdfFlags::DELTA_REFLECTION,
            };
            let w = self.specular_reflectance.eval(si.uv) * (f_i / prob_specular);
            return Some((bs, w));
        }
        let wo = warp::square_to_cosine_hemisphere(sample2);
        let pdf = prob_diffuse * warp::square_to_cosine_hemisphere_pdf(wo);
        if pdf <= 0.0 {
            return None;
        }
        let f_o = fresnel_dielectric(wo.z, self.eta).r;
        let w = self.base(si.uv) * (self.inv_eta_2 * (1.0 - f_i) * (1.0 - f_o) / prob_diffuse);
        let bs = BsdfSample {
            wo,
            pdf,
            eta: 1.0,
            sampled: BsdfFlags::DIFFUSE_REFLECTION,
        };
        Some((bs, w))
    }
}
