//! Mitsuba 3's projective sensors (`perspective`, `thinlens`, `orthographic`): film position
//! (and, for the thin lens, an aperture sample) → primary ray.
//!
//! Mitsuba's camera space has +x to the *left*, +y up and +z forward (its `lookat` builds the
//! columns (left, up, dir)); film x grows to the right, so x_cam = (1 − 2 s_x)·tan(fov_x/2) and
//! y_cam = (1 − 2 s_y)·tan(fov_x/2)/aspect for film coordinates s ∈ [0, 1]² (row 0 at the top).
//! The ray starts on the near plane and ends on the far plane, as in `perspective.cpp`. The thin
//! lens moves the ray's start to a point of its aperture disk and aims it at the point the
//! pinhole ray meets the focal plane z_cam = focus_distance (`thinlens.cpp`); the orthographic
//! camera starts every ray at ((1 − 2 s_x), (1 − 2 s_y)/aspect, near) in camera space, mapped by
//! the whole `to_world` (its scale sets the view extent), along to_world · +z
//! (`orthographic.cpp`).

// `!(x > 0.0)` deliberately also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::math::simd::f16::{F16, V3x};
use crate::math::warp::square_to_uniform_disk_concentric;
use crate::math::{Pcg32, Vec2, Vec3};
use crate::scene::{Camera, Projection};
use crate::{Error, Result};

/// Precomputed primary-ray generator.
#[derive(Clone, Debug)]
pub struct ProjectiveCamera {
    origin: Vec3,
    /// World images of the camera axes (x = left, y = up, z = forward), not normalised when the
    /// transform scales (directions are normalised after the transform, as Mitsuba does).
    axes: [Vec3; 3],
    tan_half_x: f32,
    inv_aspect: f32,
    near: f32,
    far: f32,
    projection: Projection,
    /// Full film size in pixels.
    pub width: u32,
    pub height: u32,
}

impl ProjectiveCamera {
    /// Validates and precomputes the camera.
    pub fn new(cam: &Camera) -> Result<Self> {
        if cam.width == 0 || cam.height == 0 {
            return Err(Error::Invalid(format!(
                "film resolution {}×{} must be positive",
                cam.width, cam.height
            )));
        }
        if !(cam.fov_x_deg > 0.0 && cam.fov_x_deg < 180.0) {
            return Err(Error::Invalid(format!(
                "horizontal field of view {}° must be in (0, 180)",
                cam.fov_x_deg
            )));
        }
        if !(cam.near_clip > 0.0 && cam.far_clip > cam.near_clip) {
            return Err(Error::Invalid(format!(
                "clip planes near={} far={} must satisfy 0 < near < far",
                cam.near_clip, cam.far_clip
            )));
        }
        if let Projection::ThinLens {
            aperture_radius,
            focus_distance,
        } = cam.projection
            && !(aperture_radius >= 0.0
                && aperture_radius.is_finite()
                && focus_distance > 0.0
                && focus_distance.is_finite())
        {
            return Err(Error::Invalid(format!(
                "thin lens aperture radius {aperture_radius} must be ≥ 0 and focus distance \
                 {focus_distance} > 0"
            )));
        }
        let m = cam.to_world;
        let axes = [
            m.transform_vector3(Vec3::X),
            m.transform_vector3(Vec3::Y),
            m.transform_vector3(Vec3::Z),
        ];
        if !m.is_finite() || glam::Mat3::from_mat4(m).determinant().abs() < 1e-20 {
            return Err(Error::Invalid("camera to_world is singular".into()));
        }
        Ok(ProjectiveCamera {
            origin: m.transform_point3(Vec3::ZERO),
            axes,
            tan_half_x: (0.5 * cam.fov_x_deg.to_radians()).tan(),
            inv_aspect: cam.height as f32 / cam.width as f32,
            near: cam.near_clip,
            far: cam.far_clip,
            projection: cam.projection,
            width: cam.width,
            height: cam.height,
        })
    }

    /// True when a ray needs an aperture sample (the thin lens): the sampler's 2-D dimension
    /// after the film position, as Mitsuba's integrators draw it.
    #[inline]
    pub fn needs_aperture_sample(&self) -> bool {
        matches!(self.projection, Projection::ThinLens { .. })
    }

    /// The ray through film position (`fx`, `fy`) in pixels of the full film, drawing the
    /// aperture sample from `rng` (two numbers) only when the lens needs one; returns
    /// (origin, unit direction, maximum distance).
    #[inline]
    pub fn sample_ray_rng(&self, fx: f32, fy: f32, rng: &mut Pcg32) -> (Vec3, Vec3, f32) {
        self.sample_ray(fx, fy, self.aperture_sample(rng))
    }

