//! Microfacet distributions as Mitsuba 3's `MicrofacetDistribution`: Beckmann (its default) and
//! GGX (Trowbridge–Reitz), anisotropic roughness (alpha_u along s = local x, alpha_v along t =
//! local y), Smith's separable shadowing-masking (Beckmann through Mitsuba's rational fit), and
//! either visible-normal sampling (Jakob's numerical inversion for Beckmann, Heitz 2018 for GGX)
//! or sampling D(m) cos θ_m.

use crate::math::simd::lane::sin_cos;
use crate::math::special::{erf, erfinv};
use crate::math::{PI, Vec2, Vec3, warp};

/// Smallest roughness Mitsuba accepts (it clamps, and so do we).
pub const MIN_ALPHA: f32 = 1e-4;

/// 1/√π.
const INV_SQRT_PI: f32 = 0.564_189_6;

/// The normal distribution function (Mitsuba `MicrofacetType`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MicrofacetType {
    /// Gaussian random surfaces; Mitsuba's default when a scene names none.
    Beckmann,
    /// Trowbridge–Reitz: long tails.
    Ggx,
}

impl MicrofacetType {
    /// The distribution named by Mitsuba's `distribution` string (case-insensitive).
    pub fn from_name(name: &str) -> Option<MicrofacetType> {
        match name.to_ascii_lowercase().as_str() {
            "beckmann" => Some(MicrofacetType::Beckmann),
            "ggx" => Some(MicrofacetType::Ggx),
            _ => None,
        }
    }
}

/// A microfacet distribution with its sampling strategy.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    /// Beckmann or GGX.
    pub kind: MicrofacetType,
    /// Roughness along the tangent s (local x).
    pub alpha_u: f32,
    /// Roughness along the bitangent t (local y).
    pub alpha_v: f32,
    /// Sample the distribution of normals visible from `wi` (else D(m) cos θ_m).
    pub sample_visible: bool,
}

impl Microfacet {
    /// A distribution with roughness clamped to [`MIN_ALPHA`] as Mitsuba does.
    pub fn new(kind: MicrofacetType, alpha_u: f32, alpha_v: f32, sample_visible: bool) -> Self {
        Microfacet {
            kind,
            alpha_u: alpha_u.max(MIN_ALPHA),
            alpha_v: alpha_v.max(MIN_ALPHA),
            sample_visible,
        }
    }

    /// True when both roughnesses are equal.
    #[inline]
    pub fn is_isotropic(&self) -> bool {
        self.alpha_u == self.alpha_v
    }

    /// D(m) in 1/sr (per unit projected microsurface area); 0 below the horizon.
    #[inline]
    pub fn eval(&self, m: Vec3) -> f32 {
        let (au, av) = (self.alpha_u, self.alpha_v);
        let result = match self.kind {
            MicrofacetType::Beckmann => {
                let cos_theta_2 = m.z * m.z;
                (-((m.x / au).powi(2) + (m.y / av).powi(2)) / cos_theta_2).exp()
                    / (PI * au * av * cos_theta_2 * cos_theta_2)
            }
            MicrofacetType::Ggx => {
                let t = (m.x / au).powi(2) + (m.y / av).powi(2) + m.z * m.z;
                1.0 / (PI * au * av * t * t)
            }
        };
        // Same guard as Mitsuba against numerical trouble further down the model.
        if result * m.z > 1e-20 { result } else { 0.0 }
    }

