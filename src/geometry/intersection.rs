//! The record of a ray–surface hit: everything a BSDF (including a spatially varying BTF) needs.

use crate::math::{Frame, Vec2, Vec3};

/// A ray–surface intersection, Mitsuba 3 style: directions in `wi` are local to `sh_frame`.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceInteraction {
    /// Hit position (world).
    pub p: Vec3,
    /// Ray distance to the hit.
    pub t: f32,
    /// Unit geometric normal (world), from the triangle winding (p1 − p0) × (p2 − p0).
    pub n: Vec3,
    /// Shading frame: n = interpolated shading normal, s from ∂p/∂u (docs/conventions.md).
    pub sh_frame: Frame,
    /// Texture coordinates.
    pub uv: Vec2,
    /// Position derivatives with respect to u and v (world).
    pub dpdu: Vec3,
    pub dpdv: Vec3,
    /// Unit direction toward the ray origin, in the local shading frame.
    pub wi: Vec3,
    /// Mesh index in the scene and triangle index in the mesh.
    pub mesh: u32,
    pub prim: u32,
    /// Barycentric weights (b1, b2) of the triangle's 2nd and 3rd vertices at the hit (what
    /// per-vertex mesh attributes are interpolated with; zero on an analytic sphere).
    pub bary: Vec2,
}

impl SurfaceInteraction {
    /// World → local shading frame.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        self.sh_frame.to_local(v)
    }

    /// Local shading frame → world.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.sh_frame.to_world(v)
    }

    /// A minimal interaction at the origin with the shading frame = world axes, for BSDF tests.
    pub fn for_tests(wi: Vec3, uv: Vec2) -> Self {
        SurfaceInteraction {
            p: Vec3::ZERO,
            t: 1.0,
            n: Vec3::Z,
            sh_frame: Frame {
                s: Vec3::X,
                t: Vec3::Y,
                n: Vec3::Z,
            },
            uv,
            dpdu: Vec3::X,
            dpdv: Vec3::Y,
            wi,
            mesh: 0,
            prim: 0,
            bary: Vec2::ZERO,
        }
    }
}
