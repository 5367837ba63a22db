//! Sixteen-lane values for the packet kernels written as straight-line code: [`F16`] (f32),
//! [`M16`] (a lane mask), [`V2x`] and [`V3x`] (vectors, one [`F16`] per component). Every
//! operation is a loop over the 16 lanes marked `#[inline(always)]`, which LLVM turns into one
//! AVX-512 instruction (two AVX2 ones) inside a `#[target_feature]` build
//! ([`crate::isa_dispatch`]) and into plain loops elsewhere.
//!
//! The vector operations round exactly like glam's scalar `Vec3`/`Vec2` ones (the same
//! operations in the same order, no fused multiply-adds), so a lane computes the bits the scalar
//! code computes; branches become [`F16::select`] of both sides, which is the same value.

use super::WIDTH;
use glam::{Vec2, Vec3};
use std::ops::{Add, Div, Mul, Neg, Sub};

const W: usize = WIDTH;

/// 16 f32 lanes (sixteen single-precision lanes, not a half-precision float: that is `half::f16`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct F16(pub [f32; W]);

/// A per-lane condition.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct M16(pub [bool; W]);

// Plain loops rather than `std::array::from_fn`, whose inner `try_from_fn` LLVM does not
// always inline into the large kernels (a call per lane operation).
/// `[f(0), …, f(15)]` as a plain loop (see above).
#[inline(always)]
pub fn lanes<T: Copy + Default>(f: impl Fn(usize) -> T) -> [T; W] {
    let mut o = [T::default(); W];
    for (i, v) in o.iter_mut().enumerate() {
        *v = f(i);
    }
    o
}

#[inline(always)]
fn map(f: impl Fn(usize) -> f32) -> F16 {
    F16(lanes(f))
}

#[inline(always)]
fn mask(f: impl Fn(usize) -> bool) -> M16 {
    M16(lanes(f))
}

impl F16 {
    /// Every lane `v`.
    #[inline(always)]
    pub fn splat(v: f32) -> F16 {
        F16([v; W])
    }

    /// √ per lane (correctly rounded, as `f32::sqrt`).
    #[inline(always)]
    pub fn sqrt(self) -> F16 {
        map(|i| self.0[i].sqrt())
    }

    /// |x| per lane.
    #[inline(always)]
    pub fn abs(self) -> F16 {
        map(|i| self.0[i].abs())
    }

    /// `if a < b { a } else { b }`: `f32::min(a, b)` for a non-NaN `b`.
    #[inline(always)]
    pub fn min(self, b: F16) -> F16 {
        map(|i| {
            if self.0[i] < b.0[i] {
                self.0[i]
            } else {
                b.0[i]
            }
        })
    }

    /// `if a > b { a } else { b }`: glam's `max_element` step, `f32::max(a, b)` for a non-NaN `b`.
    #[inline(always)]
    pub fn max(self, b: F16) -> F16 {
        map(|i| {
            if self.0[i] > b.0[i] {
                self.0[i]
            } else {
                b.0[i]
            }
        })
    }

    /// Lanes of `a` where `m`, of `b` elsewhere.
    #[inline(always)]
    pub fn select(m: M16, a: F16, b: F16) -> F16 {
        map(|i| if m.0[i] { a.0[i] } else { b.0[i] })
    }

    #[inline(always)]
    pub fn lt(self, b: F16) -> M16 {
        mask(|i| self.0[i] < b.0[i])
    }

    #[inline(always)]
    pub fn le(self, b: F16) -> M16 {
        mask(|i| self.0[i] <= b.0[i])
    }

    #[inline(always)]
    pub fn gt(self, b: F16) -> M16 {
        mask(|i| self.0[i] > b.0[i])
    }

    #[inline(always)]
    pub fn ge(self, b: F16) -> M16 {
        mask(|i| self.0[i] >= b.0[i])
    }

    #[inline(always)]
    pub fn eq(self, b: F16) -> M16 {
        mask(|i| self.0[i] == b.0[i])
    }

    #[inline(always)]
    pub fn ne(self, b: F16) -> M16 {
        mask(|i| self.0[i] != b.0[i])
    }

    /// Neither infinite nor NaN (`f32::is_finite`): |x| < ∞, with ∞ hidden from the optimiser.
    /// Written plainly (as a float or a bit test), LLVM folds it with a neighbouring `x > 0`
    /// into one `is.fpclass` test, which the x86 backend scalarises lane by lane.
    #[inline(always)]
    pub fn is_finite(self) -> M16 {
        let inf = F16::splat(std::hint::black_box(f32::INFINITY));
        self.abs().lt(inf)
    }

    /// `f32::copysign(1.0, x)` per lane.
    #[inline(always)]
    pub fn sign_of(self) -> F16 {
        map(|i| 1.0f32.copysign(self.0[i]))
    }
}