    /// Smith's masking for one direction `v` and microfacet normal `m`.
    #[inline]
    pub fn smith_g1(&self, v: Vec3, m: Vec3) -> f32 {
        let xy_alpha_2 = (self.alpha_u * v.x).powi(2) + (self.alpha_v * v.y).powi(2);
        // A microfacet is never seen from its back side.
        if v.dot(m) * v.z <= 0.0 {
            return 0.0;
        }
        if xy_alpha_2 == 0.0 {
            return 1.0;
        }
        let tan_theta_alpha_2 = xy_alpha_2 / (v.z * v.z);
        match self.kind {
            MicrofacetType::Beckmann => {
                // Mitsuba's rational fit of the Beckmann G1 (< 0.35 % relative error).
                let a = 1.0 / tan_theta_alpha_2.sqrt();
                if a >= 1.6 {
                    1.0
                } else {
                    let a_sqr = a * a;
                    (3.535 * a + 2.181 * a_sqr) / (1.0 + 2.276 * a + 2.577 * a_sqr)
                }
            }
            MicrofacetType::Ggx => 2.0 / (1.0 + (1.0 + tan_theta_alpha_2).sqrt()),
        }
    }

    /// Separable shadowing-masking G(wi, wo, m) = G1(wi, m) G1(wo, m).
    #[inline]
    pub fn g(&self, wi: Vec3, wo: Vec3, m: Vec3) -> f32 {
        self.smith_g1(wi, m) * self.smith_g1(wo, m)
    }

    /// Solid-angle density of [`Microfacet::sample`] producing the normal `m`.
    #[inline]
    pub fn pdf(&self, wi: Vec3, m: Vec3) -> f32 {
        let d = self.eval(m);
        if self.sample_visible {
            d * self.smith_g1(wi, m) * wi.dot(m).abs() / wi.z
        } else {
            d * m.z
        }
    }

    /// Samples a microfacet normal for the incident direction `wi` (upper hemisphere) and returns
    /// it with its solid-angle density.
    pub fn sample(&self, wi: Vec3, u: Vec2) -> (Vec3, f32) {
        let (au, av) = (self.alpha_u, self.alpha_v);
        if !self.sample_visible {
            // Azimuth: identical for Beckmann and GGX.
            let (sin_phi, cos_phi, alpha_2) = if self.is_isotropic() {
                let (s, c) = sin_cos(2.0 * PI * u.y);
                (s, c, au * au)
            } else {
                let tmp = (av / au) * (2.0 * PI * u.y).tan();
                let cos_phi = (1.0 / (tmp * tmp + 1.0).sqrt()).copysign((u.y - 0.5).abs() - 0.25);
                let sin_phi = cos_phi * tmp;
                let alpha_2 = 1.0 / ((cos_phi / au).powi(2) + (sin_phi / av).powi(2));
                (sin_phi, cos_phi, alpha_2)
            };
            let (cos_theta, pdf) = match self.kind {
                MicrofacetType::Beckmann => {
                    let cos_theta = 1.0 / (1.0 - alpha_2 * (1.0 - u.x).ln()).sqrt();
                    let cos_theta_3 = (cos_theta * cos_theta * cos_theta).max(1e-20);
                    (cos_theta, (1.0 - u.x) / (PI * au * av * cos_theta_3))
                }
                MicrofacetType::Ggx => {
                    let tan_theta_m_2 = alpha_2 * u.x / (1.0 - u.x);
                    let cos_theta = 1.0 / (1.0 + tan_theta_m_2).sqrt();
                    let temp = 1.0 + tan_theta_m_2 / alpha_2;
                    let cos_theta_3 = (cos_theta * cos_theta * cos_theta).max(1e-20);
                    (cos_theta, 1.0 / (PI * au * av * cos_theta_3 * temp * temp))
                }
            };
            let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
            let m = Vec3::new(cos_phi * sin_theta, sin_phi * sin_theta, cos_theta);
            (m, pdf)
        } else {
            // 1. Stretch wi to the alpha = 1 configuration.
            let wi_p = Vec3::new(au * wi.x, av * wi.y, wi.z).normalize();
            let (sin_phi, cos_phi) = sincos_phi(wi_p);
            let cos_theta = wi_p.z;
            // 2. Sample the slopes of visible normals for alpha = 1.
            let slope = match self.kind {
                MicrofacetType::Beckmann => sample_visible_11_beckmann(cos_theta, u),
                MicrofacetType::Ggx => sample_visible_11_ggx(cos_theta, u),
            };
            // 3. Rotate back and unstretch.
            let sx = (cos_phi * slope.x - sin_phi * slope.y) * au;
            let sy = (sin_phi * slope.x + cos_phi * slope.y) * av;
            // 4. Normal and density.
            let m = Vec3::new(-sx, -sy, 1.0).normalize();
            let pdf = self.eval(m) * self.smith_g1(wi, m) * wi.dot(m).abs() / wi.z;
            (m, pdf)
        }
    }
}