    /// The aperture sample of a ray: two numbers from `rng` when the lens needs them, else
    /// the aperture's centre (0.5, 0.5) and nothing drawn.
    #[inline]
    pub fn aperture_sample(&self, rng: &mut Pcg32) -> Vec2 {
        if self.needs_aperture_sample() {
            rng.next_2d()
        } else {
            Vec2::splat(0.5)
        }
    }

    /// The ray through film position (`fx`, `fy`) and the centre of the aperture.
    #[inline]
    pub fn ray(&self, fx: f32, fy: f32) -> (Vec3, Vec3, f32) {
        self.sample_ray(fx, fy, Vec2::splat(0.5))
    }

    /// The ray through film position (`fx`, `fy`) in pixels of the full film and aperture
    /// sample `u` ∈ [0, 1)² (used by the thin lens only); returns (origin, unit direction,
    /// maximum distance).
    #[inline]
    pub fn sample_ray(&self, fx: f32, fy: f32, u: Vec2) -> (Vec3, Vec3, f32) {
        let sx = fx / self.width as f32;
        let sy = fy / self.height as f32;
        match self.projection {
            Projection::Perspective => {
                let x = (1.0 - 2.0 * sx) * self.tan_half_x;
                let y = (1.0 - 2.0 * sy) * self.tan_half_x * self.inv_aspect;
                // Camera-space direction (x, y, 1), with |.| used to place near/far along the ray.
                let inv_len = 1.0 / (x * x + y * y + 1.0).sqrt();
                let d_world = (self.axes[0] * x + self.axes[1] * y + self.axes[2]).normalize();
                // Near/far planes are at camera-space z = near/far: t = near · |d_cam| / z_cam.
                let near_t = self.near / inv_len;
                let far_t = self.far / inv_len;
                (self.origin + d_world * near_t, d_world, far_t - near_t)
            }
            Projection::ThinLens {
                aperture_radius,
                focus_distance,
            } => {
                let x = (1.0 - 2.0 * sx) * self.tan_half_x;
                let y = (1.0 - 2.0 * sy) * self.tan_half_x * self.inv_aspect;
                let a = square_to_uniform_disk_concentric(u) * aperture_radius;
                // From the aperture point to where the pinhole ray meets the focal plane.
                let d_cam = Vec3::new(
                    x * focus_distance - a.x,
                    y * focus_distance - a.y,
                    focus_distance,
                )
                .normalize();
                let d_world =
                    (self.axes[0] * d_cam.x + self.axes[1] * d_cam.y + self.axes[2] * d_cam.z)
                        .normalize();
                let start = self.origin + self.axes[0] * a.x + self.axes[1] * a.y;
                let near_t = self.near / d_cam.z;
                let far_t = self.far / d_cam.z;
                (start + d_world * near_t, d_world, far_t - near_t)
            }
            Projection::Orthographic => {
                let x = 1.0 - 2.0 * sx;
                let y = (1.0 - 2.0 * sy) * self.inv_aspect;
                let o =
                    self.origin + self.axes[0] * x + self.axes[1] * y + self.axes[2] * self.near;
                (o, self.axes[2].normalize(), self.far - self.near)
            }
        }
    }

    /// The ray differentials of the ray through (`fx`, `fy`) with aperture sample `u`, as
    /// Mitsuba's `sample_ray_differential` makes them: the (origin, direction) of the rays one
    /// pixel to the right and one pixel down. The perspective and thin-lens offset rays leave
    /// the main ray's origin (towards where their own pinhole/focal-plane rays go); the
    /// orthographic ones leave the offset film position, parallel to the main ray.
    pub fn differentials(&self, fx: f32, fy: f32, u: Vec2) -> [(Vec3, Vec3); 2] {
        let (o, d, _) = self.sample_ray(fx, fy, u);
        [(fx + 1.0, fy), (fx, fy + 1.0)].map(|(x, y)| {
            let (ox, dx, _) = self.sample_ray(x, y, u);
            match self.projection {
                Projection::Orthographic => (ox, d),
                _ => (o, dx),
            }
        })
    }

