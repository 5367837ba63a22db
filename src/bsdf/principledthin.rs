//! Disney's thin-surface principled BSDF as Mitsuba 3 defines it (`principledthin`, after
//! Burley 2015): a two-sided sheet with a diffuse base (retro-reflection, fake subsurface, sheen),
//! Lambertian diffuse transmission, GGX specular reflection and a "transmission" that mirrors
//! the reflected direction through the sheet with roughness scaled by the IOR. Symmetric: a
//! hit from the back is evaluated as one from the front.

use super::fresnel::{fresnel_dielectric, reflect_about};
use super::microfacet::{Microfacet, MicrofacetType};
use super::plugin::BsdfProperties;
use super::principled::{lobe_flag, sampling_rate, unit_texture};
use super::principled_lobes::{
    calc_schlick, compatible, dist_params, mulsign, schlick_r0, schlick_weight, tint,
};
use super::{BsdfFlags, BsdfSample, Bxdf, Texture};
use crate::Result;
use crate::geometry::SurfaceInteraction;
use crate::math::cie1931::SpectrumUse;
use crate::math::{Spectrum, Vec2, Vec3, warp};

/// Mitsuba's `principledthin` BSDF. Weights are textures read with `eval_1`, `base_color` with
/// `eval`; `eta` is an unbounded texture.
#[derive(Clone, Debug)]
pub struct PrincipledThin {
    /// Albedo of the diffuse lobes and tint of the specular transmission.
    pub base_color: Texture,
    /// Disney roughness in [0, 1].
    pub roughness: Texture,
    /// Anisotropy of the specular lobes in [0, 1].
    pub anisotropic: Texture,
    /// Weight of the specular (reflection + transmission) part.
    pub spec_trans: Texture,
    /// Tint of the specular reflection towards `base_color`.
    pub spec_tint: Texture,
    /// Weight of the sheen.
    pub sheen: Texture,
    /// Tint of the sheen towards `base_color`.
    pub sheen_tint: Texture,
    /// Blend of the diffuse reflection towards fake subsurface.
    pub flatness: Texture,
    /// Diffuse transmission in [0, 2] (1 splits the diffuse part evenly).
    pub diff_trans: Texture,
    /// IOR of the sheet.
    pub eta: Texture,
    /// A `spec_trans` was given (Mitsuba's `m_has_spec_trans`).
    pub has_spec_trans: bool,
    /// A `diff_trans` was given (Mitsuba's `m_has_diff_trans`).
    pub has_diff_trans: bool,
    /// Relative sampling weights: specular reflection, specular transmission, diffuse
    /// reflection, diffuse transmission.
    pub rates: [f32; 4],
}

impl PrincipledThin {
    /// Mitsuba's `principledthin`: `base_color`, `roughness`, `anisotropic`, `spec_trans`,
    /// `eta`, `spec_tint`, `sheen`, `sheen_tint`, `flatness`, `diff_trans` and the four sampling
    /// rates. Weights outside [0, 1] (`diff_trans` outside [0, 2]) or a non-positive constant
    /// `eta` are errors.
    pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Self> {
        let has_spec_trans = lobe_flag(p, "spec_trans");
        let has_diff_trans = lobe_flag(p, "diff_trans");
        let eta = p.texture_as("eta", Vec3::splat(1.5), SpectrumUse::Unbounded)?;
        if let Texture::Constant(c) = &eta
            && !(c.min_element() > 0.0 && c.is_finite())
        {
            return Err(p.err_at("eta", &format!("\"eta\" must be positive, got {c}")));
        }
        let diff_trans = p.texture("diff_trans", Vec3::ZERO)?;
        if let Texture::Constant(c) = &diff_trans
            && !(c.min_element() >= 0.0 && c.max_element() <= 2.0)
        {
            return Err(p.err(&format!("\"diff_trans\" must lie in [0, 2], got {c}")));
        }
        Ok(PrincipledThin {
            base_color: unit_texture(p, "base_color", 0.5)?,
            roughness: unit_texture(p, "roughness", 0.5)?,
            anisotropic: unit_texture(p, "anisotropic", 0.0)?,
            spec_trans: unit_texture(p, "spec_trans", 0.0)?,
            spec_tint: unit_texture(p, "spec_tint", 0.0)?,
            sheen: unit_texture(p, "sheen", 0.0)?,
            sheen_tint: unit_texture(p, "sheen_tint", 0.0)?,
            flatness: unit_texture(p, "flatness", 0.0)?,
            diff_trans,
            eta,
            has_spec_trans,
            has_diff_trans,
            rates: [
                sampling_rate(p, "specular_reflectance_sampling_rate")?,
                sampling_rate(p, "specular_transmittance_sampling_rate")?,
                sampling_rate(p, "diffuse_reflectance_sampling_rate")?,
                sampling_rate(p, "diffuse_transmittance_sampling_rate")?,
            ],
        })
    }

