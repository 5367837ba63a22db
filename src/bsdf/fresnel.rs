//! Fresnel equations and mirror/refraction helpers in the local frame (Mitsuba 3 `fresnel.h`).

use crate::math::simd::real::{Real, V3};
use crate::math::{Spectrum, Vec3};

/// Result of the dielectric Fresnel equations for one incident cosine (per lane for [`F16`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FresnelDielectric<T = f32> {
    /// Unpolarised reflectance in [0, 1] (1 under total internal reflection).
    pub r: T,
    /// Signed cosine of the transmitted direction (opposite side of `cos_theta_i`; 0 under TIR).
    pub cos_theta_t: T,
    /// Relative IOR along the direction of travel (η if arriving from outside, 1/η from inside).
    pub eta_it: T,
    /// 1 / `eta_it`: the scale applied to the tangential components when refracting.
    pub eta_ti: T,
}

/// Unpolarised Fresnel reflectance at a dielectric interface of relative IOR `eta` = η_int/η_ext;
/// `cos_theta_i` < 0 means the ray arrives from the inside. Same special cases as Mitsuba:
/// index matched → r = 0, grazing (cos = 0) → r = 1.
#[inline]
pub fn fresnel_dielectric(cos_theta_i: f32, eta: f32) -> FresnelDielectric {
    fresnel_dielectric_t(cos_theta_i, eta)
}

/// [`fresnel_dielectric`] for one lane or sixteen, one relative IOR `eta` for all.
#[inline(always)]
pub fn fresnel_dielectric_t<T: Real>(cos_theta_i: T, eta: f32) -> FresnelDielectric<T> {
    let one = T::splat(1.0);
    let outside = cos_theta_i.ge(T::splat(0.0));
    let rcp_eta = 1.0 / eta;
    let eta_it = T::select(outside, T::splat(eta), T::splat(rcp_eta));
    let eta_ti = T::select(outside, T::splat(rcp_eta), T::splat(eta));

    // Snell: cos²θ_t = 1 − sin²θ_i · (η_i/η_t)².
    let cos_theta_t_sqr = one - (one - cos_theta_i * cos_theta_i) * (eta_ti * eta_ti);
    let cos_i = cos_theta_i.abs();
    let cos_t = cos_theta_t_sqr.max(T::splat(0.0)).sqrt();

    let r = if eta == 1.0 {
        // Index matched.
        T::splat(0.0)
    } else {
        let a_s = (cos_i - eta_it * cos_t) / (cos_i + eta_it * cos_t);
        let a_p = (cos_t - eta_it * cos_i) / (cos_t + eta_it * cos_i);
        let r = (a_s * a_s + a_p * a_p) * 0.5;
        T::select(cos_i.eq(T::splat(0.0)), one, r)
    };

    // The transmitted direction lies on the other side of the interface.
    let cos_theta_t = T::select(outside, -cos_t, cos_t);
    FresnelDielectric {
        r,
        cos_theta_t,
        eta_it,
        eta_ti,
    }
}

/// Unpolarised Fresnel reflectance of a conductor with complex IOR `eta + i k`, light arriving
/// from outside (`cos_theta_i` ≥ 0). `eta = 0, k = 1` gives a perfect mirror (Mitsuba `none`).
#[inline]
pub fn fresnel_conductor(cos_theta_i: f32, eta: f32, k: f32) -> f32 {
    fresnel_conductor_t(cos_theta_i, eta, k)
}

/// [`fresnel_conductor`] for one lane or sixteen.
#[inline(always)]
pub fn fresnel_conductor_t<T: Real>(cos_theta_i: T, eta: T, k: T) -> T {
    // After K. D. Moeller, "Optics" (1988), as used by Mitsuba 3.
    let zero = T::splat(0.0);
    let c2 = cos_theta_i * cos_theta_i;
    let s2 = T::splat(1.0) - c2;
    let s4 = s2 * s2;

    let temp_1 = eta * eta - k * k - s2;
    let a2_pb2 = (temp_1 * temp_1 + T::splat(4.0) * k * k * eta * eta)
        .max(zero)
        .sqrt();
    let a = ((a2_pb2 + temp_1) * 0.5).max(zero).sqrt();

    let term_1 = a2_pb2 + c2;
    let term_2 = T::splat(2.0) * cos_theta_i * a;
    let r_s = (term_1 - term_2) / (term_1 + term_2);

    let term_3 = a2_pb2 * c2 + s4;
    let term_4 = term_2 * s2;
    let r_p = r_s * (term_3 - term_4) / (term_3 + term_4);

    (r_s + r_p) * 0.5
}

/// Per-channel [`fresnel_conductor_t`] for RGB `eta` and `k`, one lane or sixteen.
#[inline(always)]
pub fn fresnel_conductor_rgb_t<T: Real>(cos_theta_i: T, eta: V3<T>, k: V3<T>) -> V3<T> {
    V3::new(
        fresnel_conductor_t(cos_theta_i, eta.x, k.x),
        fresnel_conductor_t(cos_theta_i, eta.y, k.y),
        fresnel_conductor_t(cos_theta_i, eta.z, k.z),
    )
}

/// Per-channel [`fresnel_conductor`] for RGB `eta` and `k`.
#[inline]
pub fn fresnel_conductor_rgb(cos_theta_i: f32, eta: Spectrum, k: Spectrum) -> Spectrum {
    fresnel_conductor_rgb_t(cos_theta_i, eta.into(), k.into()).into()
}

