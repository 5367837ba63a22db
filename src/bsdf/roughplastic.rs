//! Rough plastic (Mitsuba `roughplastic`, Beckmann or GGX): a diffuse base under a rough dielectric coating.
//! Glossy reflection F D G / (4 cos θ_i), plus the base seen through the coating,
//! ρ / (1 − ρ_int) · T(θ_i) T(θ_o) cos θ_o / (π η²), where T is the coating's rough transmittance
//! and ρ_int its internal diffuse reflectance (`nonlinear`: ρ / (1 − ρ·ρ_int)). T and ρ_int are
//! tabulated at load by Gauss–Legendre integration over visible normals, exactly as Mitsuba 3
//! does. Isotropic, one-sided.

use super::fresnel::{fresnel_dielectric, fresnel_dielectric_t, reflect_about, refract_about};
use super::microfacet::check_alpha;
use super::microfacet::{Microfacet, MicrofacetType};
use super::plastic::Coating;
use super::plastic::base_under_coating;
use super::plugin::BsdfProperties;
use super::{BsdfFlags, BsdfSample, Bxdf, Texture};
use crate::Result;
use crate::geometry::SurfaceInteraction;
use crate::math::quad::gauss_legendre;
use crate::math::simd::real::{Cond, Real, V2, V3};
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
    /// Mitsuba's `roughplastic`: the parameters of `plastic`, `distribution`, an isotropic
    /// `alpha` and `sample_visible`.
    pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Self> {
        let c = Coating::from_props(p, true)?;
        let distribution = MicrofacetType::from_props(p)?;
        if p.has("alpha_u") || p.has("alpha_v") {
            return Err(p.err(
                "roughplastic does not support anisotropic roughness (as Mitsuba): use \"alpha\"",
            ));
        }
        let alpha = p.float("alpha", 0.1)?;
        check_alpha(p, "alpha", alpha)?;
        Ok(RoughPlastic::new(
            distribution,
            alpha,
            c.eta,
            c.diffuse_reflectance,
            c.specular_reflectance,
            c.nonlinear,
            p.bool("sample_visible", true)?,
        ))
    }
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

    /// (specular reflectance, the base's albedo over what the coating keeps in) at `uv`, for
    /// one lane or sixteen.
    #[inline(always)]
    pub fn at<T: Real>(&self, uv: V2<T>) -> (V3<T>, V3<T>) {
        let diff = self.diffuse_reflectance.eval_t(uv);
        let base = base_under_coating(diff, self.internal_reflectance, self.nonlinear);
        (self.specular_reflectance.eval_t(uv), base)
    }

    /// The distribution for one lane or sixteen.
    #[inline(always)]
    fn distr_t<T: Real>(&self) -> Microfacet<T> {
        Microfacet {
            kind: self.distr.kind,
            alpha_u: T::splat(self.distr.alpha_u),
            alpha_v: T::splat(self.distr.alpha_v),
            sample_visible: self.distr.sample_visible,
        }
    }

    /// Probability of choosing the glossy lobe given the incident cosine.
    #[inline(always)]
    fn prob_specular_t<T: Real>(&self, cos_theta_i: T) -> T {
        let t_i = cos_theta_i.map(|c| self.transmittance(c));
        let ps = (T::splat(1.0) - t_i) * self.specular_sampling_weight;
        let pd = t_i * (1.0 - self.specular_sampling_weight);
        ps / (ps + pd)
    }

    /// [`Self::eval`] for one lane or sixteen, with the lanes' [`Self::at`].
    #[inline(always)]
    pub fn eval_t<T: Real>(&self, spec: V3<T>, base: V3<T>, wi: V3<T>, wo: V3<T>) -> V3<T> {
        let zero = T::splat(0.0);
        let distr = self.distr_t::<T>();
        let (cos_i, cos_o) = (wi.z, wo.z);
        let h = wo.add(wi).normalize();
        let d = distr.eval_t(h);
        let f = fresnel_dielectric_t(wi.dot(h), self.eta).r;
        let g = distr.g_t(wi, wo, h);
        let spec = spec.scale(f * d * g / (cos_i * 4.0));
        let t_i = cos_i.map(|c| self.transmittance(c));
        let t_o = cos_o.map(|c| self.transmittance(c));
        let v = spec.add(base.scale(cos_o * (INV_PI * self.inv_eta_2) * t_i * t_o));
        let above = cos_i.gt(zero).and(cos_o.gt(zero));
        V3::select(above, v, V3::new(zero, zero, zero))
    }

    /// [`Self::pdf`] for one lane or sixteen.
    #[inline(always)]
    pub fn pdf_t<T: Real>(&self, wi: V3<T>, wo: V3<T>) -> T {
        let zero = T::splat(0.0);
        let distr = self.distr_t::<T>();
        let (cos_i, cos_o) = (wi.z, wo.z);
        let prob_specular = self.prob_specular_t(cos_i);
        let prob_diffuse = T::splat(1.0) - prob_specular;
        let h = wo.add(wi).normalize();
        let spec = if distr.sample_visible {
            distr.eval_t(h) * distr.smith_g1_t(wi, h) / (cos_i * 4.0)
        } else {
            distr.pdf_t(wi, h) / (wo.dot(h) * 4.0)
        };
        let cos_pdf = T::select(wo.z.gt(zero), wo.z * INV_PI, zero);
        let pdf = spec * prob_specular + prob_diffuse * cos_pdf;
        T::select(cos_i.gt(zero).and(cos_o.gt(zero)), pdf, zero)
    }

    /// [`Self::sample`] for one lane or sixteen, with the lanes' [`Self::at`]: (wo, pdf,
    /// weight, glossy lobe, valid), valid false where that returns None.
    #[inline(always)]
    pub fn sample_t<T: Real>(
        &self,
        spec: V3<T>,
        base: V3<T>,
        wi: V3<T>,
        sample1: T,
        sample2: V2<T>,
    ) -> (V3<T>, T, V3<T>, T::Mask, T::Mask) {
        let zero = T::splat(0.0);
        let glossy = sample1.lt(self.prob_specular_t(wi.z));
        let (m, _) = self.distr_t::<T>().sample_t(wi, sample2);
        let wo_g = m.scale(wi.dot(m) * 2.0).sub(wi);
        let wo_d = warp::square_to_cosine_hemisphere_t(sample2);
        let wo = V3::select(glossy, wo_g, wo_d);
        let pdf = self.pdf_t(wi, wo);
        let v = self.eval_t(spec, base, wi, wo);
        let ok = wi.z.gt(zero).and(pdf.gt(zero));
        (
            wo,
            pdf,
            V3::new(v.x / pdf, v.y / pdf, v.z / pdf),
            glossy,
            ok,
        )
    }
}

