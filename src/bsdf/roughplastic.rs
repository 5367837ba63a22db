//! Rough plastic (Mitsuba `roughplastic`, Beckmann or GGX): a diffuse base under a rough dielectric coating.
//! Glossy reflection F D G / (4 cos θ_i), plus the base seen through the coating,
//! ρ / (1 − ρ_int) · T(θ_i) T(θ_o) cos θ_o / (π η²), where T is the coating's rough transmittance
//! and ρ_int its internal diffuse reflectance (`nonlinear`: ρ / (1 − ρ·ρ_int)). T and ρ_int are
//! tabulated at load by Gauss–Legendre integration over visible normals, exactly as Mitsuba 3
//! does. Isotropic, one-sided.

use super::fresnel::{fresnel_dielectric, reflect_about, refract_about};
use super::microfacet::{Microfacet, MicrofacetType};
use super::{BsdfFlags, BsdfSample, Texture};
use crate::geometry::SurfaceInteraction;
use crate::math::quad::gauss_legendre;
use crate::math::{INV_PI, Spectrum, Vec2, Vec3, warp};

/// Entries of the transmittance table over cos θ ∈ [0, 1] (Mitsuba `MI_ROUGH_TRANSMITTANCE_RES`).
pub const TRANSMITTANCE_RES: usize = 64;

/// Rough plastic, eta = int_ior / ext_ior (Mitsuba defaults polypropylene 1.49 / air).
#[derive(Clone, Debug)]
pub struct RoughPlastic {
    /// Albedo of the diffuse base (Mitsuba default 0.5).
    pub diffuse_reflectance: Texture,
    /// Multiplier on the glossy reflection (Mitsuba default 1).
    pub specular_reflectance: Texture,
    /// Account for colour shifts from internal scattering (Mitsuba `nonlinear`).
    pub nonlinear: bool,
    distr: Microfacet,
    eta: f32,
    inv_eta_2: f32,
    /// Share of samples steered to the glossy lobe before the transmittance term.
    specular_sampling_weight: f32,
    /// Rough transmittance T(cos θ) into the coating at `TRANSMITTANCE_RES` equispaced cosines.
    external_transmittance: Box<[f32; TRANSMITTANCE_RES]>,
    /// Diffuse reflectance of the coating seen from inside.
    internal_reflectance: f32,
}

impl RoughPlastic {
    /// A rough plastic with distribution `kind`, roughness `alpha` (> 0) and relative IOR `eta`
    /// (> 0, ≠ 1).
    pub fn new(
        kind: MicrofacetType,
        alpha: f32,
        eta: f32,
        diffuse_reflectance: Texture,
        specular_reflectance: Texture,
        nonlinear: bool,
        sample_visible: bool,
    ) -> RoughPlastic {
        let d_mean = diffuse_reflectance.mean();
        let s_mean = specular_reflectance.mean();
        // The tables always use visible-normal sampling, whatever `sample_visible` says.
        let table_distr = Microfacet::new(kind, alpha, alpha, true);
        let mut external_transmittance = Box::new([0.0f32; TRANSMITTANCE_RES]);
        let mut internal = 0.0f64;
        for (i, t) in external_transmittance.iter_mut().enumerate() {
            let mu = (i as f32 / (TRANSMITTANCE_RES - 1) as f32).max(1e-6);
            let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            *t = eval_transmittance(&table_distr, wi, eta) as f32;
            internal += eval_reflectance(&table_distr, wi, 1.0 / eta) * mu as f64;
        }
        let internal_reflectance = (internal / TRANSMITTANCE_RES as f64 * 2.0) as f32;
        RoughPlastic {
            distr: Microfacet::new(kind, alpha, alpha, sample_visible),
            eta,
            inv_eta_2: 1.0 / (eta * eta),
            specular_sampling_weight: s_mean / (d_mean + s_mean),
            external_transmittance,
            internal_reflectance,
            diffuse_reflectance,
            specular_reflectance,
            nonlinear,
        }
    }

    /// Relative IOR of the coating.
    pub fn eta(&self) -> f32 {
        self.eta
    }

    /// The coating's internal diffuse reflectance (what `nonlinear` feeds back).
    pub fn internal_reflectance(&self) -> f32 {
        self.internal_reflectance
    }

    /// Rough transmittance into the coating at incident cosine `cos_theta` ∈ [0, 1].
    pub fn transmittance(&self, cos_theta: f32) -> f32 {
        let x = cos_theta * (TRANSMITTANCE_RES - 1) as f32;
        // Float → int saturates at 0 for negatives and NaN, as Mitsuba's UInt32 conversion.
        let i = (x as usize).min(TRANSMITTANCE_RES - 2);
        let (v0, v1) = (
            self.external_transmittance[i],
            self.external_transmittance[i + 1],
        );
        v0 + (v1 - v0) * (x - i as f32)
    }

    /// Glossy and diffuse reflection.
    pub fn flags(&self) -> BsdfFlags {
        let f = BsdfFlags::GLOSSY_REFLECTION | BsdfFlags::DIFFUSE_REFLECTION;
        if self.diffuse_reflectance.is_spatially_varying()
            || self.specular_reflectance.is_spatially_varying()
        {
            f | BsdfFlags::SPATIALLY_VARYING
        } else {
            f
        }
    }