/// (sin φ, cos φ) of a direction, (0, 1) at the pole (Mitsuba `Frame3f::sincos_phi`).
#[inline]
fn sincos_phi(v: Vec3) -> (f32, f32) {
    // x² + y² as Mitsuba's `Frame3f::sin_theta_2`, not 1 − z², which cancels near the pole.
    let sin_theta_2 = v.x.mul_add(v.x, v.y * v.y);
    if sin_theta_2.abs() <= 4.0 * (f32::EPSILON * 0.5) {
        return (0.0, 1.0);
    }
    let inv = 1.0 / sin_theta_2.sqrt();
    ((v.y * inv).clamp(-1.0, 1.0), (v.x * inv).clamp(-1.0, 1.0))
}

/// Beckmann visible-slope sampling for alpha = 1 by Mitsuba's numerical inversion (Jakob 2014,
/// "An improved visible normal sampling routine for the Beckmann distribution"): three Newton
/// steps in the erf domain from the analytic θ_i = π/2 solution.
#[inline]
fn sample_visible_11_beckmann(cos_theta_i: f32, u: Vec2) -> Vec2 {
    let tan_theta_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0).sqrt() / cos_theta_i;
    let cot_theta_i = 1.0 / tan_theta_i;
    // Search interval, parameterised in the erf() domain.
    let maxval = erf(cot_theta_i);
    let u = u.clamp(Vec2::splat(1e-6), Vec2::splat(1.0 - 1e-6));
    let mut x = maxval - (maxval + 1.0) * erf((-u.x.ln()).sqrt());
    // Normalisation of the CDF.
    let ux = u.x * (1.0 + maxval + INV_SQRT_PI * tan_theta_i * (-cot_theta_i * cot_theta_i).exp());
    for _ in 0..3 {
        let slope = erfinv(x);
        let value = 1.0 + x + INV_SQRT_PI * tan_theta_i * (-slope * slope).exp() - ux;
        let derivative = 1.0 - slope * tan_theta_i;
        x -= value / derivative;
    }
    Vec2::new(erfinv(x), erfinv(2.0 * u.y - 1.0))
}

