//! Disney's principled BSDF as Mitsuba 3 defines it (`principled`, after Burley 2012/2015): a
//! diffuse base with retro-reflection, fake subsurface flattening and sheen, a GGX specular lobe
//! that reflects and (with `spec_trans`) refracts through a dielectric of relative IOR `eta`,
//! a metallic/tinted Schlick Fresnel blend, and a GTR1 clearcoat. Lobes are chosen with
//! Mitsuba's sampling weights; the sample weight is eval / pdf as there. The shared Disney
//! helpers (Schlick terms, GTR1, roughness mapping) live in [`super::principled_lobes`].

use super::fresnel::{fresnel_dielectric, reflect_about, refract_about};
use super::microfacet::{Microfacet, MicrofacetType};
use super::plugin::{BsdfProperties, check_unit_interval};
use super::principled_lobes::{
    calc_schlick, compatible, dist_params, gtr1_alpha, gtr1_eval, gtr1_pdf, gtr1_sample, mulsign,
    schlick_r0, schlick_weight, smith_ggx1, tint,
};
use super::{BsdfFlags, BsdfSample, Bxdf, Texture};
use crate::Result;
use crate::geometry::SurfaceInteraction;
use crate::math::{Spectrum, Vec2, Vec3, warp};
use crate::plugin::Value;

/// Mitsuba's `principled` BSDF. Every weight is a texture read with `eval_1`, `base_color`
/// with `eval`; `eta` is a scalar as in Mitsuba.
#[derive(Clone, Debug)]
pub struct Principled {
    /// Albedo of the diffuse base, tint of transmission (√) and of the metallic Fresnel.
    pub base_color: Texture,
    /// Disney roughness in [0, 1]; GGX α = max(0.001, roughness²) (stretched by `anisotropic`).
    pub roughness: Texture,
    /// Anisotropy of the specular lobes in [0, 1].
    pub anisotropic: Texture,
    /// Blend towards a conductor-like Schlick Fresnel tinted by `base_color`.
    pub metallic: Texture,
    /// Weight of the rough dielectric transmission lobe.
    pub spec_trans: Texture,
    /// Tint of the dielectric specular reflection towards `base_color`.
    pub spec_tint: Texture,
    /// Weight of the retro-reflective sheen.
    pub sheen: Texture,
    /// Tint of the sheen towards `base_color`.
    pub sheen_tint: Texture,
    /// Blend of the diffuse base towards Hanrahan–Krueger-style fake subsurface.
    pub flatness: Texture,
    /// Weight of the GTR1 clearcoat.
    pub clearcoat: Texture,
    /// Clearcoat glossiness: GTR1 α = lerp(0.1, 0.001, gloss).
    pub clearcoat_gloss: Texture,
    /// Relative IOR of the dielectric (interior over exterior).
    pub eta: f32,
    /// A `spec_trans` was given (Mitsuba's `m_has_spec_trans`): the transmission lobe exists
    /// and the back side samples it.
    pub has_spec_trans: bool,
    /// Relative sampling weight of the diffuse lobe (`diffuse_reflectance_sampling_rate`).
    pub diffuse_rate: f32,
    /// Relative sampling weight of the main specular lobes (`main_specular_sampling_rate`).
    pub specular_rate: f32,
    /// Relative sampling weight of the clearcoat (`clearcoat_sampling_rate`).
    pub clearcoat_rate: f32,
}

/// Mitsuba's `get_flag`: a lobe is on when its parameter is given and is not the float 0.
pub(super) fn lobe_flag(p: &dyn BsdfProperties, name: &str) -> bool {
    p.has(name) && !matches!(p.value(name), Some(Value::Float(v)) if *v == 0.0)
}

/// A weight texture (default `default`) that must lie in [0, 1] where it is a constant.
pub(super) fn unit_texture(
    p: &mut dyn BsdfProperties,
    name: &str,
    default: f32,
) -> Result<Texture> {
    let t = p.texture(name, Vec3::splat(default))?;
    check_unit_interval(p, name, &t)?;
    Ok(t)
}