macro_rules! fx_op {
    ($tr:ident, $f:ident, $op:tt) => {
        impl $tr for F16 {
            type Output = F16;
            #[inline(always)]
            fn $f(self, b: F16) -> F16 {
                map(|i| self.0[i] $op b.0[i])
            }
        }
        impl $tr<f32> for F16 {
            type Output = F16;
            #[inline(always)]
            fn $f(self, b: f32) -> F16 {
                map(|i| self.0[i] $op b)
            }
        }
        impl $tr<F16> for f32 {
            type Output = F16;
            #[inline(always)]
            fn $f(self, b: F16) -> F16 {
                map(|i| self $op b.0[i])
            }
        }
    };
}
fx_op!(Add, add, +);
fx_op!(Sub, sub, -);
fx_op!(Mul, mul, *);
fx_op!(Div, div, /);

impl Neg for F16 {
    type Output = F16;
    #[inline(always)]
    fn neg(self) -> F16 {
        map(|i| -self.0[i])
    }
}

// Named methods, not operator traits: the twins of scalar code read left to right in the
// order glam evaluates, and a mask is not an integer.
#[allow(clippy::should_implement_trait)]
impl M16 {
    /// Every lane `v`.
    #[inline(always)]
    pub fn splat(v: bool) -> M16 {
        M16([v; W])
    }

    #[inline(always)]
    pub fn and(self, b: M16) -> M16 {
        mask(|i| self.0[i] & b.0[i])
    }

    #[inline(always)]
    pub fn or(self, b: M16) -> M16 {
        mask(|i| self.0[i] | b.0[i])
    }

    #[inline(always)]
    pub fn not(self) -> M16 {
        mask(|i| !self.0[i])
    }
}

/// 16 2-vectors, one [`F16`] per component.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct V2x {
    pub x: F16,
    pub y: F16,
}

// Named methods, not operator traits: the twins of scalar code read left to right in the
// order glam evaluates, and a mask is not an integer.
#[allow(clippy::should_implement_trait)]
impl V2x {
    pub const ZERO: V2x = V2x {
        x: F16([0.0; W]),
        y: F16([0.0; W]),
    };

    #[inline(always)]
    pub fn get(&self, l: usize) -> Vec2 {
        Vec2::new(self.x.0[l], self.y.0[l])
    }

    #[inline(always)]
    pub fn set(&mut self, l: usize, v: Vec2) {
        self.x.0[l] = v.x;
        self.y.0[l] = v.y;
    }

    /// `Vec2 * f32` per lane.
    #[inline(always)]
    pub fn scale(self, s: F16) -> V2x {
        V2x {
            x: self.x * s,
            y: self.y * s,
        }
    }

    #[inline(always)]
    pub fn add(self, b: V2x) -> V2x {
        V2x {
            x: self.x + b.x,
            y: self.y + b.y,
        }
    }

    #[inline(always)]
    pub fn sub(self, b: V2x) -> V2x {
        V2x {
            x: self.x - b.x,
            y: self.y - b.y,
        }
    }

    /// Lanes of `a` where `m`, of `b` elsewhere.
    #[inline(always)]
    pub fn select(m: M16, a: V2x, b: V2x) -> V2x {
        V2x {
            x: F16::select(m, a.x, b.x),
            y: F16::select(m, a.y, b.y),
        }
    }
}

/// 16 3-vectors, one [`F16`] per component.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct V3x {
    pub x: F16,
    pub y: F16,
    pub z: F16,
}

// Named methods, not operator traits: the twins of scalar code read left to right in the
// order glam evaluates, and a mask is not an integer.
#[allow(clippy::should_implement_trait)]
impl V3x {
    pub const ZERO: V3x = V3x {
        x: F16([0.0; W]),
        y: F16([0.0; W]),
        z: F16([0.0; W]),
    };

    /// Every lane `v`.
    #[inline(always)]
    pub fn splat(v: Vec3) -> V3x {
        V3x {
            x: F16::splat(v.x),
            y: F16::splat(v.y),
            z: F16::splat(v.z),
        }
    }

    #[inline(always)]
    pub fn new(x: F16, y: F16, z: F16) -> V3x {
        V3x { x, y, z }
    }

    #[inline(always)]
    pub fn get(&self, l: usize) -> Vec3 {
        Vec3::new(self.x.0[l], self.y.0[l], self.z.0[l])
    }

    #[inline(always)]
    pub fn set(&mut self, l: usize, v: Vec3) {
        self.x.0[l] = v.x;
        self.y.0[l] = v.y;
        self.z.0[l] = v.z;
    }

    /// `Vec3 * f32` per lane.
    #[inline(always)]
    pub fn scale(self, s: F16) -> V3x {
        V3x::new(self.x * s, self.y * s, self.z * s)
    }

    /// `Vec3 / f32` per lane (a division per component, as glam).
    #[inline(always)]
    pub fn div(self, s: F16) -> V3x {
        V3x::new(self.x / s, self.y / s, self.z / s)
    }

    /// Component-wise product.
    #[inline(always)]
    pub fn mul(self, b: V3x) -> V3x {
        V3x::new(self.x * b.x, self.y * b.y, self.z * b.z)
    }

    #[inline(always)]
    pub fn add(self, b: V3x) -> V3x {
        V3x::new(self.x + b.x, self.y + b.y, self.z + b.z)
    }

    #[inline(always)]
    pub fn sub(self, b: V3x) -> V3x {
        V3x::new(self.x - b.x, self.y - b.y, self.z - b.z)
    }

