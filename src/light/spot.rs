//! Spot light (Mitsuba `spot`): shines along +z of its `to_world`, full intensity inside
//! `beam_width`, a linear-in-angle falloff to zero at `cutoff_angle`, optionally times a texture
//! projected over the cutoff cone (uv ∈ [0, 1]² spans the square of half-width tan(cutoff) at
//! local z = 1).

// `!(x > 0.0)` deliberately also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::{LightSample, LightSampleX};
use crate::bsdf::Texture;
use crate::math::simd::f16::{F16, M16, V3x, lanes};
use crate::math::{Mat3, Mat4, Spectrum, Vec2, Vec3};
use crate::{Error, Result};

/// A spot light, with its angles precomputed.
#[derive(Clone, Debug)]
pub struct SpotLight {
    position: Vec3,
    /// World → light-local rotation (light shines along local +z).
    to_local: Mat3,
    /// Radiant intensity on the axis (W/sr).
    intensity: Spectrum,
    cos_cutoff: f32,
    cos_beam: f32,
    /// Cutoff angle in radians.
    cutoff: f32,
    /// 1 / (cutoff − beam) in 1/radians (0 when they are equal).
    inv_transition: f32,
    /// The projected texture (Mitsuba's `texture`, spatially varying), if any.
    texture: Option<Texture>,
    /// tan(cutoff): the half-width of the texture's square at local z = 1.
    uv_factor: f32,
}

impl SpotLight {
    /// Builds the light; angles in degrees (the beam is clamped to the cutoff); `texture`
    /// multiplies the intensity by direction.
    pub fn new(
        to_world: Mat4,
        intensity: Spectrum,
        cutoff_angle: f32,
        beam_width: f32,
        texture: Option<Texture>,
    ) -> Result<SpotLight> {
        let cutoff = cutoff_angle.to_radians();
        let beam = beam_width.to_radians().min(cutoff);
        Ok(SpotLight {
            position: to_world.transform_point3(Vec3::ZERO),
            to_local: rotation_inverse(to_world, "spot emitter")?,
            intensity,
            cos_cutoff: cutoff.cos(),
            cos_beam: beam.cos(),
            cutoff,
            inv_transition: if cutoff > beam {
                1.0 / (cutoff - beam)
            } else {
                0.0
            },
            texture,
            uv_factor: cutoff.tan(),
        })
    }

    /// True if a texture is projected (the packet kernel then samples the light lane by lane).
    pub fn is_textured(&self) -> bool {
        self.texture.is_some()
    }

    /// The (delta) direction toward the light from `p`; weight = intensity · falloff / d².
    #[inline]
    pub fn sample_li(&self, p: Vec3) -> Option<LightSample> {
        let to = self.position - p;
        let d2 = to.length_squared();
        if !(d2 > 0.0) {
            return None;
        }
        let dist = d2.sqrt();
        let wi = to / dist;
        let local = (self.to_local * -wi).normalize_or_zero();
        let c = local.z;
        let falloff = if c <= self.cos_cutoff {
            0.0
        } else if c >= self.cos_beam {
            1.0
        } else {
            (self.cutoff - c.clamp(-1.0, 1.0).acos()) * self.inv_transition
        };
        if !(falloff > 0.0) {
            return None;
        }
        let radiance = match &self.texture {
            None => self.intensity,
            Some(t) => {
                // Mitsuba's `direction_to_uv` of the (unnormalised) local direction.
                let l = self.to_local * -wi;
                let zf = l.z * self.uv_factor;
                let uv = Vec2::new(0.5 + 0.5 * l.x / zf, 0.5 + 0.5 * l.y / zf);
                self.intensity * t.eval(uv)
            }
        };
        Some(LightSample {
            wi,
            dist,
            n_geo: Vec3::ZERO,
            weight: radiance * (falloff / d2),
            pdf: 1.0,
            delta: true,
        })
    }

    /// [`SpotLight::sample_li`] of an untextured spot for 16 reference points: the samples and
    /// the lanes that have one (the same bits per lane; the transition band's acos is libm's,
    /// lane by lane).
    #[inline(always)]
    pub fn sample_li_x(&self, p: V3x) -> (LightSampleX, M16) {
        let to = V3x::splat(self.position).sub(p);
        let d2 = to.length_squared();
        let dist = d2.sqrt();
        let wi = to.div(dist);
        let local = wi.neg().transform(&self.to_local).normalize_or_zero();
        let c = local.z;
        let (outside, inside) = (
            c.le(F16::splat(self.cos_cutoff)),
            c.ge(F16::splat(self.cos_beam)),
        );
        // (acos only where a lane is in the transition band.)
        let band = F16(lanes(|l| {
            if outside.0[l] || inside.0[l] {
                0.0
            } else {
                (self.cutoff - c.0[l].clamp(-1.0, 1.0).acos()) * self.inv_transition
            }
        }));
        let falloff = F16::select(
            outside,
            F16::splat(0.0),
            F16::select(inside, F16::splat(1.0), band),
        );
        let ok = d2.gt(F16::splat(0.0)).and(falloff.gt(F16::splat(0.0)));
        let s = LightSampleX {
            wi,
            dist,
            n_geo: V3x::ZERO,
            weight: V3x::splat(self.intensity).scale(falloff / d2),
            pdf: F16::splat(1.0),
            delta: M16::splat(true),
        };
        (s, ok)
    }
}

/// Inverse of the linear part of `m` (an error naming `what` if singular).
fn rotation_inverse(m: Mat4, what: &str) -> Result<Mat3> {
    let m3 = Mat3::from_mat4(m);
    let det = m3.determinant();
    if !det.is_finite() || det.abs() < 1e-12 {
        return Err(Error::Invalid(format!("{what}: to_world is singular")));
    }
    Ok(m3.inverse())
}

#[cfg(test)]
mod tests {
    use crate::light::{Emitter, LightSet};
    use crate::math::{Mat4, Spectrum, Vec2, Vec3};

    #[test]
    fn spot_falloff_matches_mitsuba_profile() {
        let to_world = Mat4::IDENTITY;
        let emitters = [Emitter::Spot {
            to_world,
            intensity: Spectrum::ONE,
            cutoff_angle: 20.0,
            beam_width: 10.0,
            texture: None,
        }];
        let ls = LightSet::new(&[], &emitters, &[], (Vec3::ZERO, Vec3::ONE)).unwrap();
        let at = |deg: f32| {
            let t = deg.to_radians();
            let p = Vec3::new(t.sin(), 0.0, t.cos()) * 2.0;
            ls.sample(p, 0.0, Vec2::ZERO)
                .map_or(0.0, |s| s.weight.x * 4.0)
        };
        assert!((at(5.0) - 1.0).abs() < 1e-5);
        assert!((at(15.0) - 0.5).abs() < 1e-3);
        assert_eq!(at(25.0), 0.0);
    }
}