/// A sampling rate: finite and non-negative.
pub(super) fn sampling_rate(p: &dyn BsdfProperties, name: &str) -> Result<f32> {
    let r = p.float(name, 1.0)?;
    if !(r.is_finite() && r >= 0.0) {
        return Err(p.err_at(
            name,
            &format!("\"{name}\" must be finite and >= 0, got {r}"),
        ));
    }
    Ok(r)
}

impl Principled {
    /// Mitsuba's `principled`: `base_color`, `roughness`, `anisotropic`, `metallic`,
    /// `spec_trans`, `eta` or `specular`, `spec_tint`, `sheen`, `sheen_tint`, `flatness`,
    /// `clearcoat`, `clearcoat_gloss` and the three sampling rates. Weights outside [0, 1] (the
    /// range Mitsuba documents), a non-positive `eta` or both `eta` and `specular` are errors.
    pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Self> {
        let has_spec_trans = lobe_flag(p, "spec_trans");
        let eta = if p.has("eta") && p.has("specular") {
            return Err(p.err("give either \"eta\" or \"specular\", not both"));
        } else if p.has("eta") {
            let eta = p.float("eta", 1.5)?;
            if !(eta.is_finite() && eta > 0.0) {
                return Err(p.err_at("eta", &format!("\"eta\" must be positive, got {eta}")));
            }
            // A matched index cannot refract: Mitsuba nudges it.
            if has_spec_trans && eta == 1.0 {
                1.001
            } else {
                eta
            }
        } else {
            let mut specular = p.float("specular", 0.5)?;
            if !(0.0..=1.0).contains(&specular) {
                return Err(p.err_at(
                    "specular",
                    &format!("\"specular\" must lie in [0, 1], got {specular}"),
                ));
            }
            if has_spec_trans && specular == 0.0 {
                specular = 1e-3;
            }
            2.0 / (1.0 - (0.08 * specular).sqrt()) - 1.0
        };
        let specular_rate = sampling_rate(p, "main_specular_sampling_rate")?;
        if specular_rate == 0.0 {
            return Err(p.err_at(
                "main_specular_sampling_rate",
                "\"main_specular_sampling_rate\" must be positive",
            ));
        }
        Ok(Principled {
            base_color: unit_texture(p, "base_color", 0.5)?,
            roughness: unit_texture(p, "roughness", 0.5)?,
            anisotropic: unit_texture(p, "anisotropic", 0.0)?,
            metallic: unit_texture(p, "metallic", 0.0)?,
            spec_trans: unit_texture(p, "spec_trans", 0.0)?,
            spec_tint: unit_texture(p, "spec_tint", 0.0)?,
            sheen: unit_texture(p, "sheen", 0.0)?,
            sheen_tint: unit_texture(p, "sheen_tint", 0.0)?,
            flatness: unit_texture(p, "flatness", 0.0)?,
            clearcoat: unit_texture(p, "clearcoat", 0.0)?,
            clearcoat_gloss: unit_texture(p, "clearcoat_gloss", 0.0)?,
            eta,
            has_spec_trans,
            diffuse_rate: sampling_rate(p, "diffuse_reflectance_sampling_rate")?,
            specular_rate,
            clearcoat_rate: sampling_rate(p, "clearcoat_sampling_rate")?,
        })
    }

    fn textures(&self) -> [&Texture; 11] {
        [
            &self.base_color,
            &self.roughness,
            &self.anisotropic,
            &self.metallic,
            &self.spec_trans,
            &self.spec_tint,
            &self.sheen,
            &self.sheen_tint,
            &self.flatness,
            &self.clearcoat,
            &self.clearcoat_gloss,
        ]
    }