    #[inline(always)]
    pub fn neg(self) -> V3x {
        V3x::new(-self.x, -self.y, -self.z)
    }

    /// (x·x' + y·y') + z·z', glam's order.
    #[inline(always)]
    pub fn dot(self, b: V3x) -> F16 {
        (self.x * b.x) + (self.y * b.y) + (self.z * b.z)
    }

    /// glam's cross product.
    #[inline(always)]
    pub fn cross(self, b: V3x) -> V3x {
        V3x::new(
            self.y * b.z - b.y * self.z,
            self.z * b.x - b.z * self.x,
            self.x * b.y - b.x * self.y,
        )
    }

    #[inline(always)]
    pub fn length_squared(self) -> F16 {
        self.dot(self)
    }

    #[inline(always)]
    pub fn length(self) -> F16 {
        self.dot(self).sqrt()
    }

    /// glam's `normalize_or_zero`: v · (1/|v|) where that reciprocal is finite and positive.
    #[inline(always)]
    pub fn normalize_or_zero(self) -> V3x {
        let rcp = 1.0 / self.length();
        let ok = rcp.is_finite().and(rcp.gt(F16::splat(0.0)));
        V3x::select(ok, self.scale(rcp), V3x::ZERO)
    }

    /// All three components are 0 (`v == Vec3::ZERO`).
    #[inline(always)]
    pub fn is_zero(self) -> M16 {
        let z = F16::splat(0.0);
        self.x.eq(z).and(self.y.eq(z)).and(self.z.eq(z))
    }

    /// glam's `abs().max_element()`: max(|x|, max(|y|, |z|)).
    #[inline(always)]
    pub fn abs_max_element(self) -> F16 {
        self.x.abs().max(self.y.abs().max(self.z.abs()))
    }

    /// glam's `max_element`: max(x, max(y, z)).
    #[inline(always)]
    pub fn max_element(self) -> F16 {
        self.x.max(self.y.max(self.z))
    }

    /// glam's `Mat3 * Vec3` per lane: (x_axis·x + y_axis·y) + z_axis·z.
    #[inline(always)]
    pub fn transform(self, m: &glam::Mat3) -> V3x {
        let (a, b, c) = (m.x_axis, m.y_axis, m.z_axis);
        let col = |v: glam::Vec3, s: F16| V3x::new(s * v.x, s * v.y, s * v.z);
        col(a, self.x).add(col(b, self.y)).add(col(c, self.z))
    }

    /// Every component finite (`Vec3::is_finite`).
    #[inline(always)]
    pub fn is_finite(self) -> M16 {
        self.x
            .is_finite()
            .and(self.y.is_finite())
            .and(self.z.is_finite())
    }

    /// Lanes of `a` where `m`, of `b` elsewhere.
    #[inline(always)]
    pub fn select(m: M16, a: V3x, b: V3x) -> V3x {
        V3x::new(
            F16::select(m, a.x, b.x),
            F16::select(m, a.y, b.y),
            F16::select(m, a.z, b.z),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lane operations give glam's scalar bits, including where a branch would be taken.
    #[test]
    fn lanes_round_like_glam() {
        let mut rng = crate::math::Pcg32::new(5, 9);
        let mut a = V3x::ZERO;
        let mut b = V3x::ZERO;
        let mut av = [Vec3::ZERO; W];
        let mut bv = [Vec3::ZERO; W];
        for _ in 0..200 {
            for l in 0..W {
                let mut r = || (rng.next_f32() - 0.5) * 10.0;
                av[l] = Vec3::new(r(), r(), r());
                bv[l] = Vec3::new(r(), r(), r());
                if l == 3 {
                    av[l] = Vec3::ZERO;
                }
                a.set(l, av[l]);
                b.set(l, bv[l]);
            }
            let dot = a.dot(b);
            let cross = a.cross(b);
            let norm = a.normalize_or_zero();
            let sc = a.scale(dot);
            let dv = a.div(dot);
            for l in 0..W {
                assert_eq!(dot.0[l].to_bits(), av[l].dot(bv[l]).to_bits());
                let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                assert_eq!(bits(cross.get(l)), bits(av[l].cross(bv[l])));
                assert_eq!(bits(norm.get(l)), bits(av[l].normalize_or_zero()));
                assert_eq!(bits(sc.get(l)), bits(av[l] * av[l].dot(bv[l])));
                assert_eq!(bits(dv.get(l)), bits(av[l] / av[l].dot(bv[l])));
                assert_eq!(a.abs_max_element().0[l], av[l].abs().max_element());
                assert_eq!(a.max_element().0[l], av[l].max_element());
                assert_eq!(a.length().0[l], av[l].length());
                assert_eq!(a.is_zero().0[l], av[l] == Vec3::ZERO);
                assert_eq!(a.x.min(F16::splat(0.95)).0[l], av[l].x.min(0.95));
                let m = glam::Mat3::from_cols(av[(l + 1) % W], bv[l], av[(l + 5) % W]);
                assert_eq!(bits(b.transform(&m).get(l)), bits(m * bv[l]));
            }
        }
    }
}
