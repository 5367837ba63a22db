//! The pieces Mitsuba 3's `principled` and `principledthin` share (its `principledhelpers.h`,
//! after Burley's "Physically Based Shading at Disney"): Schlick Fresnel terms, the isotropic
//! GTR1 distribution of the clearcoat with its separable GGX masking, the Disney roughness to
//! GGX α mapping, and the macro/micro-surface orientation test.

use crate::math::color::luminance;
use crate::math::{Spectrum, Vec2, Vec3};
use std::f32::consts::PI;

/// −v if the sign bit of `s` is set (Mitsuba `mulsign`).
#[inline]
pub fn mulsign(v: Vec3, s: f32) -> Vec3 {
    if s.is_sign_negative() { -v } else { v }
}

/// (1 − cos)⁵ with cos clamped to [0, 1]: Schlick's Fresnel weight.
#[inline]
pub fn schlick_weight(cos_i: f32) -> f32 {
    let m = (1.0 - cos_i).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// Schlick's approximation R0 + (1 − R0)·w, with w from the transmitted angle when the ray
/// travels into the optically thinner side (η_it < 1), as Mitsuba's `calc_schlick`.
#[inline]
pub fn calc_schlick(r0: Spectrum, cos_theta_i: f32, eta: f32) -> Spectrum {
    let outside = cos_theta_i >= 0.0;
    let eta_it = if outside { eta } else { 1.0 / eta };
    let eta_ti = if outside { 1.0 / eta } else { eta };
    let w = if eta_it > 1.0 {
        schlick_weight(cos_theta_i.abs())
    } else {
        let cos_t_sqr = 1.0 - (1.0 - cos_theta_i * cos_theta_i) * (eta_ti * eta_ti);
        schlick_weight(cos_t_sqr.max(0.0).sqrt())
    };
    Spectrum::splat(w) + r0 * (1.0 - w)
}

/// Normal-incidence reflectance ((η − 1)/(η + 1))² of a dielectric.
#[inline]
pub fn schlick_r0(eta: f32) -> f32 {
    ((eta - 1.0) / (eta + 1.0)).powi(2)
}

/// The base colour normalised by its luminance (white if black): the hue of the tints.
#[inline]
pub fn tint(base_color: Spectrum) -> Spectrum {
    let lum = luminance(base_color);
    if lum > 0.0 {
        base_color / lum
    } else {
        Spectrum::ONE
    }
}

/// GGX (α_x, α_y) from Disney roughness and anisotropy, each at least 0.001.
#[inline]
pub fn dist_params(anisotropic: f32, roughness: f32) -> (f32, f32) {
    let r2 = roughness * roughness;
    let aspect = (1.0 - 0.9 * anisotropic).sqrt();
    ((r2 / aspect).max(0.001), (r2 * aspect).max(0.001))
}

/// The clearcoat's GTR1 α for a `clearcoat_gloss`: lerp(0.1, 0.001, gloss).
#[inline]
pub fn gtr1_alpha(gloss: f32) -> f32 {
    0.1 + gloss * (0.001 - 0.1)
}

/// GTR1 D(m) (per unit projected microsurface area); 0 where D cos θ_m is negligible.
#[inline]
pub fn gtr1_eval(m: Vec3, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let r = (a2 - 1.0) / (PI * a2.ln() * (1.0 + (a2 - 1.0) * m.z * m.z));
    if r * m.z > 1e-20 { r } else { 0.0 }
}

/// Density D(m) cos θ_m of [`gtr1_sample`].
#[inline]
pub fn gtr1_pdf(m: Vec3, alpha: f32) -> f32 {
    if m.z < 0.0 {
        0.0
    } else {
        m.z * gtr1_eval(m, alpha)
    }
}

/// A GTR1 normal by inversion of its cos θ_m distribution.
#[inline]
pub fn gtr1_sample(u: Vec2, alpha: f32) -> Vec3 {
    let (sin_phi, cos_phi) = (2.0 * PI * u.x).sin_cos();
    let a2 = alpha * alpha;
    let cos2 = (1.0 - a2.powf(1.0 - u.y)) / (1.0 - a2);
    let sin_t = (1.0 - cos2).max(0.0).sqrt();
    let cos_t = cos2.max(0.0).sqrt();
    Vec3::new(cos_phi * sin_t, sin_phi * sin_t, cos_t)
}

/// Smith's GGX masking of direction `v` for the clearcoat (isotropic α), 0 on a back-facing
/// microfacet.
#[inline]
pub fn smith_ggx1(v: Vec3, wh: Vec3, alpha: f32) -> f32 {
    let cos = v.z.abs();
    let tan2 = (1.0 - cos * cos) / (cos * cos);
    let mut r = 2.0 / (1.0 + (1.0 + alpha * alpha * tan2).sqrt());
    if v.z == 1.0 {
        r = 1.0;
    }
    if v.dot(wh) * v.z <= 0.0 {
        r = 0.0;
    }
    r
}

/// Whether the microfacet `m` sees `wi` and `wo` on the sides a reflection (or refraction)
/// needs, with `m` flipped to `wi`'s side of the macrosurface.
#[inline]
pub fn compatible(m: Vec3, wi: Vec3, wo: Vec3, cos_theta_i: f32, reflection: bool) -> bool {
    let m = mulsign(m, cos_theta_i);
    wi.dot(m) > 0.0
        && if reflection {
            wo.dot(m) > 0.0
        } else {
            wo.dot(-m) > 0.0
        }
}
