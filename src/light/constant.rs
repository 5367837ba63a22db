//! Uniform environment light (Mitsuba `constant`), sampled uniformly over the sphere.

use super::{LightSample, LightSampleX};
use crate::math::simd::f16::{F16, M16, V2x, V3x};
use crate::math::{INV_FOUR_PI, Spectrum, Vec2, Vec3, warp};

/// Uniform radiance from every direction at infinity.
#[derive(Clone, Debug)]
pub struct ConstantLight {
    /// Radiance (W/(m²·sr)).
    pub radiance: Spectrum,
}

impl ConstantLight {
    /// A uniformly chosen direction (pdf 1/(4π), no selection).
    #[inline]
    pub fn sample_li(&self, u: Vec2) -> LightSample {
        let wi = warp::square_to_uniform_sphere(u);
        LightSample {
            wi,
            dist: f32::INFINITY,
            n_geo: Vec3::ZERO,
            weight: self.radiance / INV_FOUR_PI,
            pdf: INV_FOUR_PI,
            delta: false,
        }
    }

    /// [`ConstantLight::sample_li`] for 16 lanes (the same bits per lane).
    #[inline(always)]
    pub fn sample_li_x(&self, u: V2x) -> LightSampleX {
        LightSampleX {
            wi: warp::square_to_uniform_sphere_x(u),
            dist: F16::splat(f32::INFINITY),
            n_geo: V3x::ZERO,
            weight: V3x::splat(self.radiance / INV_FOUR_PI),
            pdf: F16::splat(INV_FOUR_PI),
            delta: M16::splat(false),
        }
    }

    /// Radiance and solid-angle pdf (no selection) for an escaped ray (any direction).
    #[inline]
    pub fn eval_pdf(&self) -> (Spectrum, f32) {
        (self.radiance, INV_FOUR_PI)
    }
}
