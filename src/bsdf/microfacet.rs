//! Microfacet distributions as Mitsuba 3's `MicrofacetDistribution`: Beckmann (its default) and
//! GGX (Trowbridge–Reitz), anisotropic roughness (alpha_u along s = local x, alpha_v along t =
//! local y), Smith's separable shadowing-masking (Beckmann through Mitsuba's rational fit), and
//! either visible-normal sampling (Jakob's numerical inversion for Beckmann, Heitz 2018 for GGX)
//! or sampling D(m) cos θ_m. Written once for one lane or sixteen ([`Real`]); [`F16`] is the
//! 16-lane type.

use super::{BsdfProperties, Texture};
use crate::Result;
use crate::math::cie1931::SpectrumUse;
use crate::math::simd::real::{Real, V2, V3};
use crate::math::special::{erf, erfinv};
use crate::math::{PI, Vec2, Vec3, warp};
use crate::plugin::Properties;

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

    /// The `distribution` property of a microfacet BSDF: Mitsuba's default `beckmann` when
    /// none is given.
    pub fn from_props(p: &dyn Properties) -> Result<MicrofacetType> {
        match p.string_opt("distribution")? {
            None => Ok(MicrofacetType::Beckmann),
            Some(d) => MicrofacetType::from_name(&d).ok_or_else(|| {
                p.err(&format!(
                    "invalid distribution \"{d}\": must be \"beckmann\" or \"ggx\""
                ))
            }),
        }
    }
}

/// `alpha` or `alpha_u`/`alpha_v` of roughconductor and roughdielectric: floats or textures
/// (Mitsuba 3.9.1's `get_unbounded_texture`, read with `eval_1` at the hit). A constant must
/// be finite and non-negative.
pub fn roughness(p: &mut dyn BsdfProperties) -> Result<(Texture, Texture)> {
    const U: SpectrumUse = SpectrumUse::Unbounded;
    let (alpha_u, alpha_v) = if p.has("alpha_u") || p.has("alpha_v") {
        if p.has("alpha") {
            return Err(p.err("specify either \"alpha\" or \"alpha_u\"/\"alpha_v\", not both"));
        }
        if !(p.has("alpha_u") && p.has("alpha_v")) {
            return Err(p.err("both \"alpha_u\" and \"alpha_v\" must be specified"));
        }
        (
            p.texture_as("alpha_u", Vec3::splat(0.1), U)?,
            p.texture_as("alpha_v", Vec3::splat(0.1), U)?,
        )
    } else {
        let a = p.texture_as("alpha", Vec3::splat(0.1), U)?;
        (a.clone(), a)
    };
    for (name, t) in [("alpha_u", &alpha_u), ("alpha_v", &alpha_v)] {
        if let Texture::Constant(c) = t {
            for v in [c.x, c.y, c.z] {
                check_alpha(p, name, v)?;
            }
        }
    }
    Ok((alpha_u, alpha_v))
}

/// A roughness must be finite and non-negative (0 is clamped to 1e-4, as Mitsuba).
pub fn check_alpha(p: &dyn Properties, name: &str, alpha: f32) -> Result<()> {
    if alpha.is_finite() && alpha >= 0.0 {
        Ok(())
    } else {
        Err(p.err(&format!(
            "\"{name}\" must be a non-negative roughness, got {alpha}"
        )))
    }
}

/// A microfacet distribution with its sampling strategy; `T` is `f32`, or [`F16`] for 16 lanes
/// of one kind with per-lane roughness (the SoA twins run the scalar code's operations).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet<T = f32> {
    /// Beckmann or GGX.
    pub kind: MicrofacetType,
    /// Roughness along the tangent s (local x).
    pub alpha_u: T,
    /// Roughness along the bitangent t (local y).
    pub alpha_v: T,
    /// Sample the distribution of normals visible from `wi` (else D(m) cos θ_m).
    pub sample_visible: bool,
}

impl Microfacet {
    /// A distribution with roughness clamped to [`MIN_ALPHA`] as Mitsuba does.
    pub fn new(kind: MicrofacetType, alpha_u: f32, alpha_v: f32, sample_visible: bool) -> Self {
        Microfacet::new_t(kind, alpha_u, alpha_v, sample_visible)
    }

    /// True when both roughnesses are equal.
    #[inline]
    pub fn is_isotropic(&self) -> bool {
        self.alpha_u == self.alpha_v
    }

    /// D(m) in 1/sr (per unit projected microsurface area); 0 below the horizon.
    #[inline]
    pub fn eval(&self, m: Vec3) -> f32 {
        self.eval_t(m.into())
    }

    /// Smith's masking for one direction `v` and microfacet normal `m`.
    #[inline]
    pub fn smith_g1(&self, v: Vec3, m: Vec3) -> f32 {
        self.smith_g1_t(v.into(), m.into())
    }

    /// Separable shadowing-masking G(wi, wo, m) = G1(wi, m) G1(wo, m).
    #[inline]
    pub fn g(&self, wi: Vec3, wo: Vec3, m: Vec3) -> f32 {
        self.g_t(wi.into(), wo.into(), m.into())
    }