    fn textures(&self) -> [&Texture; 10] {
        [
            &self.base_color,
            &self.roughness,
            &self.anisotropic,
            &self.spec_trans,
            &self.spec_tint,
            &self.sheen,
            &self.sheen_tint,
            &self.flatness,
            &self.diff_trans,
            &self.eta,
        ]
    }

    /// The parameters at `uv`.
    fn at(&self, uv: Vec2) -> ThinParams {
        let anisotropic = self.anisotropic.eval_1(uv);
        let roughness = self.roughness.eval_1(uv);
        let eta = self.eta.eval_1(uv);
        let (ax, ay) = dist_params(anisotropic, roughness);
        let (tx, ty) = dist_params(anisotropic, (0.65 * eta - 0.35) * roughness);
        ThinParams {
            base_color: self.base_color.eval(uv),
            roughness,
            spec_trans: self.spec_trans.eval_1(uv),
            spec_tint: self.spec_tint.eval_1(uv),
            sheen: self.sheen.eval_1(uv),
            sheen_tint: self.sheen_tint.eval_1(uv),
            flatness: self.flatness.eval_1(uv),
            diff_trans: self.diff_trans.eval_1(uv) / 2.0,
            eta,
            reflect_distr: Microfacet::new(MicrofacetType::Ggx, ax, ay, true),
            trans_distr: Microfacet::new(MicrofacetType::Ggx, tx, ty, true),
        }
    }

    /// Normalised lobe probabilities: specular reflection, specular transmission, diffuse
    /// reflection, diffuse transmission.
    fn lobe_probabilities(&self, q: &ThinParams) -> [f32; 4] {
        let [r_sr, r_st, r_dr, r_dt] = self.rates;
        let (p_sr, p_st) = if self.has_spec_trans {
            (q.spec_trans * r_sr / 2.0, q.spec_trans * r_st / 2.0)
        } else {
            (0.0, 0.0)
        };
        let p_dr = r_dr * (1.0 - q.spec_trans) * (1.0 - q.diff_trans);
        let p_dt = if self.has_diff_trans {
            r_dt * (1.0 - q.spec_trans) * q.diff_trans
        } else {
            0.0
        };
        let rcp = 1.0 / (p_sr + p_st + p_dr + p_dt);
        [p_sr * rcp, p_st * rcp, p_dr * rcp, p_dt * rcp]
    }

