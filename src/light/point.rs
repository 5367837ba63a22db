//! Isotropic point light (Mitsuba `point`).

// `!(x > 0.0)` deliberately also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::{LightSample, LightSampleX};
use crate::math::simd::f16::{F16, M16, V3x};
use crate::math::{Spectrum, Vec3};

/// An isotropic point light.
#[derive(Clone, Debug)]
pub struct PointLight {
    pub position: Vec3,
    /// Radiant intensity (W/sr).
    pub intensity: Spectrum,
}

impl PointLight {
    /// The (delta) direction toward the light from `p`; weight = intensity / d².
    #[inline]
    pub fn sample_li(&self, p: Vec3) -> Option<LightSample> {
        let to = self.position - p;
        let d2 = to.length_squared();
        if !(d2 > 0.0) {
            return None;
        }
        let dist = d2.sqrt();
        Some(LightSample {
            wi: to / dist,
            dist,
            n_geo: Vec3::ZERO,
            weight: self.intensity / d2,
            pdf: 1.0,
            delta: true,
        })
    }

    /// [`PointLight::sample_li`] for 16 reference points: the samples and the lanes that have
    /// one (the same bits per lane).
    #[inline(always)]
    pub fn sample_li_x(&self, p: V3x) -> (LightSampleX, M16) {
        let to = V3x::splat(self.position).sub(p);
        let d2 = to.length_squared();
        let dist = d2.sqrt();
        let s = LightSampleX {
            wi: to.div(dist),
            dist,
            n_geo: V3x::ZERO,
            weight: V3x::splat(self.intensity).div(d2),
            pdf: F16::splat(1.0),
            delta: M16::splat(true),
        };
        (s, d2.gt(F16::splat(0.0)))
    }
}
