//! Directional (distant) light (Mitsuba `directional`).

use super::{LightSample, LightSampleX};
use crate::math::simd::f16::{F16, M16, V3x};
use crate::math::{Spectrum, Vec3};
use crate::{Error, Result};

/// A light at infinity shining in one direction.
#[derive(Clone, Debug)]
pub struct DirectionalLight {
    /// Unit direction of travel of the light.
    pub direction: Vec3,
    /// Irradiance on a surface facing the light (W/m²).
    pub irradiance: Spectrum,
}

impl DirectionalLight {
    /// Builds the light; `direction` need not be unit length but must not be zero.
    pub fn new(direction: Vec3, irradiance: Spectrum) -> Result<DirectionalLight> {
        let d = direction.normalize_or_zero();
        if d == Vec3::ZERO {
            return Err(Error::Invalid(
                "directional emitter with a zero direction".into(),
            ));
        }
        Ok(DirectionalLight {
            direction: d,
            irradiance,
        })
    }

    /// The (delta) direction toward the light from `p`; `bsphere` = scene bounding sphere
    /// (centre, radius) bounds the shadow ray.
    #[inline]
    pub fn sample_li(&self, p: Vec3, bsphere: (Vec3, f32)) -> LightSample {
        let (c, r) = bsphere;
        LightSample {
            wi: -self.direction,
            // Past the scene's bounding sphere nothing can occlude (Mitsuba: 2·radius).
            dist: 2.0 * r.max((p - c).length()),
            n_geo: Vec3::ZERO,
            weight: self.irradiance,
            pdf: 1.0,
            delta: true,
        }
    }

    /// [`DirectionalLight::sample_li`] for 16 reference points (the same bits per lane).
    #[inline(always)]
    pub fn sample_li_x(&self, p: V3x, bsphere: (Vec3, f32)) -> LightSampleX {
        let (c, r) = bsphere;
        // f32::max(r, x) with r not NaN: x where x > r, else r (also for a NaN x).
        let len = p.sub(V3x::splat(c)).length();
        LightSampleX {
            wi: V3x::splat(-self.direction),
            dist: 2.0 * F16::select(len.gt(F16::splat(r)), len, F16::splat(r)),
            n_geo: V3x::ZERO,
            weight: V3x::splat(self.irradiance),
            pdf: F16::splat(1.0),
            delta: M16::splat(true),
        }
    }
}