    /// f · |cos θ_o| with the parameters `q`.
    fn eval_at(&self, q: &ThinParams, wi: Vec3, wo: Vec3) -> Spectrum {
        if wi.z == 0.0 {
            return Spectrum::ZERO;
        }
        let wo_t = mulsign(wo, wi.z);
        let wi = mulsign(wi, wi.z);
        let (cos_i, cos_o) = (wi.z, wo_t.z);
        let (reflect, refract) = (cos_o > 0.0, cos_o < 0.0);
        let wo_r = Vec3::new(wo_t.x, wo_t.y, wo_t.z.abs());
        let wh = (wi + wo_r).normalize();
        let mut value = Spectrum::ZERO;
        if self.has_spec_trans && q.spec_trans > 0.0 {
            let f = fresnel_dielectric(wi.dot(wh), q.eta).r;
            if reflect && compatible(wh, wi, wo_t, cos_i, true) {
                let d = &q.reflect_distr;
                let f_schlick =
                    calc_schlick(tint(q.base_color) * schlick_r0(q.eta), wi.dot(wh), q.eta);
                let f_thin = Spectrum::splat(f).lerp(f_schlick, q.spec_tint);
                value += f_thin * (q.spec_trans * d.eval(wh) * d.g(wi, wo_t, wh) / (4.0 * cos_i));
            }
            if refract && compatible(wh, wi, wo_t, cos_i, false) {
                let d = &q.trans_distr;
                value += q.base_color
                    * (q.spec_trans * (1.0 - f) * d.eval(wh) * d.g(wi, wo_t, wh) / (4.0 * cos_i));
            }
        }
        let diffuse = 1.0 - q.spec_trans;
        if reflect && q.spec_trans < 1.0 && q.diff_trans < 1.0 {
            let fo = schlick_weight(cos_o.abs());
            let fi = schlick_weight(cos_i);
            let f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
            let cos_d = wh.dot(wo_t);
            let rr = 2.0 * q.roughness * cos_d * cos_d;
            let f_retro = rr * (fo + fi + fo * fi * (rr - 1.0));
            let fss90 = rr / 2.0;
            let fss = (1.0 + fo * (fss90 - 1.0)) * (1.0 + fi * (fss90 - 1.0));
            let f_ss = 1.25 * (fss * (1.0 / (cos_o.abs() + cos_i) - 0.5) + 0.5);
            let lobe = f_diff + f_retro + q.flatness * (f_ss - (f_diff + f_retro));
            value += q.base_color
                * (diffuse * cos_o * std::f32::consts::FRAC_1_PI * (1.0 - q.diff_trans) * lobe);
            if q.sheen > 0.0 {
                let fd = schlick_weight(cos_d.abs());
                let c_sheen = Spectrum::ONE.lerp(tint(q.base_color), q.sheen_tint);
                value += c_sheen * (q.sheen * diffuse * fd * (1.0 - q.diff_trans) * cos_o.abs());
            }
        }
        if self.has_diff_trans && refract && q.spec_trans < 1.0 && q.diff_trans > 0.0 {
            value +=
                q.base_color * (diffuse * q.diff_trans * std::f32::consts::FRAC_1_PI * cos_o.abs());
        }
        value
    }

    /// Density of [`Bxdf::sample`] with the parameters `q`.
    fn pdf_at(&self, q: &ThinParams, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z == 0.0 {
            return 0.0;
        }
        let wo_t = mulsign(wo, wi.z);
        let wi = mulsign(wi, wi.z);
        let (reflect, refract) = (wo_t.z > 0.0, wo_t.z < 0.0);
        let [p_sr, p_st, p_dr, p_dt] = self.lobe_probabilities(q);
        let mut pdf = 0.0;
        if self.has_spec_trans {
            let wo_r = Vec3::new(wo_t.x, wo_t.y, wo_t.z.abs());
            let wh = (wi + wo_r).normalize();
            let dwh_dwo = (1.0 / (4.0 * wo_r.dot(wh))).abs();
            if reflect && compatible(wh, wi, wo_t, wi.z, true) {
                pdf += p_sr * q.reflect_distr.pdf(wi, wh) * dwh_dwo;
            }
            if refract && compatible(wh, wi, wo_t, wi.z, false) {
                pdf += p_st * q.trans_distr.pdf(wi, wh) * dwh_dwo;
            }
        }
        if reflect {
            pdf += p_dr * warp::square_to_cosine_hemisphere_pdf(wo_t);
        }
        if self.has_diff_trans && refract {
            pdf += p_dt * warp::square_to_cosine_hemisphere_pdf(-wo_t);
        }
        pdf
    }
}

