//! One helper for the scalar code and its 16-lane twin: [`Real`] is the arithmetic the twins
//! share, implemented for `f32` (the scalar code) and [`F16`] (16 lanes), so a helper written
//! once over it compiles to both with the same operations in the same order (and so the same
//! bits per lane). Branches are written as [`Real::select`] of both sides, which for `f32` is
//! the value the branch would have produced. Functions without a lane formula of their own
//! (`exp`, `ln`, `tan`, fused multiply-add) call the scalar libm routine lane by lane.

use super::f16::{F16, M16, V2x, V3x};
use glam::{Vec2, Vec3};
use std::ops::{Add, Div, Mul, Neg, Sub};

/// A per-lane condition: `bool` for `f32`, [`M16`] for [`F16`].
pub trait Cond: Copy {
    fn splat(v: bool) -> Self;
    fn and(self, b: Self) -> Self;
    fn or(self, b: Self) -> Self;
    fn not(self) -> Self;
}

impl Cond for bool {
    #[inline(always)]
    fn splat(v: bool) -> bool {
        v
    }
    #[inline(always)]
    fn and(self, b: bool) -> bool {
        self & b
    }
    #[inline(always)]
    fn or(self, b: bool) -> bool {
        self | b
    }
    #[inline(always)]
    fn not(self) -> bool {
        !self
    }
}

impl Cond for M16 {
    #[inline(always)]
    fn splat(v: bool) -> M16 {
        M16::splat(v)
    }
    #[inline(always)]
    fn and(self, b: M16) -> M16 {
        M16::and(self, b)
    }
    #[inline(always)]
    fn or(self, b: M16) -> M16 {
        M16::or(self, b)
    }
    #[inline(always)]
    fn not(self) -> M16 {
        M16::not(self)
    }
}

/// f32 arithmetic on one lane (`f32`) or sixteen ([`F16`]).
pub trait Real:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Add<f32, Output = Self>
    + Sub<f32, Output = Self>
    + Mul<f32, Output = Self>
    + Div<f32, Output = Self>
{
    /// The condition type of comparisons.
    type Mask: Cond;
    fn splat(v: f32) -> Self;
    /// Correctly rounded √.
    fn sqrt(self) -> Self;
    fn abs(self) -> Self;
    /// `f32::min` (for a non-NaN `b`).
    fn min(self, b: Self) -> Self;
    /// `f32::max` (for a non-NaN `b`).
    fn max(self, b: Self) -> Self;
    /// `f32::clamp`: below `lo` → `lo`, then above `hi` → `hi` (NaN stays NaN).
    #[inline(always)]
    fn clamp(self, lo: f32, hi: f32) -> Self {
        let x = Self::select(self.lt(Self::splat(lo)), Self::splat(lo), self);
        Self::select(x.gt(Self::splat(hi)), Self::splat(hi), x)
    }
    /// `a` where `m`, else `b`.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    fn lt(self, b: Self) -> Self::Mask;
    fn le(self, b: Self) -> Self::Mask;
    fn gt(self, b: Self) -> Self::Mask;
    fn ge(self, b: Self) -> Self::Mask;
    fn eq(self, b: Self) -> Self::Mask;
    /// Neither infinite nor NaN.
    fn is_finite(self) -> Self::Mask;
    /// The sign bit is set (−0 included), `f32::is_sign_negative`.
    fn is_sign_negative(self) -> Self::Mask;
    /// `f32::copysign`.
    fn copysign(self, sign: Self) -> Self;
    /// libm's `expf`, lane by lane.
    fn exp(self) -> Self;
    /// libm's `logf`, lane by lane.
    fn ln(self) -> Self;
    /// libm's `tanf`, lane by lane.
    fn tan(self) -> Self;
    /// `self · a + b` with one rounding (`f32::mul_add`), lane by lane.
    fn mul_add(self, a: Self, b: Self) -> Self;
    /// (sin, cos) by [`super::approx::sin_cos`].
    fn sin_cos(self) -> (Self, Self);
    /// `f(x)` of a scalar function, lane by lane.
    fn map(self, f: impl Fn(f32) -> f32) -> Self;
    /// `f32::floor`.
    fn floor(self) -> Self;
    /// `N` 3-vectors per lane from a scalar function of the lane's `a` and `b` (a gather: texels,
    /// table entries).
    fn gather<const N: usize>(a: Self, b: Self, f: impl Fn(f32, f32) -> [Vec3; N])
    -> [V3<Self>; N];
}

