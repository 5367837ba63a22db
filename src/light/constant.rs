//! Uniform environment light (Mitsuba `constant`), sampled uniformly over the sphere.

use super::LightSample;
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

    /// Radiance and solid-angle pdf (no selection) for an escaped ray (any direction).
    #[inline]
    pub fn eval_pdf(&self) -> (Spectrum, f32) {
        (self.radiance, INV_FOUR_PI)
    }
}