    /// The parameters at `uv`.
    fn at(&self, uv: Vec2) -> Params {
        let metallic = self.metallic.eval_1(uv);
        let spec_trans = self.spec_trans.eval_1(uv);
        let (ax, ay) = dist_params(self.anisotropic.eval_1(uv), self.roughness.eval_1(uv));
        Params {
            base_color: self.base_color.eval(uv),
            roughness: self.roughness.eval_1(uv),
            metallic,
            brdf: (1.0 - metallic) * (1.0 - spec_trans),
            bsdf: (1.0 - metallic) * spec_trans,
            spec_tint: self.spec_tint.eval_1(uv),
            sheen: self.sheen.eval_1(uv),
            sheen_tint: self.sheen_tint.eval_1(uv),
            flatness: self.flatness.eval_1(uv),
            clearcoat: self.clearcoat.eval_1(uv),
            clearcoat_alpha: gtr1_alpha(self.clearcoat_gloss.eval_1(uv)),
            distr: Microfacet::new(MicrofacetType::Ggx, ax, ay, true),
        }
    }

    /// Lobe selection probabilities (diffuse, clearcoat, transmission, reflection), normalised,
    /// given the dielectric Fresnel reflectance `f` at the microfacet normal.
    fn lobe_probabilities(&self, q: &Params, front: bool, f: f32) -> [f32; 4] {
        let s = self.specular_rate;
        let (p_refl, p_trans, p_cc, p_diff) = if front {
            (
                s * (1.0 - q.bsdf * (1.0 - f)),
                if self.has_spec_trans {
                    s * q.bsdf * (1.0 - f)
                } else {
                    0.0
                },
                0.25 * q.clearcoat * self.clearcoat_rate,
                q.brdf * self.diffuse_rate,
            )
        } else {
            let t = if self.has_spec_trans { 1.0 - f } else { 0.0 };
            (f, t, 0.0, 0.0)
        };
        let rcp = 1.0 / (p_refl + p_trans + p_cc + p_diff);
        [p_diff * rcp, p_cc * rcp, p_trans * rcp, p_refl * rcp]
    }

    /// The half vector of `wi` and `wo` (generalised for refraction), pointing outwards.
    fn half_vector(&self, wi: Vec3, wo: Vec3) -> Vec3 {
        let reflect = wi.z * wo.z > 0.0;
        let eta_path = if wi.z > 0.0 { self.eta } else { 1.0 / self.eta };
        let wh = (wi + wo * if reflect { 1.0 } else { eta_path }).normalize();
        mulsign(wh, wh.z)
    }