impl Real for f32 {
    type Mask = bool;
    #[inline(always)]
    fn splat(v: f32) -> f32 {
        v
    }
    #[inline(always)]
    fn sqrt(self) -> f32 {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> f32 {
        f32::abs(self)
    }
    #[inline(always)]
    fn min(self, b: f32) -> f32 {
        f32::min(self, b)
    }
    #[inline(always)]
    fn max(self, b: f32) -> f32 {
        f32::max(self, b)
    }
    #[inline(always)]
    fn select(m: bool, a: f32, b: f32) -> f32 {
        if m { a } else { b }
    }
    #[inline(always)]
    fn lt(self, b: f32) -> bool {
        self < b
    }
    #[inline(always)]
    fn le(self, b: f32) -> bool {
        self <= b
    }
    #[inline(always)]
    fn gt(self, b: f32) -> bool {
        self > b
    }
    #[inline(always)]
    fn ge(self, b: f32) -> bool {
        self >= b
    }
    #[inline(always)]
    fn eq(self, b: f32) -> bool {
        self == b
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
    #[inline(always)]
    fn is_sign_negative(self) -> bool {
        f32::is_sign_negative(self)
    }
    #[inline(always)]
    fn copysign(self, sign: f32) -> f32 {
        f32::copysign(self, sign)
    }
    #[inline(always)]
    fn exp(self) -> f32 {
        f32::exp(self)
    }
    #[inline(always)]
    fn ln(self) -> f32 {
        f32::ln(self)
    }
    #[inline(always)]
    fn tan(self) -> f32 {
        f32::tan(self)
    }
    #[inline(always)]
    fn mul_add(self, a: f32, b: f32) -> f32 {
        f32::mul_add(self, a, b)
    }
    #[inline(always)]
    fn sin_cos(self) -> (f32, f32) {
        super::approx::sin_cos(self)
    }
    #[inline(always)]
    fn map(self, f: impl Fn(f32) -> f32) -> f32 {
        f(self)
    }
    #[inline(always)]
    fn floor(self) -> f32 {
        f32::floor(self)
    }
    #[inline(always)]
    fn gather<const N: usize>(a: f32, b: f32, f: impl Fn(f32, f32) -> [Vec3; N]) -> [V3<f32>; N] {
        f(a, b).map(V3::from)
    }
}

impl Real for F16 {
    type Mask = M16;
    #[inline(always)]
    fn splat(v: f32) -> F16 {
        F16::splat(v)
    }
    #[inline(always)]
    fn sqrt(self) -> F16 {
        F16::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> F16 {
        F16::abs(self)
    }
    #[inline(always)]
    fn min(self, b: F16) -> F16 {
        F16::min(self, b)
    }
    #[inline(always)]
    fn max(self, b: F16) -> F16 {
        F16::max(self, b)
    }
    #[inline(always)]
    fn select(m: M16, a: F16, b: F16) -> F16 {
        F16::select(m, a, b)
    }
    #[inline(always)]
    fn lt(self, b: F16) -> M16 {
        F16::lt(self, b)
    }
    #[inline(always)]
    fn le(self, b: F16) -> M16 {
        F16::le(self, b)
    }
    #[inline(always)]
    fn gt(self, b: F16) -> M16 {
        F16::gt(self, b)
    }
    #[inline(always)]
    fn ge(self, b: F16) -> M16 {
        F16::ge(self, b)
    }
    #[inline(always)]
    fn eq(self, b: F16) -> M16 {
        F16::eq(self, b)
    }
    #[inline(always)]
    fn is_finite(self) -> M16 {
        F16::is_finite(self)
    }
    #[inline(always)]
    fn is_sign_negative(self) -> M16 {
        M16(super::f16::lanes(|i| self.0[i].is_sign_negative()))
    }
    #[inline(always)]
    fn copysign(self, sign: F16) -> F16 {
        F16(super::f16::lanes(|i| self.0[i].copysign(sign.0[i])))
    }
    #[inline(always)]
    fn exp(self) -> F16 {
        self.map(f32::exp)
    }
    #[inline(always)]
    fn ln(self) -> F16 {
        self.map(f32::ln)
    }
    #[inline(always)]
    fn tan(self) -> F16 {
        self.map(f32::tan)
    }
    #[inline(always)]
    fn mul_add(self, a: F16, b: F16) -> F16 {
        F16(super::f16::lanes(|i| self.0[i].mul_add(a.0[i], b.0[i])))
    }
    #[inline(always)]
    fn sin_cos(self) -> (F16, F16) {
        super::approx::sin_cos_x(self)
    }
    #[inline(always)]
    fn map(self, f: impl Fn(f32) -> f32) -> F16 {
        F16(super::f16::lanes(|i| f(self.0[i])))
    }
    #[inline(always)]
    fn floor(self) -> F16 {
        F16(super::f16::lanes(|i| self.0[i].floor()))
    }
    #[inline(always)]
    fn gather<const N: usize>(a: F16, b: F16, f: impl Fn(f32, f32) -> [Vec3; N]) -> [V3<F16>; N] {
        let zero = F16::splat(0.0);
        let mut out = [V3::new(zero, zero, zero); N];
        for l in 0..super::WIDTH {
            for (o, v) in out.iter_mut().zip(f(a.0[l], b.0[l])) {
                o.x.0[l] = v.x;
                o.y.0[l] = v.y;
                o.z.0[l] = v.z;
            }
        }
        out
    }
}

/// A 2-vector of [`Real`]s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct V2<T> {
    pub x: T,
    pub y: T,
}

impl<T: Real> V2<T> {
    #[inline(always)]
    pub fn new(x: T, y: T) -> V2<T> {
        V2 { x, y }
    }

    /// glam's `length_squared`: x·x + y·y.
    #[inline(always)]
    pub fn length_squared(self) -> T {
        self.x * self.x + self.y * self.y
    }

    /// glam's `Vec2 * f32`.
    #[inline(always)]
    pub fn scale(self, s: T) -> V2<T> {
        V2::new(self.x * s, self.y * s)
    }
}

/// A 3-vector of [`Real`]s whose operations round like glam's `Vec3` ones.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct V3<T> {
    pub x: T,
    pub y: T,
    pub z: T,
}

// Named methods, not operator traits, as `f16::V3x`: the twins read left to right in the order
// glam evaluates.
#[allow(clippy::should_implement_trait)]
impl<T: Real> V3<T> {
    #[inline(always)]
    pub fn new(x: T, y: T, z: T) -> V3<T> {
        V3 { x, y, z }
    }