    /// Solid-angle density of [`Microfacet::sample`] producing the normal `m`.
    #[inline]
    pub fn pdf(&self, wi: Vec3, m: Vec3) -> f32 {
        self.pdf_t(wi.into(), m.into())
    }

    /// Samples a microfacet normal for the incident direction `wi` (upper hemisphere) and returns
    /// it with its solid-angle density.
    pub fn sample(&self, wi: Vec3, u: Vec2) -> (Vec3, f32) {
        let (m, pdf) = self.sample_t(wi.into(), u.into());
        (m.into(), pdf)
    }
}

/// x².
#[inline(always)]
fn sq<T: Real>(x: T) -> T {
    x * x
}

impl<T: Real> Microfacet<T> {
    /// [`Microfacet::new`] for one lane or sixteen.
    #[inline(always)]
    pub fn new_t(kind: MicrofacetType, alpha_u: T, alpha_v: T, sample_visible: bool) -> Self {
        Microfacet {
            kind,
            alpha_u: alpha_u.max(T::splat(MIN_ALPHA)),
            alpha_v: alpha_v.max(T::splat(MIN_ALPHA)),
            sample_visible,
        }
    }

    /// [`Microfacet::eval`] for one lane or sixteen.
    #[inline(always)]
    pub fn eval_t(&self, m: V3<T>) -> T {
        let (au, av) = (self.alpha_u, self.alpha_v);
        let result = match self.kind {
            MicrofacetType::Beckmann => {
                let cos_theta_2 = m.z * m.z;
                (-(sq(m.x / au) + sq(m.y / av)) / cos_theta_2).exp()
                    / (au * PI * av * cos_theta_2 * cos_theta_2)
            }
            MicrofacetType::Ggx => {
                let t = sq(m.x / au) + sq(m.y / av) + m.z * m.z;
                T::splat(1.0) / (au * PI * av * t * t)
            }
        };
        // Same guard as Mitsuba against numerical trouble further down the model.
        T::select((result * m.z).gt(T::splat(1e-20)), result, T::splat(0.0))
    }

    /// [`Microfacet::smith_g1`] for one lane or sixteen.
    #[inline(always)]
    pub fn smith_g1_t(&self, v: V3<T>, m: V3<T>) -> T {
        let one = T::splat(1.0);
        let xy_alpha_2 = sq(self.alpha_u * v.x) + sq(self.alpha_v * v.y);
        let tan_theta_alpha_2 = xy_alpha_2 / (v.z * v.z);
        let g = match self.kind {
            MicrofacetType::Beckmann => {
                // Mitsuba's rational fit of the Beckmann G1 (< 0.35 % relative error).
                let a = one / tan_theta_alpha_2.sqrt();
                let a_sqr = a * a;
                let fit = (a * 3.535 + a_sqr * 2.181) / (one + a * 2.276 + a_sqr * 2.577);
                T::select(a.ge(T::splat(1.6)), one, fit)
            }
            MicrofacetType::Ggx => T::splat(2.0) / (one + (one + tan_theta_alpha_2).sqrt()),
        };
        let g = T::select(xy_alpha_2.eq(T::splat(0.0)), one, g);
        // A microfacet is never seen from its back side.
        T::select((v.dot(m) * v.z).le(T::splat(0.0)), T::splat(0.0), g)
    }

    /// [`Microfacet::g`] for one lane or sixteen.
    #[inline(always)]
    pub fn g_t(&self, wi: V3<T>, wo: V3<T>, m: V3<T>) -> T {
        self.smith_g1_t(wi, m) * self.smith_g1_t(wo, m)
    }

    /// [`Microfacet::pdf`] for one lane or sixteen.
    #[inline(always)]
    pub fn pdf_t(&self, wi: V3<T>, m: V3<T>) -> T {
        let d = self.eval_t(m);
        if self.sample_visible {
            d * self.smith_g1_t(wi, m) * wi.dot(m).abs() / wi.z
        } else {
            d * m.z
        }
    }