    /// f · |cos θ_o| with the parameters `q`.
    fn eval_at(&self, q: &Params, wi: Vec3, wo: Vec3) -> Spectrum {
        let (cos_i, cos_o) = (wi.z, wo.z);
        if cos_i == 0.0 {
            return Spectrum::ZERO;
        }
        let reflect = cos_i * cos_o > 0.0;
        let refract = cos_i * cos_o < 0.0;
        let front = cos_i > 0.0;
        let eta_path = if front { self.eta } else { 1.0 / self.eta };
        let inv_eta_path = if front { 1.0 / self.eta } else { self.eta };
        let wh = self.half_vector(wi, wo);
        let f = fresnel_dielectric(wi.dot(wh), self.eta).r;
        let refl_ok = reflect && compatible(wh, wi, wo, cos_i, true);
        let d = q.distr.eval(wh);
        let g = q.distr.g(wi, wo, wh);
        let mut value = Spectrum::ZERO;

        if refl_ok && f > 0.0 {
            let fp = self.fresnel(q, f, wi.dot(wh), front);
            value += fp * (d * g / (4.0 * cos_i.abs()));
        }
        if self.has_spec_trans
            && q.bsdf > 0.0
            && refract
            && compatible(wh, wi, wo, cos_i, false)
            && f < 1.0
        {
            let (dwi, dwo) = (wi.dot(wh), wo.dot(wh));
            let scale = inv_eta_path * inv_eta_path;
            let denom = dwi + eta_path * dwo;
            let t = (scale * (1.0 - f) * d * g * eta_path * eta_path * dwi * dwo)
                / (cos_i * denom * denom);
            value += q.base_color.map(f32::sqrt) * (q.bsdf * t.abs());
        }
        if q.clearcoat > 0.0 && refl_ok && front {
            let fcc = calc_schlick(Spectrum::splat(0.04), wi.dot(wh), self.eta).x;
            let dcc = gtr1_eval(wh, q.clearcoat_alpha);
            let gcc = smith_ggx1(wi, wh, 0.25) * smith_ggx1(wo, wh, 0.25);
            value += Spectrum::splat(q.clearcoat * 0.25 * fcc * dcc * gcc * cos_o.abs());
        }
        if q.brdf > 0.0 && reflect && front {
            let (ao, ai) = (cos_o.abs(), cos_i.abs());
            let (fo, fi) = (schlick_weight(ao), schlick_weight(ai));
            let f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
            let cos_d = wh.dot(wo);
            let rr = 2.0 * q.roughness * cos_d * cos_d;
            let f_retro = rr * (fo + fi + fo * fi * (rr - 1.0));
            let fss90 = rr / 2.0;
            let fss = lerp(1.0, fss90, fo) * lerp(1.0, fss90, fi);
            let f_ss = 1.25 * (fss * (1.0 / (ao + ai) - 0.5) + 0.5);
            let lobe = lerp(f_diff + f_retro, f_ss, q.flatness);
            value += q.base_color * (q.brdf * ao * std::f32::consts::FRAC_1_PI * lobe);
            if q.sheen > 0.0 && 1.0 - q.metallic > 0.0 {
                let fd = schlick_weight(cos_d.abs());
                let c_sheen = Spectrum::ONE.lerp(tint(q.base_color), q.sheen_tint);
                value += c_sheen * (q.sheen * (1.0 - q.metallic) * fd * ao);
            }
        }
        value
    }

    /// Mitsuba's `principled_fresnel`: on the front side a blend of the dielectric reflectance
    /// `f`, a metallic Schlick term tinted by the base colour and a `spec_tint`ed dielectric
    /// Schlick term; on the back side the dielectric alone, weighted by the transmission lobe.
    fn fresnel(&self, q: &Params, f: f32, cos_i_m: f32, front: bool) -> Spectrum {
        if !front {
            return Spectrum::splat(q.bsdf * f);
        }
        let eta_it = if cos_i_m >= 0.0 {
            self.eta
        } else {
            1.0 / self.eta
        };
        let metal = calc_schlick(q.base_color, cos_i_m, self.eta) * q.metallic;
        let r0 = schlick_r0(eta_it);
        let tinted = calc_schlick(tint(q.base_color) * r0, cos_i_m, self.eta)
            * ((1.0 - q.metallic) * q.spec_tint);
        Spectrum::splat((1.0 - q.metallic) * (1.0 - q.spec_tint) * f) + (metal + tinted)
    }

    /// Density of [`Bxdf::sample`] with the parameters `q`.
    fn pdf_at(&self, q: &Params, wi: Vec3, wo: Vec3) -> f32 {
        let cos_i = wi.z;
        if cos_i == 0.0 {
            return 0.0;
        }
        let front = cos_i > 0.0;
        let eta_path = if front { self.eta } else { 1.0 / self.eta };
        let reflect = cos_i * wo.z > 0.0;
        let refract = cos_i * wo.z < 0.0;
        let wh = self.half_vector(wi, wo);
        let f = fresnel_dielectric(wi.dot(wh), self.eta).r;
        let [p_diff, p_cc, p_trans, p_refl] = self.lobe_probabilities(q, front, f);
        let (dwi, dwo) = (wi.dot(wh), wo.dot(wh));
        let dwh_dwo = if reflect || !self.has_spec_trans {
            1.0 / (4.0 * dwo)
        } else {
            eta_path * eta_path * dwo / ((dwi + eta_path * dwo) * (dwi + eta_path * dwo))
        }
        .abs();
        let mut pdf = 0.0;
        let wi_up = mulsign(wi, cos_i);
        let refl_ok = reflect && compatible(wh, wi, wo, cos_i, true);
        if refl_ok {
            pdf += p_refl * q.distr.pdf(wi_up, wh) * dwh_dwo;
            pdf += p_cc * gtr1_pdf(wh, q.clearcoat_alpha) * dwh_dwo;
        }
        if reflect {
            pdf += p_diff * warp::square_to_cosine_hemisphere_pdf(wo);
        }
        if self.has_spec_trans && refract && compatible(wh, wi, wo, cos_i, false) {
            pdf += p_trans * q.distr.pdf(wi_up, wh) * dwh_dwo;
        }
        pdf
    }
}

