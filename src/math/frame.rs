//! Orthonormal frames: the local shading space in which BSDFs and BTFs are evaluated (z = normal).

use crate::math::simd::f16::{F16, V3x};
use glam::Vec3;

/// An orthonormal basis (s, t, n); local coordinates are (x along s, y along t, z along n).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// A frame around a unit normal with an arbitrary but continuous tangent
    /// (Duff et al. 2017, "Building an orthonormal basis, revisited").
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// The BTF shading frame of docs/conventions.md: s = normalize(∂p/∂u − n (n·∂p/∂u)), t = n × s.
    /// Falls back to [`Frame::from_normal`] when ∂p/∂u is zero or parallel to n.
    pub fn from_normal_tangent(n: Vec3, dpdu: Vec3) -> Self {
        let s = dpdu - n * n.dot(dpdu);
        let len2 = s.length_squared();
        if len2.is_nan() || len2 <= 1e-20 || !len2.is_finite() {
            return Frame::from_normal(n);
        }
        let s = s / len2.sqrt();
        Frame {
            s,
            t: n.cross(s),
            n,
        }
    }

    /// World → local.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local → world.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// 16 frames, one per lane: [`Frame`]'s constructors and transforms on [`V3x`], the same bits
/// per lane (the packet kernels' twin of [`Frame`]).
#[derive(Clone, Copy, Debug)]
pub struct FrameX {
    pub s: V3x,
    pub t: V3x,
    pub n: V3x,
}

impl FrameX {
    /// [`Frame::from_normal`] per lane.
    #[inline(always)]
    pub fn from_normal(n: V3x) -> Self {
        let sign = n.z.sign_of();
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = V3x::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = V3x::new(b, sign + n.y * n.y * a, -n.y);
        FrameX { s, t, n }
    }

    /// [`Frame::from_normal_tangent`] per lane.
    #[inline(always)]
    pub fn from_normal_tangent(n: V3x, dpdu: V3x) -> Self {
        let s = dpdu.sub(n.scale(n.dot(dpdu)));
        let len2 = s.length_squared();
        let bad = len2
            .ne(len2)
            .or(len2.le(F16::splat(1e-20)))
            .or(len2.is_finite().not());
        let s = s.div(len2.sqrt());
        let fb = FrameX::from_normal(n);
        FrameX {
            s: V3x::select(bad, fb.s, s),
            t: V3x::select(bad, fb.t, n.cross(s)),
            n,
        }
    }

    /// World → local per lane.
    #[inline(always)]
    pub fn to_local(&self, v: V3x) -> V3x {
        V3x::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local → world per lane.
    #[inline(always)]
    pub fn to_world(&self, v: V3x) -> V3x {
        self.s
            .scale(v.x)
            .add(self.t.scale(v.y))
            .add(self.n.scale(v.z))
    }
}

/// cos θ of a local direction.
#[inline]
pub fn cos_theta(v: Vec3) -> f32 {
    v.z
}

/// (θ, φ) in radians of a local unit direction, φ ∈ [0, 2π) measured from s toward t.
#[inline]
pub fn to_spherical(v: Vec3) -> (f32, f32) {
    let theta = v.z.clamp(-1.0, 1.0).acos();
    let mut phi = v.y.atan2(v.x);
    if phi < 0.0 {
        phi += 2.0 * std::f32::consts::PI;
    }
    (theta, phi)
}

/// Local unit direction from (θ, φ) in radians.
#[inline]
pub fn from_spherical(theta: f32, phi: f32) -> Vec3 {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    Vec3::new(st * cp, st * sp, ct)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_orthonormal_and_invert() {
        for &n in &[
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, 0.8).normalize(),
            Vec3::new(1e-8, 0.0, -1.0).normalize(),
        ] {
            let f = Frame::from_normal(n);
            assert!((f.s.dot(f.t)).abs() < 1e-5 && (f.s.dot(f.n)).abs() < 1e-5);
            assert!((f.s.length() - 1.0).abs() < 1e-5 && (f.t.length() - 1.0).abs() < 1e-5);
            let v = Vec3::new(0.2, 0.7, -0.4);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn tangent_frame_follows_dpdu() {
        let f = Frame::from_normal_tangent(Vec3::Z, Vec3::new(2.0, 0.0, 0.5));
        assert!((f.s - Vec3::X).length() < 1e-6);
        assert!((f.t - Vec3::Y).length() < 1e-6);
        let g = Frame::from_normal_tangent(Vec3::Z, Vec3::Z);
        assert!((g.n - Vec3::Z).length() < 1e-6);
    }

    #[test]
    fn spherical_round_trip() {
        let v = from_spherical(0.7, 4.0);
        let (t, p) = to_spherical(v);
        assert!((t - 0.7).abs() < 1e-5 && (p - 4.0).abs() < 1e-5);
    }
}