    /// [`Microfacet::sample`] for one lane or sixteen.
    #[inline(always)]
    pub fn sample_t(&self, wi: V3<T>, u: V2<T>) -> (V3<T>, T) {
        let (au, av) = (self.alpha_u, self.alpha_v);
        let one = T::splat(1.0);
        if !self.sample_visible {
            // Azimuth: identical for Beckmann and GGX.
            let (s, c) = (u.y * (2.0 * PI)).sin_cos();
            let tmp = (av / au) * (u.y * (2.0 * PI)).tan();
            let cos_a = (one / (tmp * tmp + one).sqrt()).copysign((u.y - 0.5).abs() - 0.25);
            let sin_a = cos_a * tmp;
            let alpha_2_a = one / (sq(cos_a / au) + sq(sin_a / av));
            let iso = au.eq(av);
            let sin_phi = T::select(iso, s, sin_a);
            let cos_phi = T::select(iso, c, cos_a);
            let alpha_2 = T::select(iso, au * au, alpha_2_a);
            let (cos_theta, pdf) = match self.kind {
                MicrofacetType::Beckmann => {
                    let cos_theta = one / (one - alpha_2 * (one - u.x).ln()).sqrt();
                    let cos_theta_3 = (cos_theta * cos_theta * cos_theta).max(T::splat(1e-20));
                    (cos_theta, (one - u.x) / (au * PI * av * cos_theta_3))
                }
                MicrofacetType::Ggx => {
                    let tan_theta_m_2 = alpha_2 * u.x / (one - u.x);
                    let cos_theta = one / (one + tan_theta_m_2).sqrt();
                    let temp = one + tan_theta_m_2 / alpha_2;
                    let cos_theta_3 = (cos_theta * cos_theta * cos_theta).max(T::splat(1e-20));
                    (cos_theta, one / (au * PI * av * cos_theta_3 * temp * temp))
                }
            };
            let sin_theta = (one - cos_theta * cos_theta).max(T::splat(0.0)).sqrt();
            let m = V3::new(cos_phi * sin_theta, sin_phi * sin_theta, cos_theta);
            (m, pdf)
        } else {
            // 1. Stretch wi to the alpha = 1 configuration.
            let wi_p = V3::new(au * wi.x, av * wi.y, wi.z).normalize();
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
            let m = V3::new(-sx, -sy, one).normalize();
            let pdf = self.eval_t(m) * self.smith_g1_t(wi, m) * wi.dot(m).abs() / wi.z;
            (m, pdf)
        }
    }
}

/// (sin φ, cos φ) of a direction, (0, 1) at the pole (Mitsuba `Frame3f::sincos_phi`).
#[inline(always)]
fn sincos_phi<T: Real>(v: V3<T>) -> (T, T) {
    // x² + y² as Mitsuba's `Frame3f::sin_theta_2`, not 1 − z², which cancels near the pole.
    let sin_theta_2 = v.x.mul_add(v.x, v.y * v.y);
    let pole = sin_theta_2.abs().le(T::splat(4.0 * (f32::EPSILON * 0.5)));
    let inv = T::splat(1.0) / sin_theta_2.sqrt();
    (
        T::select(pole, T::splat(0.0), (v.y * inv).clamp(-1.0, 1.0)),
        T::select(pole, T::splat(1.0), (v.x * inv).clamp(-1.0, 1.0)),
    )
}

/// Beckmann visible-slope sampling for alpha = 1 by Mitsuba's numerical inversion (Jakob 2014,
/// "An improved visible normal sampling routine for the Beckmann distribution"): three Newton
/// steps in the erf domain from the analytic θ_i = π/2 solution.
#[inline(always)]
fn sample_visible_11_beckmann<T: Real>(cos_theta_i: T, u: V2<T>) -> V2<T> {
    let one = T::splat(1.0);
    let tan_theta_i = (one - cos_theta_i * cos_theta_i).max(T::splat(0.0)).sqrt() / cos_theta_i;
    let cot_theta_i = one / tan_theta_i;
    // Search interval, parameterised in the erf() domain.
    let maxval = cot_theta_i.map(erf);
    // glam's `Vec2::clamp`: max, then min.
    let clamp = |x: T| {
        let (lo, hi) = (T::splat(1e-6), T::splat(1.0 - 1e-6));
        let x = T::select(x.gt(lo), x, lo);
        T::select(x.lt(hi), x, hi)
    };
    let u = V2::new(clamp(u.x), clamp(u.y));
    let mut x = maxval - (maxval + one) * (-u.x.ln()).sqrt().map(erf);
    // Normalisation of the CDF.
    let ux =
        u.x * (one + maxval + tan_theta_i * INV_SQRT_PI * ((-cot_theta_i) * cot_theta_i).exp());
    for _ in 0..3 {
        let slope = x.map(erfinv);
        let value = one + x + tan_theta_i * INV_SQRT_PI * ((-slope) * slope).exp() - ux;
        let derivative = one - slope * tan_theta_i;
        x = x - value / derivative;
    }
    V2::new(x.map(erfinv), (u.y * 2.0 - 1.0).map(erfinv))
}

/// GGX visible-slope sampling for alpha = 1 (Heitz 2018, "A simpler and exact sampling routine
/// for the GGX distribution of visible normals"), in Mitsuba's slope formulation.
#[inline(always)]
fn sample_visible_11_ggx<T: Real>(cos_theta_i: T, u: V2<T>) -> V2<T> {
    let one = T::splat(1.0);
    let zero = T::splat(0.0);
    let mut p = warp::square_to_uniform_disk_concentric_t(u);
    let s = (one + cos_theta_i) * 0.5;
    let lo = (one - p.x * p.x).max(zero).sqrt();
    p.y = lo + (p.y - lo) * s;
    let (x, y) = (p.x, p.y);
    let z = (one - p.length_squared()).max(zero).sqrt();
    let sin_theta_i = (one - cos_theta_i * cos_theta_i).max(zero).sqrt();
    let norm = one / (sin_theta_i * y + cos_theta_i * z);
    V2::new(cos_theta_i * y - sin_theta_i * z, x).scale(norm)
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
