//! Projection light (Mitsuba `projector`): a pinhole at the origin of its `to_world` that
//! projects an irradiance texture along local +z through a perspective frustum, the reciprocal
//! of the `perspective` camera. The texture's uv spans the image plane at local z = 1; the
//! emitted intensity carries the camera's inverse importance, so a constant texture projected
//! onto a plane facing the light at distance 1 gives a constant irradiance.

// `!(x > 0.0)` deliberately also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::LightSample;
use crate::bsdf::Texture;
use crate::math::{Mat4, Vec2, Vec3};
use crate::{Error, Result};

/// A projector, with its projection precomputed.
#[derive(Clone, Debug)]
pub struct ProjectorLight {
    position: Vec3,
    /// World → light-local affine map (the projector looks along local +z).
    to_local: Mat4,
    /// to_world applied to local +z (not normalised, as Mitsuba's `ds.n`).
    axis: Vec3,
    /// The projected texture: irradiance on the image plane at local z = 1.
    irradiance: Texture,
    /// π · `scale`.
    pi_scale: f32,
    /// u = ½ − `u_factor` · x / z (½ · cot(fov_x / 2)).
    u_factor: f32,
    /// v = ½ − `v_factor` · y / z (½ · aspect · cot(fov_x / 2)).
    v_factor: f32,
}

impl ProjectorLight {
    /// Builds the light; `fov_x` is the horizontal field of view in degrees, the aspect ratio is
    /// the texture's width / height.
    pub fn new(
        to_world: Mat4,
        irradiance: Texture,
        scale: f32,
        fov_x: f32,
    ) -> Result<ProjectorLight> {
        let det = to_world.determinant();
        if !det.is_finite() || det.abs() < 1e-12 {
            return Err(Error::Invalid(
                "projector emitter: to_world is singular".into(),
            ));
        }
        let (w, h) = irradiance.resolution();
        let aspect = w as f32 / h as f32;
        let cot = 1.0 / (0.5 * fov_x.to_radians()).tan();
        Ok(ProjectorLight {
            position: to_world.transform_point3(Vec3::ZERO),
            to_local: to_world.inverse(),
            axis: to_world.transform_vector3(Vec3::Z),
            irradiance,
            pi_scale: std::f32::consts::PI * scale,
            u_factor: 0.5 * cot,
            v_factor: 0.5 * aspect * cot,
        })
    }

    /// The (delta) direction toward the projector from `p`; weight = π · scale · E(uv) /
    /// (z_local² · cos θ), θ between the projector's axis and the direction to `p` (None
    /// outside the frustum).
    #[inline]
    pub fn sample_li(&self, p: Vec3) -> Option<LightSample> {
        let local = self.to_local.transform_point3(p);
        if !(local.z > 0.0) {
            return None;
        }
        let uv = Vec2::new(
            0.5 - self.u_factor * (local.x / local.z),
            0.5 - self.v_factor * (local.y / local.z),
        );
        if !(uv.x >= 0.0 && uv.x <= 1.0 && uv.y >= 0.0 && uv.y <= 1.0) {
            return None;
        }
        let to = self.position - p;
        let d2 = to.length_squared();
        if !(d2 > 0.0) {
            return None;
        }
        let dist = d2.sqrt();
        let wi = to / dist;
        let cos = -self.axis.dot(wi);
        let weight = self.irradiance.eval(uv) * (self.pi_scale / (local.z * local.z * cos));
        if !(weight.max_element() > 0.0) {
            return None;
        }
        Some(LightSample {
            wi,
            dist,
            n_geo: Vec3::ZERO,
            weight,
            pdf: 1.0,
            delta: true,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::ProjectorLight;
    use crate::bsdf::Texture;
    use crate::math::{Mat4, Spectrum, Vec3};

    /// A constant projector facing a plane at distance 1 gives irradiance E · π on it, so a
    /// white Lambertian plane shows radiance E (the inverse-importance factor).
    #[test]
    fn constant_projection_onto_a_facing_plane_is_flat() {
        let e = Spectrum::new(2.0, 3.0, 4.0);
        let l = ProjectorLight::new(Mat4::IDENTITY, Texture::Constant(e), 1.5, 90.0).unwrap();
        for (x, y) in [(0.0, 0.0), (0.5, -0.3), (-0.9, 0.9)] {
            let s = l.sample_li(Vec3::new(x, y, 1.0)).unwrap();
            let cos = s.wi.z.abs();
            let irradiance = s.weight * cos;
            let want = e * (std::f32::consts::PI * 1.5);
            assert!((irradiance - want).abs().max_element() < 1e-4 * want.max_element());
        }
        // Outside the 90° frustum and behind the projector: no light.
        assert!(l.sample_li(Vec3::new(1.1, 0.0, 1.0)).is_none());
        assert!(l.sample_li(Vec3::new(0.0, 0.0, -1.0)).is_none());
    }
}