    /// [`ProjectiveCamera::sample_ray`] for 16 film positions and aperture samples `(ux, uy)`:
    /// the same operations in the same order per lane (the packet integrator's refill), so each
    /// lane is the scalar ray's bits. The pinhole runs in SIMD; the thin lens and orthographic
    /// cameras call the scalar ray per lane.
    #[inline(always)]
    pub fn ray_x(&self, fx: F16, fy: F16, ux: F16, uy: F16) -> (V3x, V3x, F16) {
        if self.projection != Projection::Perspective {
            let mut o = V3x::splat(Vec3::ZERO);
            let mut d = V3x::splat(Vec3::ZERO);
            let mut t = F16::splat(0.0);
            for l in 0..16 {
                let (lo, ld, lt) = self.sample_ray(fx.0[l], fy.0[l], Vec2::new(ux.0[l], uy.0[l]));
                o.set(l, lo);
                d.set(l, ld);
                t.0[l] = lt;
            }
            return (o, d, t);
        }
        let sx = fx / self.width as f32;
        let sy = fy / self.height as f32;
        let x = (1.0 - 2.0 * sx) * self.tan_half_x;
        let y = (1.0 - 2.0 * sy) * self.tan_half_x * self.inv_aspect;
        let inv_len = 1.0 / (x * x + y * y + 1.0).sqrt();
        let [a0, a1, a2] = self.axes.map(V3x::splat);
        let d = a0.scale(x).add(a1.scale(y)).add(a2);
        let d_world = d.scale(1.0 / d.length());
        let near_t = self.near / inv_len;
        let far_t = self.far / inv_len;
        let o = V3x::splat(self.origin).add(d_world.scale(near_t));
        (o, d_world, far_t - near_t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Mat4;
    use crate::math::transform::look_at as lookat;

    #[test]
    fn image_left_is_world_left_and_top_is_up() {
        // Looking down −z from +z with +y up: world −x must be on the left of the image.
        let cam = Camera {
            to_world: lookat(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y),
            projection: crate::scene::Projection::Perspective,
            fov_x_deg: 90.0,
            near_clip: 0.01,
            far_clip: 100.0,
            width: 200,
            height: 100,
            crop: None,
            filter: crate::math::filter::Filter::BOX,
        };
        let c = ProjectiveCamera::new(&cam).unwrap();
        let (_, d, _) = c.ray(100.0, 50.0);
        assert!((d - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
        let (_, d, _) = c.ray(0.0, 50.0);
        assert!((d - Vec3::new(-1.0, 0.0, -1.0).normalize()).length() < 1e-6);
        let (_, d, _) = c.ray(100.0, 0.0);
        assert!((d - Vec3::new(0.0, 0.5, -1.0).normalize()).length() < 1e-6);
        let (o, d, tmax) = c.ray(0.0, 0.0);
        let end = o + d * tmax;
        // Near plane at z_cam = 0.01, far plane at z_cam = 100.
        assert!(((5.0 - o.z) - 0.01).abs() < 1e-5);
        assert!(((5.0 - end.z) - 100.0).abs() < 1e-3);
    }

    #[test]
    fn bad_cameras_are_errors() {
        let mut cam = Camera {
            to_world: Mat4::IDENTITY,
            projection: crate::scene::Projection::Perspective,
            fov_x_deg: 180.0,
            near_clip: 0.01,
            far_clip: 100.0,
            width: 2,
            height: 2,
            crop: None,
            filter: crate::math::filter::Filter::BOX,
        };
        assert!(ProjectiveCamera::new(&cam).is_err());
        cam.fov_x_deg = 45.0;
        cam.width = 0;
        assert!(ProjectiveCamera::new(&cam).is_err());
    }

    /// The 16-lane twin gives each lane the scalar ray's bits (an oblique camera, film
    /// positions across and just outside the film).
    #[test]
    fn ray_x_is_ray_per_lane() {
        let cam = Camera {
            to_world: lookat(Vec3::new(1.0, 2.0, 5.0), Vec3::new(0.3, 0.0, -1.0), Vec3::Y),
            projection: crate::scene::Projection::Perspective,
            fov_x_deg: 39.3,
            near_clip: 0.01,
            far_clip: 1000.0,
            width: 160,
            height: 120,
            crop: None,
            filter: crate::math::filter::Filter::BOX,
        };
        let c = ProjectiveCamera::new(&cam).unwrap();
        let fx = F16(std::array::from_fn(|l| l as f32 * 10.7 - 0.5));
        let fy = F16(std::array::from_fn(|l| 120.5 - l as f32 * 7.9));
        let (o, d, t) = c.ray_x(fx, fy, F16::splat(0.5), F16::splat(0.5));
        for l in 0..16 {
            let (so, sd, st) = c.ray(fx.0[l], fy.0[l]);
            let bits = |v: Vec3| v.to_array().map(f32::to_bits);
            assert_eq!(bits(o.get(l)), bits(so), "lane {l}");
            assert_eq!(bits(d.get(l)), bits(sd), "lane {l}");
            assert_eq!(t.0[l].to_bits(), st.to_bits(), "lane {l}");
        }
    }
}
