//! Warps from the unit square to sampling domains, with their pdfs (Mitsuba 3 `warp` conventions).

use super::{INV_FOUR_PI, INV_PI, INV_TWO_PI, PI};
use crate::math::simd::approx::sin_cos;
use crate::math::simd::f16::{F16, V2x, V3x};
use crate::math::simd::real::{Cond, Real, V2, V3};
use glam::{Vec2, Vec3};

/// Concentric (Shirley–Chiu) map to the unit disk: low distortion, continuous.
#[inline]
pub fn square_to_uniform_disk_concentric(u: Vec2) -> Vec2 {
    square_to_uniform_disk_concentric_t(u.into()).into()
}

/// [`square_to_uniform_disk_concentric`] for one lane or sixteen.
#[inline(always)]
pub fn square_to_uniform_disk_concentric_t<T: Real>(u: V2<T>) -> V2<T> {
    let zero = T::splat(0.0);
    let a = u.x * 2.0 - 1.0;
    let b = u.y * 2.0 - 1.0;
    let center = a.eq(zero).and(b.eq(zero));
    let first = (a * a).gt(b * b);
    let r = T::select(first, a, b);
    let phi = T::select(
        first,
        (b / a) * (PI / 4.0),
        T::splat(PI / 2.0) - (a / b) * (PI / 4.0),
    );
    let (s, c) = phi.sin_cos();
    V2::new(
        T::select(center, zero, r * c),
        T::select(center, zero, r * s),
    )
}

/// Cosine-weighted hemisphere around +z (Malley's method).
#[inline]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    square_to_cosine_hemisphere_t(u.into()).into()
}

/// [`square_to_cosine_hemisphere`] for one lane or sixteen.
#[inline(always)]
pub fn square_to_cosine_hemisphere_t<T: Real>(u: V2<T>) -> V3<T> {
    let d = square_to_uniform_disk_concentric_t(u);
    let z = (T::splat(1.0) - d.length_squared())
        .max(T::splat(0.0))
        .sqrt();
    V3::new(d.x, d.y, z)
}

/// Solid-angle pdf of [`square_to_cosine_hemisphere`].
#[inline]
pub fn square_to_cosine_hemisphere_pdf(v: Vec3) -> f32 {
    if v.z > 0.0 { v.z * INV_PI } else { 0.0 }
}

/// Uniform hemisphere around +z.
#[inline]
pub fn square_to_uniform_hemisphere(u: Vec2) -> Vec3 {
    let z = u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = sin_cos(2.0 * PI * u.y);
    Vec3::new(r * c, r * s, z)
}

/// Solid-angle pdf of [`square_to_uniform_hemisphere`].
#[inline]
pub fn square_to_uniform_hemisphere_pdf(v: Vec3) -> f32 {
    if v.z > 0.0 { INV_TWO_PI } else { 0.0 }
}

/// Uniform direction on the sphere.
#[inline]
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = sin_cos(2.0 * PI * u.y);
    Vec3::new(r * c, r * s, z)
}

/// [`square_to_uniform_sphere`] per lane.
#[inline(always)]
pub fn square_to_uniform_sphere_x(u: V2x) -> V3x {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(F16::splat(0.0)).sqrt();
    let (s, c) = (2.0 * PI * u.y).sin_cos();
    V3x::new(r * c, r * s, z)
}

/// Solid-angle pdf of [`square_to_uniform_sphere`].
#[inline]
pub fn square_to_uniform_sphere_pdf() -> f32 {
    INV_FOUR_PI
}

/// Uniform direction in the cone around +z with cos of the half-angle `cos_cutoff`.
#[inline]
pub fn square_to_uniform_cone(u: Vec2, cos_cutoff: f32) -> Vec3 {
    let z = 1.0 - u.x * (1.0 - cos_cutoff);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = sin_cos(2.0 * PI * u.y);
    Vec3::new(r * c, r * s, z)
}

/// Solid-angle pdf of [`square_to_uniform_cone`].
#[inline]
pub fn square_to_uniform_cone_pdf(v: Vec3, cos_cutoff: f32) -> f32 {
    if v.z >= cos_cutoff {
        INV_TWO_PI / (1.0 - cos_cutoff)
    } else {
        0.0
    }
}

/// Uniform barycentrics (b1, b2) on a triangle; b0 = 1 − b1 − b2.
#[inline]
pub fn square_to_uniform_triangle(u: Vec2) -> Vec2 {
    let t = (1.0 - u.x).sqrt();
    Vec2::new(1.0 - t, u.y * t)
}

/// [`square_to_uniform_triangle`] per lane.
#[inline(always)]
pub fn square_to_uniform_triangle_x(u: V2x) -> V2x {
    let t = (1.0 - u.x).sqrt();
    V2x {
        x: 1.0 - t,
        y: u.y * t,
    }
}

/// [`square_to_cosine_hemisphere`] per lane.
#[inline(always)]
pub fn square_to_cosine_hemisphere_x(u: V2x) -> V3x {
    square_to_cosine_hemisphere_t::<F16>(u.into()).into()
}

/// [`square_to_cosine_hemisphere_pdf`] per lane.
#[inline(always)]
pub fn square_to_cosine_hemisphere_pdf_x(v: V3x) -> F16 {
    F16::select(v.z.gt(F16::splat(0.0)), v.z * INV_PI, F16::splat(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warps_land_in_their_domains() {
        let mut rng = crate::math::Pcg32::new(1, 2);
        for _ in 0..1000 {
            let u = rng.next_2d();
            assert!(square_to_uniform_disk_concentric(u).length() <= 1.0 + 1e-6);
            let c = square_to_cosine_hemisphere(u);
            assert!(c.z >= 0.0 && (c.length() - 1.0).abs() < 1e-5);
            let h = square_to_uniform_hemisphere(u);
            assert!(h.z >= 0.0 && (h.length() - 1.0).abs() < 1e-5);
            assert!((square_to_uniform_sphere(u).length() - 1.0).abs() < 1e-5);
            assert!(square_to_uniform_cone(u, 0.8).z >= 0.8 - 1e-6);
            let b = square_to_uniform_triangle(u);
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
        }
    }
}