    /// (x·x' + y·y') + z·z', glam's order.
    #[inline(always)]
    pub fn dot(self, b: V3<T>) -> T {
        (self.x * b.x) + (self.y * b.y) + (self.z * b.z)
    }

    #[inline(always)]
    pub fn add(self, b: V3<T>) -> V3<T> {
        V3::new(self.x + b.x, self.y + b.y, self.z + b.z)
    }

    #[inline(always)]
    pub fn sub(self, b: V3<T>) -> V3<T> {
        V3::new(self.x - b.x, self.y - b.y, self.z - b.z)
    }

    #[inline(always)]
    pub fn neg(self) -> V3<T> {
        V3::new(-self.x, -self.y, -self.z)
    }

    /// glam's `Vec3 * f32`.
    #[inline(always)]
    pub fn scale(self, s: T) -> V3<T> {
        V3::new(self.x * s, self.y * s, self.z * s)
    }

    /// Component-wise product.
    #[inline(always)]
    pub fn mul(self, b: V3<T>) -> V3<T> {
        V3::new(self.x * b.x, self.y * b.y, self.z * b.z)
    }

    /// glam's `normalize`: v · (1 / |v|).
    #[inline(always)]
    pub fn normalize(self) -> V3<T> {
        self.scale(T::splat(1.0) / self.dot(self).sqrt())
    }

    /// `a` where `m`, else `b`.
    #[inline(always)]
    pub fn select(m: T::Mask, a: V3<T>, b: V3<T>) -> V3<T> {
        V3::new(
            T::select(m, a.x, b.x),
            T::select(m, a.y, b.y),
            T::select(m, a.z, b.z),
        )
    }

    /// Every component finite (`Vec3::is_finite`).
    #[inline(always)]
    pub fn is_finite(self) -> T::Mask {
        self.x
            .is_finite()
            .and(self.y.is_finite())
            .and(self.z.is_finite())
    }
}

impl From<Vec3> for V3<f32> {
    #[inline(always)]
    fn from(v: Vec3) -> V3<f32> {
        V3::new(v.x, v.y, v.z)
    }
}

impl From<V3<f32>> for Vec3 {
    #[inline(always)]
    fn from(v: V3<f32>) -> Vec3 {
        Vec3::new(v.x, v.y, v.z)
    }
}

impl From<V3x> for V3<F16> {
    #[inline(always)]
    fn from(v: V3x) -> V3<F16> {
        V3::new(v.x, v.y, v.z)
    }
}

impl From<V3<F16>> for V3x {
    #[inline(always)]
    fn from(v: V3<F16>) -> V3x {
        V3x::new(v.x, v.y, v.z)
    }
}

impl From<Vec2> for V2<f32> {
    #[inline(always)]
    fn from(v: Vec2) -> V2<f32> {
        V2::new(v.x, v.y)
    }
}

impl From<V2<f32>> for Vec2 {
    #[inline(always)]
    fn from(v: V2<f32>) -> Vec2 {
        Vec2::new(v.x, v.y)
    }
}

impl From<V2x> for V2<F16> {
    #[inline(always)]
    fn from(v: V2x) -> V2<F16> {
        V2::new(v.x, v.y)
    }
}

impl From<V2<F16>> for V2x {
    #[inline(always)]
    fn from(v: V2<F16>) -> V2x {
        V2x { x: v.x, y: v.y }
    }
}
