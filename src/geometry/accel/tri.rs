//! Leaf triangle packets: `LANES` triangles in SoA, tested at once generic over the lane type
//! ([`F8`]: one ymm operation per step in the AVX2 traversal), plus the scalar reference.

use crate::math::Vec3;
use crate::math::simd::f8::F8;
#[cfg(test)]
use glam::Vec3A;

/// Triangles per leaf packet: 8 = one ymm register per SoA component under AVX2.
pub(super) const LANES: usize = 8;

/// Up to `LANES` triangles of a leaf, SoA, laid out for the Möller–Trumbore variant of
/// Áfra/madmann91 (one cross product per test): e1 = p0 − p1, e2 = p2 − p0, n = e1 × e2, each
/// as [x lanes, y lanes, z lanes]. Unused lanes are all zero: their determinant is 0, the
/// weights NaN, and they never hit. 384 bytes (six cache lines) at 8 lanes.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct TriPack {
    p0: [[f32; LANES]; 3],
    e1: [[f32; LANES]; 3],
    e2: [[f32; LANES]; 3],
    n: [[f32; LANES]; 3],
}

/// Per-lane hits of one packet: bit k of `mask` set if lane k is hit; t, b1, b2 per lane.
pub(super) struct PackHit {
    /// Lanes hit at t in (0, tmax].
    pub mask: u32,
    /// Distance per lane (world units).
    pub t: [f32; LANES],
    /// Barycentric weight of the 2nd vertex per lane.
    pub u: [f32; LANES],
    /// Barycentric weight of the 3rd vertex per lane.
    pub v: [f32; LANES],
}

impl PackHit {
    /// The nearest lane that hit (the lowest one on a tie), if any.
    #[inline(always)]
    pub fn nearest(&self) -> Option<usize> {
        let mut m = self.mask;
        if m == 0 {
            return None;
        }
        let mut lane = m.trailing_zeros() as usize;
        m &= m - 1;
        while m != 0 {
            let l = m.trailing_zeros() as usize;
            m &= m - 1;
            if self.t[l] < self.t[lane] {
                lane = l;
            }
        }
        Some(lane)
    }
}

impl Default for TriPack {
    fn default() -> TriPack {
        TriPack {
            p0: [[0.0; LANES]; 3],
            e1: [[0.0; LANES]; 3],
            e2: [[0.0; LANES]; 3],
            n: [[0.0; LANES]; 3],
        }
    }
}

impl TriPack {
    /// Stores triangle (p0, p1, p2) in lane `k`.
    pub fn set(&mut self, k: usize, p0: Vec3, p1: Vec3, p2: Vec3) {
        let e1 = p0 - p1;
        let e2 = p2 - p0;
        let n = e1.cross(e2);
        for a in 0..3 {
            self.p0[a][k] = p0[a];
            self.e1[a][k] = e1[a];
            self.e2[a][k] = e2[a];
            self.n[a][k] = n[a];
        }
    }

    /// Which lanes are hit at t in (0, tmax], with t, b1, b2 per lane, for the ray with origin
    /// `o` and direction `d` splatted per axis. Division-free: the edge and distance tests run
    /// on the numerators with the determinant's sign moved onto them (u·|det| ≥ 0, v·|det| ≥ 0,
    /// (u + v)·|det| ≤ |det|, 0 < t·|det| ≤ tmax·|det|), so a packet that nobody hits (the
    /// common case) costs no division; 1/|det| is taken only for a packet with a hit, and its
    /// distances are tested against (0, tmax] once more. Same operations in the same order as
    /// [`Tri::intersect`] (no fused multiply-adds), so every build agrees.
    #[inline(always)]
    pub fn intersect<V: F8>(&self, o: &[V; 3], d: &[V; 3], tmax: f32) -> PackHit {
        let ld = |r: &[[f32; LANES]; 3]| [V::load(&r[0]), V::load(&r[1]), V::load(&r[2])];
        let dot = |a: &[V; 3], b: &[V; 3]| a[0].mul(b[0]).add(a[1].mul(b[1])).add(a[2].mul(b[2]));
        let p0 = ld(&self.p0);
        let c = [p0[0].sub(o[0]), p0[1].sub(o[1]), p0[2].sub(o[2])];
        // r = d × c
        let r = [
            d[1].mul(c[2]).sub(d[2].mul(c[1])),
            d[2].mul(c[0]).sub(d[0].mul(c[2])),
            d[0].mul(c[1]).sub(d[1].mul(c[0])),
        ];
        let n = ld(&self.n);
        let det = dot(&n, d);
        let adet = det.abs();
        let u = dot(&r, &ld(&self.e2)).mul_sign(det);
        let v = dot(&r, &ld(&self.e1)).mul_sign(det);
        let t = dot(&n, &c).mul_sign(det);
        let zero = V::splat(0.0);
        let tmax = V::splat(tmax);
        // (A zero determinant fails: u = v = 0 then, and 0 < t ≤ 0 cannot hold.)
        let ok = u.ge(zero) & v.ge(zero) & u.add(v).le(adet) & t.gt(zero) & t.le(tmax.mul(adet));
        if V::bitmask(ok) == 0 {
            // The common case: no division, no spilling of t, b1, b2.
            return PackHit {
                mask: 0,
                t: [0.0; LANES],
                u: [0.0; LANES],
                v: [0.0; LANES],
            };
        }
        let inv = V::splat(1.0).div(adet);
        let t = t.mul(inv);
        // Rounding t·|det| and tmax·|det| can pass a distance a little past tmax (or a
        // tiny one that rounds to 0): the quotient is what the caller compares.
        let ok = ok & t.gt(zero) & t.le(tmax);
        PackHit {
            mask: V::bitmask(ok),
            t: t.to_array(),
            u: u.mul(inv).to_array(),
            v: v.mul(inv).to_array(),
        }
    }
}

/// The scalar form of [`TriPack`]: the reference the packet code is tested against.
#[cfg(test)]
#[derive(Clone, Copy, Debug)]
pub(super) struct Tri {
    p0: Vec3A,
    e1: Vec3A,
    e2: Vec3A,
    n: Vec3A,
}

#[cfg(test)]
impl Tri {
    /// Precomputes the edges and normal of (p0, p1, p2).
    pub fn new(p0: Vec3, p1: Vec3, p2: Vec3) -> Tri {
        let (p0, p1, p2) = (Vec3A::from(p0), Vec3A::from(p1), Vec3A::from(p2));
        let e1 = p0 - p1;
        let e2 = p2 - p0;
        Tri {
            p0,
            e1,
            e2,
            n: e1.cross(e2),
        }
    }

    /// (t, b1, b2) if the ray hits the triangle at t in (0, tmax], by the division-free test of
    /// [`TriPack::intersect`] (a zero determinant fails it).
    #[inline(always)]
    pub fn intersect(&self, o: Vec3A, d: Vec3A, tmax: f32) -> Option<(f32, f32, f32)> {
        let c = self.p0 - o;
        let r = d.cross(c);
        let det = self.n.dot(d);
        let s = 1.0f32.copysign(det);
        let adet = det.abs();
        let u = r.dot(self.e2) * s;
        let v = r.dot(self.e1) * s;
        let t = self.n.dot(c) * s;
        if u >= 0.0 && v >= 0.0 && u + v <= adet && t > 0.0 && t <= tmax * adet {
            let inv = 1.0 / adet;
            let t = t * inv;
            if t > 0.0 && t <= tmax {
                return Some((t, u * inv, v * inv));
            }
        }
        None
    }
}