impl Bxdf for RoughPlastic {
    /// Glossy and diffuse reflection.
    fn flags(&self) -> BsdfFlags {
        let f = BsdfFlags::GLOSSY_REFLECTION | BsdfFlags::DIFFUSE_REFLECTION;
        f.varying_if(
            self.diffuse_reflectance.is_spatially_varying()
                || self.specular_reflectance.is_spatially_varying(),
        )
    }

    /// Both lobes; 0 unless wi and wo are above the surface.
    fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        let (cos_i, cos_o) = (si.wi.z, wo.z);
        if !(cos_i > 0.0 && cos_o > 0.0) {
            return Spectrum::ZERO;
        }
        let (spec, base) = self.at(si.uv.into());
        self.eval_t(spec, base, si.wi.into(), wo.into()).into()
    }

    /// Mixture of the glossy lobe's density and the cosine hemisphere.
    fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        self.pdf_t(si.wi.into(), wo.into())
    }

    /// Chooses a lobe by `sample1`, samples it, and weights by eval / pdf of the mixture.
    fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        if !(si.wi.z > 0.0) {
            return None;
        }
        let (spec, base) = self.at(si.uv.into());
        let (wo, pdf, weight, glossy, ok) =
            self.sample_t(spec, base, si.wi.into(), sample1, sample2.into());
        let sampled = if glossy {
            BsdfFlags::GLOSSY_REFLECTION
        } else {
            BsdfFlags::DIFFUSE_REFLECTION
        };
        let bs = BsdfSample {
            wo: wo.into(),
            pdf,
            eta: 1.0,
            sampled,
        };
        ok.then_some((bs, weight.into()))
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
