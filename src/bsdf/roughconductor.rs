//! Rough conductor (Mitsuba `roughconductor`): Cook–Torrance with a Beckmann or GGX normal
//! distribution, Smith masking and complex-IOR Fresnel. One-sided. Roughness and IOR are
//! textures evaluated at the hit, as in Mitsuba 3.9.1 (`alpha_u->eval_1(si)`, `eta->eval(si)`).

use super::conductor::conductor_ior;
use super::fresnel::fresnel_conductor_rgb_t;
use super::microfacet::roughness;
use super::microfacet::{Microfacet, MicrofacetType};
use super::plugin::BsdfProperties;
use super::{BsdfFlags, BsdfSample, Bxdf, Texture};
use crate::Result;
use crate::geometry::SurfaceInteraction;
use crate::math::simd::real::{Cond, Real, V2, V3};
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
    /// Mitsuba's `roughconductor`: the conductor's IOR and `specular_reflectance`,
    /// `distribution`, `alpha` or `alpha_u`/`alpha_v`, `sample_visible`.
    pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Self> {
        let (eta, k) = conductor_ior(p)?;
        let specular_reflectance = p.texture("specular_reflectance", Vec3::ONE)?;
        let distribution = MicrofacetType::from_props(p)?;
        let (alpha_u, alpha_v) = roughness(p)?;
        Ok(RoughConductor {
            distribution,
            alpha_u,
            alpha_v,
            eta,
            k,
            specular_reflectance,
            sample_visible: p.bool("sample_visible", true)?,
        })
    }
}

impl RoughConductor {
    /// The textures at `uv`, for one lane or sixteen.
    #[inline(always)]
    pub fn at<T: Real>(&self, uv: V2<T>) -> RoughConductorAt<T> {
        RoughConductorAt {
            distr: Microfacet::new_t(
                self.distribution,
                self.alpha_u.eval_1_t(uv),
                self.alpha_v.eval_1_t(uv),
                self.sample_visible,
            ),
            eta: self.eta.eval_t(uv),
            k: self.k.eval_t(uv),
            specular: self.specular_reflectance.eval_t(uv),
        }
    }

    /// [`Self::eval_pdf`] for one lane or sixteen with the textures `at` the hit.
    #[inline(always)]
    pub fn eval_pdf_t<T: Real>(
        &self,
        at: &RoughConductorAt<T>,
        wi: V3<T>,
        wo: V3<T>,
    ) -> (V3<T>, T) {
        let zero = T::splat(0.0);
        let d = &at.distr;
        let below = wi.z.le(zero).or(wo.z.le(zero));
        let h = wo.add(wi).normalize();
        let dm = d.eval_t(h);
        let g1_wi = d.smith_g1_t(wi, h);
        let g = g1_wi * d.smith_g1_t(wo, h);
        let f = fresnel_conductor_rgb_t(wi.dot(h), at.eta, at.k);
        let value = at.specular.mul(f).scale(dm * g / (wi.z * 4.0));
        let pdf = if d.sample_visible {
            dm * g1_wi / (wi.z * 4.0)
        } else {
            d.pdf_t(wi, h) / (wo.dot(h) * 4.0)
        };
        let back = wi.dot(h).le(zero).or(wo.dot(h).le(zero));
        let none = below.or(dm.eq(zero));
        let zero3 = V3::new(zero, zero, zero);
        (
            V3::select(none, zero3, value),
            T::select(none.or(back), zero, pdf),
        )
    }

    /// [`Self::sample`] for one lane or sixteen with the textures `at` the hit: (wo, pdf,
    /// weight, valid), valid false where that returns None.
    #[inline(always)]
    pub fn sample_t<T: Real>(
        &self,
        at: &RoughConductorAt<T>,
        wi: V3<T>,
        sample2: V2<T>,
    ) -> (V3<T>, T, V3<T>, T::Mask) {
        let zero = T::splat(0.0);
        let d = &at.distr;
        let (m, pdf_m) = d.sample_t(wi, sample2);
        let wo = m.scale(wi.dot(m) * 2.0).sub(wi);
        let weight = if d.sample_visible {
            d.smith_g1_t(wo, m)
        } else {
            d.g_t(wi, wo, m) * wi.dot(m) / (wi.z * m.z)
        };
        let pdf = pdf_m / (wo.dot(m) * 4.0);
        let f = fresnel_conductor_rgb_t(wi.dot(m), at.eta, at.k);
        let ok =
            wi.z.le(zero)
                .not()
                .and(pdf_m.eq(zero).not())
                .and(wo.z.gt(zero))
                .and(pdf.is_finite())
                .and(pdf.gt(zero));
        (wo, pdf, at.specular.mul(f).scale(weight), ok)
    }
}

impl Bxdf for RoughConductor {
    /// Glossy reflection.
    fn flags(&self) -> BsdfFlags {
        let f = BsdfFlags::GLOSSY_REFLECTION;
        f.varying_if(
            self.specular_reflectance.is_spatially_varying()
                || self.alpha_u.is_spatially_varying()
                || self.alpha_v.is_spatially_varying()
                || self.eta.is_spatially_varying()
                || self.k.is_spatially_varying(),
        )
    }

    /// D G F / (4 cos θ_i) (= f · cos θ_o); 0 unless both directions are above the surface.
    fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        self.eval_pdf(si, wo).0
    }

    /// Density of [`RoughConductor::sample`] (reflection Jacobian 1/(4 wo·m) included).
    fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        self.eval_pdf(si, wo).1
    }

    /// `eval` and `pdf` together, sharing the half vector and D (Mitsuba `eval_pdf`).
    fn eval_pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> (Spectrum, f32) {
        let wi = si.wi;
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let (v, pdf) = self.eval_pdf_t(&self.at(si.uv.into()), wi.into(), wo.into());
        (v.into(), pdf)
    }

    /// Samples a microfacet normal and reflects `wi` about it. Weight: G1(wo) F (visible
    /// sampling) or G F (wi·m) / (cos θ_i cos θ_m); None if the reflection goes below.
    fn sample(
        &self,
        si: &SurfaceInteraction,
        _sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        if si.wi.z <= 0.0 {
            return None;
        }
        let (wo, pdf, weight, ok) =
            self.sample_t(&self.at(si.uv.into()), si.wi.into(), sample2.into());
        let bs = BsdfSample {
            wo: wo.into(),
            pdf,
            eta: 1.0,
            sampled: BsdfFlags::GLOSSY_REFLECTION,
        };
        ok.then_some((bs, weight.into()))
    }
}

/// A rough conductor's textures at a hit (per lane for [`crate::math::simd::f16::F16`]).
#[derive(Clone, Copy, Debug)]
pub struct RoughConductorAt<T> {
    /// The distribution with the roughness there.
    pub distr: Microfacet<T>,
    /// Real part of the IOR.
    pub eta: V3<T>,
    /// Extinction coefficient.
    pub k: V3<T>,
    /// Multiplier on the reflectance.
    pub specular: V3<T>,
}