/// Hemispherically averaged (diffuse) Fresnel reflectance of an interface with relative IOR
/// `eta`, Mitsuba 3's fit: Egan & Hilgeman (1973) for η < 1, d'Eon & Irving (2011) above.
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    let inv = 1.0 / eta;
    if eta < 1.0 {
        0.0636 * inv + eta * (eta * -1.4399 + 0.7099) + 0.6681
    } else {
        let (i2, i3) = (inv * inv, inv * inv * inv);
        let (i4, i5) = (i3 * inv, i3 * inv * inv);
        0.919317 - 3.4793 * inv + 6.75335 * i2 - 7.80989 * i3 + 4.98554 * i4 - 1.36881 * i5
    }
}

/// Mirror reflection about the local normal (0, 0, 1).
#[inline]
pub fn reflect(wi: Vec3) -> Vec3 {
    Vec3::new(-wi.x, -wi.y, wi.z)
}

/// Mirror reflection of `wi` about the unit vector `m`.
#[inline]
pub fn reflect_about(wi: Vec3, m: Vec3) -> Vec3 {
    m * (2.0 * wi.dot(m)) - wi
}

/// Refraction through the local interface, with `cos_theta_t`/`eta_ti` from [`fresnel_dielectric`].
#[inline]
pub fn refract(wi: Vec3, cos_theta_t: f32, eta_ti: f32) -> Vec3 {
    Vec3::new(-eta_ti * wi.x, -eta_ti * wi.y, cos_theta_t)
}

/// Refraction of `wi` through the microfacet with unit normal `m` (Mitsuba `refract(wi, m, ...)`),
/// with `cos_theta_t`/`eta_ti` from [`fresnel_dielectric`] at cos = wi·m.
#[inline]
pub fn refract_about(wi: Vec3, m: Vec3, cos_theta_t: f32, eta_ti: f32) -> Vec3 {
    m * (wi.dot(m) * eta_ti + cos_theta_t) - wi * eta_ti
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_normal_incidence_brewster_and_tir() {
        let eta = 1.5f32;
        let f = fresnel_dielectric(1.0, eta);
        let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
        assert!((f.r - r0).abs() < 1e-6, "{} vs {}", f.r, r0);
        assert_eq!(f.cos_theta_t, -1.0);
        assert_eq!((f.eta_it, f.eta_ti), (eta, 1.0 / eta));

        // Brewster angle: p-polarised reflectance vanishes, so r = r_s / 2.
        let theta_b = eta.atan();
        let f = fresnel_dielectric(theta_b.cos(), eta);
        let ci = theta_b.cos();
        let ct = (1.0 - (1.0 - ci * ci) / (eta * eta)).sqrt();
        let rs = ((ci - eta * ct) / (ci + eta * ct)).powi(2);
        assert!((f.r - 0.5 * rs).abs() < 1e-6);

        // From inside beyond the critical angle: total internal reflection.
        let crit = (1.0 / eta).asin();
        let f = fresnel_dielectric(-(crit + 0.05).cos(), eta);
        assert_eq!(f.r, 1.0);
        assert_eq!(f.cos_theta_t, 0.0);
        // Index matched: nothing reflects.
        assert_eq!(fresnel_dielectric(0.3, 1.0).r, 0.0);
    }

    #[test]
    fn dielectric_is_reciprocal_and_refraction_obeys_snell() {
        // Stokes relations: R is the same for the refracted ray travelling back.
        for &eta in &[1.33f32, 1.5, 2.4, 0.7] {
            for i in 1..20 {
                let ci = i as f32 / 20.0;
                let f = fresnel_dielectric(ci, eta);
                if f.r >= 1.0 {
                    continue;
                }
                let back = fresnel_dielectric(f.cos_theta_t, eta);
                assert!((f.r - back.r).abs() < 2e-5, "eta {eta} cos {ci}");
                assert!((back.cos_theta_t - ci).abs() < 2e-5);
                let wi = Vec3::new((1.0 - ci * ci).sqrt(), 0.0, ci);
                let wt = refract(wi, f.cos_theta_t, f.eta_ti);
                assert!((wt.length() - 1.0).abs() < 1e-5);
                // η_i sin θ_i = η_t sin θ_t (η_ext = 1 outside).
                assert!((wi.x - eta * (-wt.x)).abs() < 1e-5);
            }
        }
    }

    #[test]
    fn conductor_limits() {
        // Mitsuba's `none` material (eta 0, k 1) is a perfect mirror at every angle.
        for i in 0..=10 {
            let c = i as f32 / 10.0;
            assert!((fresnel_conductor(c, 0.0, 1.0) - 1.0).abs() < 1e-6);
            // Large extinction → mirror.
            assert!(fresnel_conductor(c.max(0.05), 1.0, 1e3) > 0.999);
        }
        // k = 0 reduces to the dielectric formula.
        for i in 1..=10 {
            let c = i as f32 / 10.0;
            let a = fresnel_conductor(c, 1.5, 0.0);
            let b = fresnel_dielectric(c, 1.5).r;
            assert!((a - b).abs() < 1e-5, "{c}: {a} vs {b}");
        }
        // Normal incidence: ((n−1)² + k²) / ((n+1)² + k²).
        let (n, k) = (0.2f32, 3.9f32);
        let r0 = ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k);
        assert!((fresnel_conductor(1.0, n, k) - r0).abs() < 1e-5);
        // Grazing incidence reflects everything.
        assert!((fresnel_conductor(0.0, n, k) - 1.0).abs() < 1e-5);
    }
}