/// GGX visible-slope sampling for alpha = 1 (Heitz 2018, "A simpler and exact sampling routine
/// for the GGX distribution of visible normals"), in Mitsuba's slope formulation.
#[inline]
fn sample_visible_11_ggx(cos_theta_i: f32, u: Vec2) -> Vec2 {
    let mut p = warp::square_to_uniform_disk_concentric(u);
    let s = 0.5 * (1.0 + cos_theta_i);
    let lo = (1.0 - p.x * p.x).max(0.0).sqrt();
    p.y = lo + (p.y - lo) * s;
    let (x, y) = (p.x, p.y);
    let z = (1.0 - p.length_squared()).max(0.0).sqrt();
    let sin_theta_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0).sqrt();
    let norm = 1.0 / (sin_theta_i * y + cos_theta_i * z);
    Vec2::new(cos_theta_i * y - sin_theta_i * z, x) * norm
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::frame::from_spherical;

    const KINDS: [MicrofacetType; 2] = [MicrofacetType::Beckmann, MicrofacetType::Ggx];

    /// ∫ f(ω) dω over the upper hemisphere by the midpoint rule in (cos θ, φ).
    fn integrate_hemisphere(n: usize, f: impl Fn(Vec3) -> f64) -> f64 {
        let mut sum = 0.0;
        let (dz, dphi) = (1.0 / n as f64, 2.0 * std::f64::consts::PI / (2 * n) as f64);
        for i in 0..n {
            let z = (i as f64 + 0.5) * dz;
            for j in 0..2 * n {
                let phi = (j as f64 + 0.5) * dphi;
                let r = (1.0 - z * z).sqrt();
                let v = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
                sum += f(v);
            }
        }
        sum * dz * dphi
    }

    #[test]
    fn projected_area_is_one_and_visible_normals_normalise() {
        for (kind, &(au, av)) in KINDS.iter().flat_map(|k| {
            [(0.3f32, 0.3f32), (0.5, 0.15), (0.8, 0.8)]
                .iter()
                .map(move |a| (*k, a))
        }) {
            let d = Microfacet::new(kind, au, av, true);
            // Beckmann's G1 is Mitsuba's rational fit (< 0.35 % error), GGX's is exact.
            let tol = if kind == MicrofacetType::Beckmann {
                4e-3
            } else {
                3e-3
            };
            let area = integrate_hemisphere(800, |m| d.eval(m) as f64 * m.z as f64);
            assert!(
                (area - 1.0).abs() < 2e-3,
                "{kind:?} alpha {au},{av}: {area}"
            );
            // ∫ G1(wi, m) max(0, wi·m) D(m) dm = cos θ_i (visible projected area).
            for &(theta, phi) in &[(0.3f32, 0.4f32), (1.2, 2.0), (1.5, 4.0)] {
                let wi = from_spherical(theta, phi);
                let vis = integrate_hemisphere(800, |m| {
                    (d.smith_g1(wi, m) * wi.dot(m).max(0.0) * d.eval(m)) as f64
                });
                assert!(
                    (vis - wi.z as f64).abs() < tol * (1.0 + wi.z as f64),
                    "{kind:?} alpha {au},{av} wi {wi}: {vis} vs {}",
                    wi.z
                );
            }
        }
    }

    #[test]
    fn sampled_normals_match_their_pdf() {
        let mut rng = crate::math::Pcg32::new(3, 5);
        for (kind, vis) in KINDS.iter().flat_map(|&k| [(k, true), (k, false)]) {
            for &(au, av) in &[(0.2f32, 0.2f32), (0.6, 0.1)] {
                let d = Microfacet::new(kind, au, av, vis);
                let wi = from_spherical(0.9, 0.7);
                for _ in 0..2000 {
                    let (m, pdf) = d.sample(wi, rng.next_2d());
                    assert!((m.length() - 1.0).abs() < 1e-4 && m.z > 0.0);
                    let p = d.pdf(wi, m);
                    if pdf > 1e-3 {
                        assert!(
                            (p - pdf).abs() <= 1e-3 * pdf,
                            "{kind:?} vis {vis}: {p} vs {pdf}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn alpha_is_clamped_and_normal_incidence_is_unmasked() {
        for kind in KINDS {
            let d = Microfacet::new(kind, 0.0, 0.0, true);
            assert_eq!((d.alpha_u, d.alpha_v), (MIN_ALPHA, MIN_ALPHA));
            let d = Microfacet::new(kind, 0.4, 0.4, true);
            assert_eq!(d.smith_g1(Vec3::Z, Vec3::Z), 1.0);
            // Back-facing microfacet → fully masked.
            let m = Vec3::new(0.8, 0.0, 0.6);
            assert_eq!(d.smith_g1(Vec3::new(-0.8, 0.0, 0.6), m), 0.0);
        }
        assert_eq!(
            MicrofacetType::from_name("BeckMann"),
            Some(MicrofacetType::Beckmann)
        );
        assert_eq!(MicrofacetType::from_name("phong"), None);
    }
}