/// a + t (b − a).
#[inline]
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + t * (b - a)
}

/// A principled material's parameters at one hit.
struct Params {
    base_color: Spectrum,
    roughness: f32,
    metallic: f32,
    /// Weight of the opaque (diffuse + sheen) part: (1 − metallic)(1 − spec_trans).
    brdf: f32,
    /// Weight of the transmissive part: (1 − metallic) spec_trans.
    bsdf: f32,
    spec_tint: f32,
    sheen: f32,
    sheen_tint: f32,
    flatness: f32,
    clearcoat: f32,
    clearcoat_alpha: f32,
    distr: Microfacet,
}

impl Bxdf for Principled {
    /// Diffuse and glossy reflection, glossy transmission when `spec_trans` is given.
    fn flags(&self) -> BsdfFlags {
        let mut f = BsdfFlags::DIFFUSE_REFLECTION | BsdfFlags::GLOSSY_REFLECTION;
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

    /// Picks a lobe with Mitsuba's weights (one GGX normal drawn first decides the dielectric
    /// split), samples it with `sample2`, and weights by eval / pdf of the whole mixture.
    fn sample(
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
        let q = self.at(si.uv);
        let front = cos_i > 0.0;
        if !(front || q.bsdf > 0.0) {
            return None;
        }
        let (m, _) = q.distr.sample(mulsign(wi, cos_i), sample2);
        let fr = fresnel_dielectric(wi.dot(m), self.eta);
        let [p_diff, p_cc, p_trans, _] = self.lobe_probabilities(&q, front, fr.r);
        let (wo, sampled, eta) = if sample1 < p_diff {
            let wo = warp::square_to_cosine_hemisphere(sample2);
            (cos_i * wo.z > 0.0).then_some((wo, BsdfFlags::DIFFUSE_REFLECTION, 1.0))?
        } else if sample1 < p_diff + p_cc {
            let m_cc = gtr1_sample(sample2, q.clearcoat_alpha);
            let wo = reflect_about(wi, m_cc);
            let ok = compatible(m_cc, wi, wo, cos_i, true) && cos_i * wo.z > 0.0;
            ok.then_some((wo, BsdfFlags::GLOSSY_REFLECTION, 1.0))?
        } else if sample1 < p_diff + p_cc + p_trans {
            let wo = refract_about(wi, m, fr.cos_theta_t, fr.eta_ti);
            let ok = compatible(m, wi, wo, cos_i, false) && cos_i * wo.z < 0.0;
            ok.then_some((wo, BsdfFlags::GLOSSY_TRANSMISSION, fr.eta_it))?
        } else {
            let wo = reflect_about(wi, m);
            let ok = compatible(m, wi, wo, cos_i, true) && cos_i * wo.z > 0.0;
            ok.then_some((wo, BsdfFlags::GLOSSY_REFLECTION, 1.0))?
        };
        let pdf = self.pdf_at(&q, wi, wo);
        if !(pdf > 0.0) {
            return None;
        }
        let weight = self.eval_at(&q, wi, wo) / pdf;
        let bs = BsdfSample {
            wo,
            pdf,
            eta,
            sampled,
        };
        weight.is_finite().then_some((bs, weight))
    }
}
