//! Rough dielectric interface (Mitsuba `roughdielectric`, Beckmann or GGX): Walter et al. 2007 microfacet
//! reflection and refraction on both sides, lobe chosen with probability F(wi·m), radiance
//! transport (1/η² on refraction), optional texture-driven anisotropic roughness.

use super::fresnel::fresnel_dielectric_t;
use super::ior::ior;
use super::microfacet::roughness;
use super::microfacet::{Microfacet, MicrofacetType};
use super::plugin::BsdfProperties;
use super::{BsdfFlags, BsdfSample, Bxdf, Texture};
use crate::Result;
use crate::geometry::SurfaceInteraction;
use crate::math::simd::real::{Cond, Real, V2, V3};
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

impl RoughDielectric {
    /// Mitsuba's `roughdielectric`: `int_ior`, `ext_ior` (different), `distribution`, `alpha`
    /// or `alpha_u`/`alpha_v`, `specular_reflectance`, `specular_transmittance`,
    /// `sample_visible`.
    pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Self> {
        let int_ior = ior(p, "int_ior", "bk7")?;
        let ext_ior = ior(p, "ext_ior", "air")?;
        if !(int_ior > 0.0 && ext_ior > 0.0) || int_ior == ext_ior {
            return Err(p.err(
                "the interior and exterior indices of refraction must be positive and differ",
            ));
        }
        let distribution = MicrofacetType::from_props(p)?;
        let (alpha_u, alpha_v) = roughness(p)?;
        Ok(RoughDielectric {
            distribution,
            alpha_u,
            alpha_v,
            eta: int_ior / ext_ior,
            specular_reflectance: p.texture("specular_reflectance", Vec3::ONE)?,
            specular_transmittance: p.texture("specular_transmittance", Vec3::ONE)?,
            sample_visible: p.bool("sample_visible", true)?,
        })
    }
}

/// −v if `s` < 0 (Mitsuba `mulsign`, with +0 and −0 distinguished as there).
#[inline(always)]
fn mulsign<T: Real>(v: V3<T>, s: T) -> V3<T> {
    V3::select(s.is_sign_negative(), v.neg(), v)
}

impl RoughDielectric {
    /// The distribution at `uv` (roughness textures evaluated there), for one lane or sixteen.
    #[inline(always)]
    pub fn distr_t<T: Real>(&self, uv: V2<T>) -> Microfacet<T> {
        Microfacet::new_t(
            self.distribution,
            self.alpha_u.eval_1_t(uv),
            self.alpha_v.eval_1_t(uv),
            self.sample_visible,
        )
    }

    /// The distribution that sampling uses: non-visible sampling widens it by 1.2 − 0.2 √|cos θ_i|.
    #[inline(always)]
    fn sample_distr<T: Real>(&self, d: Microfacet<T>, cos_theta_i: T) -> Microfacet<T> {
        if d.sample_visible {
            d
        } else {
            let s = T::splat(1.2) - cos_theta_i.abs().sqrt() * 0.2;
            Microfacet {
                kind: d.kind,
                alpha_u: d.alpha_u * s,
                alpha_v: d.alpha_v * s,
                sample_visible: false,
            }
        }
    }

    /// The textures at `uv`, for one lane or sixteen.
    #[inline(always)]
    pub fn at<T: Real>(&self, uv: V2<T>) -> RoughDielectricAt<T> {
        RoughDielectricAt {
            distr: self.distr_t(uv),
            reflectance: self.specular_reflectance.eval_t(uv),
            transmittance: self.specular_transmittance.eval_t(uv),
        }
    }

    /// [`Self::eval_pdf`] for one lane or sixteen with the textures `at` the hit.
    #[inline(always)]
    pub fn eval_pdf_t<T: Real>(
        &self,
        at: &RoughDielectricAt<T>,
        wi: V3<T>,
        wo: V3<T>,
    ) -> (V3<T>, T) {
        let (zero, one) = (T::splat(0.0), T::splat(1.0));
        let (cos_i, cos_o) = (wi.z, wo.z);
        let reflect = (cos_i * cos_o).gt(zero);
        let front = cos_i.gt(zero);
        let eta = T::select(front, T::splat(self.eta), T::splat(1.0 / self.eta));
        let inv_eta = T::select(front, T::splat(1.0 / self.eta), T::splat(self.eta));
        let m = wi.add(wo.scale(T::select(reflect, one, eta))).normalize();
        let m = mulsign(m, m.z);
        let (dot_wi_m, dot_wo_m) = (wi.dot(m), wo.dot(m));
        let active = (dot_wi_m * cos_i).gt(zero).and((dot_wo_m * cos_o).gt(zero));
        let distr = &at.distr;
        let d = distr.eval_t(m);
        let f = fresnel_dielectric_t(dot_wi_m, self.eta).r;
        let g = distr.g_t(wi, wo, m);
        let v_r = at.reflectance.scale(f * d * g / (cos_i.abs() * 4.0));
        let scale = inv_eta * inv_eta;
        let denom = dot_wi_m + eta * dot_wo_m;
        let v = (scale * (one - f) * d * g * eta * eta * dot_wi_m * dot_wo_m)
            / (cos_i * (denom * denom));
        let v_t = at.transmittance.scale(v.abs());
        let value = V3::select(reflect, v_r, v_t);
        let zero3 = V3::new(zero, zero, zero);
        let value = V3::select(value.is_finite(), value, zero3);
        let sd = self.sample_distr(*distr, cos_i);
        let pdf = sd.pdf_t(mulsign(wi, cos_i), m) * T::select(reflect, f, one - f);
        let dwh_dwo = T::select(
            reflect,
            one / (dot_wo_m * 4.0),
            (eta * eta * dot_wo_m) / (denom * denom),
        );
        let pdf = T::select(active, pdf * dwh_dwo.abs(), zero);
        let zero_i = cos_i.eq(zero);
        (
            V3::select(zero_i, zero3, value),
            T::select(zero_i, zero, pdf),
        )
    }