    /// Probability of choosing the glossy lobe given T(θ_i).
    #[inline]
    fn prob_specular(&self, t_i: f32) -> f32 {
        let ps = (1.0 - t_i) * self.specular_sampling_weight;
        let pd = t_i * (1.0 - self.specular_sampling_weight);
        ps / (ps + pd)
    }

    /// Both lobes; 0 unless wi and wo are above the surface.
    pub fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        let wi = si.wi;
        let (cos_i, cos_o) = (wi.z, wo.z);
        if !(cos_i > 0.0 && cos_o > 0.0) {
            return Spectrum::ZERO;
        }
        let h = (wo + wi).normalize();
        let d = self.distr.eval(h);
        let f = fresnel_dielectric(wi.dot(h), self.eta).r;
        let g = self.distr.g(wi, wo, h);
        let spec = self.specular_reflectance.eval(si.uv) * (f * d * g / (4.0 * cos_i));
        let t_i = self.transmittance(cos_i);
        let t_o = self.transmittance(cos_o);
        let diff = self.diffuse_reflectance.eval(si.uv);
        let diff = if self.nonlinear {
            diff / (Spectrum::ONE - diff * self.internal_reflectance)
        } else {
            diff / (1.0 - self.internal_reflectance)
        };
        spec + diff * (INV_PI * self.inv_eta_2 * cos_o * t_i * t_o)
    }

    /// Mixture of the glossy lobe's density and the cosine hemisphere.
    pub fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        let wi = si.wi;
        let (cos_i, cos_o) = (wi.z, wo.z);
        if !(cos_i > 0.0 && cos_o > 0.0) {
            return 0.0;
        }
        let prob_specular = self.prob_specular(self.transmittance(cos_i));
        let prob_diffuse = 1.0 - prob_specular;
        let h = (wo + wi).normalize();
        let spec = if self.distr.sample_visible {
            self.distr.eval(h) * self.distr.smith_g1(wi, h) / (4.0 * cos_i)
        } else {
            self.distr.pdf(wi, h) / (4.0 * wo.dot(h))
        };
        spec * prob_specular + prob_diffuse * warp::square_to_cosine_hemisphere_pdf(wo)
    }

    /// Chooses a lobe by `sample1`, samples it, and weights by eval / pdf of the mixture.
    pub fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        let wi = si.wi;
        if !(wi.z > 0.0) {
            return None;
        }
        let prob_specular = self.prob_specular(self.transmittance(wi.z));
        let (wo, sampled) = if sample1 < prob_specular {
            let (m, _) = self.distr.sample(wi, sample2);
            (reflect_about(wi, m), BsdfFlags::GLOSSY_REFLECTION)
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
        let value = self.eval(si, wo);
        let bs = BsdfSample {
            wo,
            pdf,
            eta: 1.0,
            sampled,
        };
        Some((bs, value / pdf))
    }
}

/// Mitsuba's `eval_transmittance`: ∫ (1 − F) G1(wo) over visible normals, wo refracted (32² or
/// 128² Gauss–Legendre nodes for eta > 1 or < 1).
fn eval_transmittance(distr: &Microfacet, wi: Vec3, eta: f32) -> f64 {
    integrate_visible(distr, wi, eta, |m| {
        let fr = fresnel_dielectric(wi.dot(m), eta);
        let wo = refract_about(wi, m, fr.cos_theta_t, fr.eta_ti);
        if wo.z * wi.z >= 0.0 {
            0.0
        } else {
            distr.smith_g1(wo, m) * (1.0 - fr.r)
        }
    })
}

/// Mitsuba's `eval_reflectance`: ∫ F G1(wo) over visible normals, wo reflected.
fn eval_reflectance(distr: &Microfacet, wi: Vec3, eta: f32) -> f64 {
    integrate_visible(distr, wi, eta, |m| {
        let wo = reflect_about(wi, m);
        if wo.z <= 0.0 || wi.z <= 0.0 {
            0.0
        } else {
            distr.smith_g1(wo, m) * fresnel_dielectric(wi.dot(m), eta).r
        }
    })
}

/// Σ f(m) over the visible-normal samples of a product Gauss–Legendre grid on [0, 1]².
fn integrate_visible(distr: &Microfacet, wi: Vec3, eta: f32, f: impl Fn(Vec3) -> f32) -> f64 {
    let res = if eta > 1.0 { 32 } else { 128 };
    let (nodes, weights) = gauss_legendre(res);
    let mut sum = 0.0f64;
    // Mitsuba's meshgrid: x varies fastest.
    for (ny, wy) in nodes.iter().zip(&weights) {
        for (nx, wx) in nodes.iter().zip(&weights) {
            let u = Vec2::new((nx * 0.5 + 0.5) as f32, (ny * 0.5 + 0.5) as f32);
            let (m, _) = distr.sample(wi, u);
            sum += f(m) as f64 * wx * wy * 0.25;
        }
    }
    sum
}