/// A thin principled material's parameters at one hit.
struct ThinParams {
    base_color: Spectrum,
    roughness: f32,
    spec_trans: f32,
    spec_tint: f32,
    sheen: f32,
    sheen_tint: f32,
    flatness: f32,
    /// `diff_trans` / 2, in [0, 1].
    diff_trans: f32,
    eta: f32,
    reflect_distr: Microfacet,
    /// The reflection distribution with roughness scaled by (0.65 η − 0.35).
    trans_distr: Microfacet,
}

impl Bxdf for PrincipledThin {
    /// Diffuse and glossy reflection, diffuse transmission, and glossy transmission when
    /// `spec_trans` is given.
    fn flags(&self) -> BsdfFlags {
        let mut f = BsdfFlags::DIFFUSE_REFLECTION
            | BsdfFlags::DIFFUSE_TRANSMISSION
            | BsdfFlags::GLOSSY_REFLECTION;
        if self.has_spec_trans {
            f = f | BsdfFlags::GLOSSY_TRANSMISSION;
        }
        f.varying_if(self.textures().iter().any(|t| t.is_spatially_varying()))
    }

    fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        self.eval_at(&self.at(si.uv), si.wi, wo)
    }

    fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        self.pdf_at(&self.at(si.uv), si.wi, wo)
    }

    fn eval_pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> (Spectrum, f32) {
        let q = self.at(si.uv);
        (self.eval_at(&q, si.wi, wo), self.pdf_at(&q, si.wi, wo))
    }

    /// Picks a lobe with Mitsuba's weights, samples it on the front side of the sheet, flips
    /// the result to the side of `wi`, and weights by eval / pdf of the whole mixture.
    fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        let cos_i = si.wi.z;
        if cos_i == 0.0 {
            return None;
        }
        let q = self.at(si.uv);
        let wi = mulsign(si.wi, cos_i);
        let [p_sr, p_st, p_dr, _] = self.lobe_probabilities(&q);
        let (wo, sampled) = if self.has_spec_trans && sample1 < p_sr {
            let (m, _) = q.reflect_distr.sample(wi, sample2);
            let wo = reflect_about(wi, m);
            let ok = compatible(m, wi, wo, wi.z, true) && wo.z > 0.0;
            ok.then_some((wo, BsdfFlags::GLOSSY_REFLECTION))?
        } else if self.has_spec_trans && sample1 < p_sr + p_st {
            let (m, _) = q.trans_distr.sample(wi, sample2);
            let r = reflect_about(wi, m);
            let wo = Vec3::new(r.x, r.y, -r.z);
            let ok = compatible(m, wi, wo, wi.z, false) && wo.z < 0.0;
            ok.then_some((wo, BsdfFlags::GLOSSY_TRANSMISSION))?
        } else if sample1 < p_sr + p_st + p_dr {
            let wo = warp::square_to_cosine_hemisphere(sample2);
            (wo, BsdfFlags::DIFFUSE_REFLECTION)
        } else if self.has_diff_trans {
            let wo = -warp::square_to_cosine_hemisphere(sample2);
            (wo, BsdfFlags::DIFFUSE_TRANSMISSION)
        } else {
            return None;
        };
        let wo = mulsign(wo, cos_i);
        let pdf = self.pdf_at(&q, si.wi, wo);
        if !(pdf > 0.0) {
            return None;
        }
        let weight = self.eval_at(&q, si.wi, wo) / pdf;
        let bs = BsdfSample {
            wo,
            pdf,
            eta: 1.0,
            sampled,
        };
        weight.is_finite().then_some((bs, weight))
    }
}