    /// [`Self::sample`] for one lane or sixteen with the textures `at` the hit.
    #[inline(always)]
    pub fn sample_t<T: Real>(
        &self,
        at: &RoughDielectricAt<T>,
        wi: V3<T>,
        sample1: T,
        sample2: V2<T>,
    ) -> RoughDielectricSample<T> {
        let (zero, one) = (T::splat(0.0), T::splat(1.0));
        let cos_i = wi.z;
        let distr = &at.distr;
        let sd = self.sample_distr(*distr, cos_i);
        let (m, pdf_m) = sd.sample_t(mulsign(wi, cos_i), sample2);
        let fr = fresnel_dielectric_t(wi.dot(m), self.eta);
        let reflected = sample1.le(fr.r);
        let wo_r = m.scale(wi.dot(m) * 2.0).sub(wi);
        let wo_t = m
            .scale(wi.dot(m) * fr.eta_ti + fr.cos_theta_t)
            .sub(wi.scale(fr.eta_ti));
        let wo = V3::select(reflected, wo_r, wo_t);
        let e = fr.eta_it;
        let dwh_r = one / (wo.dot(m) * 4.0);
        let denom = wi.dot(m) + e * wo.dot(m);
        let dwh_t = (e * e * wo.dot(m)) / (denom * denom);
        let dwh_dwo = T::select(reflected, dwh_r, dwh_t);
        let weight = V3::select(
            reflected,
            at.reflectance,
            at.transmittance.scale(fr.eta_ti * fr.eta_ti),
        );
        let w = if distr.sample_visible {
            distr.smith_g1_t(wo, m)
        } else {
            distr.g_t(wi, wo, m) * wi.dot(m) / (cos_i * m.z)
        };
        let weight = weight.scale(w);
        let pdf_lobe = T::select(reflected, fr.r, one - fr.r);
        let pdf = pdf_m * pdf_lobe * dwh_dwo.abs();
        let ok = cos_i
            .eq(zero)
            .not()
            .and(pdf_m.eq(zero).not())
            .and(pdf.gt(zero))
            .and(pdf.is_finite())
            .and(weight.is_finite());
        RoughDielectricSample {
            wo,
            pdf,
            weight,
            eta: T::select(reflected, one, e),
            reflected,
            ok,
        }
    }
}

impl Bxdf for RoughDielectric {
    /// Glossy reflection and transmission.
    fn flags(&self) -> BsdfFlags {
        let f = BsdfFlags::GLOSSY_REFLECTION | BsdfFlags::GLOSSY_TRANSMISSION;
        f.varying_if(
            self.specular_reflectance.is_spatially_varying()
                || self.specular_transmittance.is_spatially_varying()
                || self.alpha_u.is_spatially_varying()
                || self.alpha_v.is_spatially_varying(),
        )
    }

    /// f · |cos θ_o| for reflection or refraction.
    fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        self.eval_pdf(si, wo).0
    }

    /// Density of [`RoughDielectric::sample`].
    fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        self.eval_pdf(si, wo).1
    }

    /// `eval` and `pdf` sharing the generalised half vector (Mitsuba `eval_pdf`).
    fn eval_pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> (Spectrum, f32) {
        let (v, pdf) = self.eval_pdf_t(&self.at(si.uv.into()), si.wi.into(), wo.into());
        (v.into(), pdf)
    }

    /// Samples a microfacet normal, then reflects with probability F or refracts.
    fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        if si.wi.z == 0.0 {
            return None;
        }
        let s = self.sample_t(
            &self.at(si.uv.into()),
            si.wi.into(),
            sample1,
            sample2.into(),
        );
        let sampled = if s.reflected {
            BsdfFlags::GLOSSY_REFLECTION
        } else {
            BsdfFlags::GLOSSY_TRANSMISSION
        };
        let bs = BsdfSample {
            wo: s.wo.into(),
            pdf: s.pdf,
            eta: s.eta,
            sampled,
        };
        s.ok.then_some((bs, s.weight.into()))
    }
}

/// A rough dielectric's textures at a hit (per lane for [`crate::math::simd::f16::F16`]).
#[derive(Clone, Copy, Debug)]
pub struct RoughDielectricAt<T> {
    /// The distribution with the roughness there.
    pub distr: Microfacet<T>,
    /// Multiplier on reflection.
    pub reflectance: V3<T>,
    /// Multiplier on transmission.
    pub transmittance: V3<T>,
}

/// A sample of [`RoughDielectric::sample_t`].
#[derive(Clone, Copy, Debug)]
pub struct RoughDielectricSample<T: Real> {
    /// Sampled direction.
    pub wo: V3<T>,
    /// Its density.
    pub pdf: T,
    /// eval · |cos θ_o| / pdf.
    pub weight: V3<T>,
    /// Relative IOR of the event (1 for reflection).
    pub eta: T,
    /// The reflection lobe was chosen.
    pub reflected: T::Mask,
    /// False where [`RoughDielectric::sample`] returns None.
    pub ok: T::Mask,
}
