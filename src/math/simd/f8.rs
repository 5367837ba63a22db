//! Eight f32 lanes for the BVH traversal's node slab test and triangle packets, written once
//! against the [`F8`] trait: [`Avx8`] is one AVX ymm register (used only inside code compiled
//! for AVX2), [`Sse8`] two glam `Vec4`s (SSE2 on x86-64, scalar elsewhere) for the baseline build.
//!
//! Explicit vectors rather than lane loops over `[f32; 8]`: LLVM's SLP vectoriser split those
//! loops into a mix of ymm, xmm and scalar inserts (the far-plane mins and the hit mask came out
//! as 4+2+2 lanes with shuffles), losing most of the 8-wide step.
//!
//! No fused multiply-adds: both implementations round every operation the same way, so the
//! traversal returns the same bits on every CPU. `max`/`min` keep SSE's NaN rule (the second
//! operand when either is NaN), which the slab test relies on.

use glam::{BVec4A, Vec4};

/// Eight f32 lanes and the operations the traversal needs.
pub trait F8: Copy {
    /// Per-lane comparison results.
    type M: Copy + std::ops::BitAnd<Output = Self::M>;
    /// Loads eight lanes from a 32-byte aligned row.
    fn load(a: &[f32; 8]) -> Self;
    /// `x` in every lane.
    fn splat(x: f32) -> Self;
    /// Lane sum.
    fn add(self, b: Self) -> Self;
    /// Lane difference.
    fn sub(self, b: Self) -> Self;
    /// Lane product.
    fn mul(self, b: Self) -> Self;
    /// Lane quotient.
    fn div(self, b: Self) -> Self;
    /// |x| per lane.
    fn abs(self) -> Self;
    /// `self` with its sign flipped in the lanes where `s` has its sign bit set (`self ·
    /// copysign(1, s)`, exact).
    fn mul_sign(self, s: Self) -> Self;
    /// `self > b ? self : b` per lane (x86 maxps: `b` when either is NaN).
    fn max(self, b: Self) -> Self;
    /// `self < b ? self : b` per lane (x86 minps: `b` when either is NaN).
    fn min(self, b: Self) -> Self;
    /// `self <= b` per lane (false on NaN).
    fn le(self, b: Self) -> Self::M;
    /// `self >= b` per lane (false on NaN).
    fn ge(self, b: Self) -> Self::M;
    /// `self > b` per lane (false on NaN).
    fn gt(self, b: Self) -> Self::M;
    /// Bit k set if lane k of `m` is true.
    fn bitmask(m: Self::M) -> u32;
    /// The lanes as an array.
    fn to_array(self) -> [f32; 8];
}

/// Two SSE `Vec4` halves: the baseline build's eight lanes.
#[derive(Clone, Copy)]
pub struct Sse8(Vec4, Vec4);

/// Comparison result of [`Sse8`].
#[derive(Clone, Copy)]
pub struct SseM(BVec4A, BVec4A);

impl std::ops::BitAnd for SseM {
    type Output = SseM;
    #[inline(always)]
    fn bitand(self, b: SseM) -> SseM {
        SseM(self.0 & b.0, self.1 & b.1)
    }
}

impl F8 for Sse8 {
    type M = SseM;
    #[inline(always)]
    fn load(a: &[f32; 8]) -> Self {
        Sse8(
            Vec4::new(a[0], a[1], a[2], a[3]),
            Vec4::new(a[4], a[5], a[6], a[7]),
        )
    }
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Sse8(Vec4::splat(x), Vec4::splat(x))
    }
    #[inline(always)]
    fn add(self, b: Self) -> Self {
        Sse8(self.0 + b.0, self.1 + b.1)
    }
    #[inline(always)]
    fn sub(self, b: Self) -> Self {
        Sse8(self.0 - b.0, self.1 - b.1)
    }
    #[inline(always)]
    fn mul(self, b: Self) -> Self {
        Sse8(self.0 * b.0, self.1 * b.1)
    }
    #[inline(always)]
    fn div(self, b: Self) -> Self {
        Sse8(self.0 / b.0, self.1 / b.1)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Sse8(self.0.abs(), self.1.abs())
    }
    #[inline(always)]
    fn mul_sign(self, s: Self) -> Self {
        Sse8(
            self.0 * Vec4::ONE.copysign(s.0),
            self.1 * Vec4::ONE.copysign(s.1),
        )
    }
    #[inline(always)]
    fn max(self, b: Self) -> Self {
        Sse8(self.0.max(b.0), self.1.max(b.1))
    }
    #[inline(always)]
    fn min(self, b: Self) -> Self {
        Sse8(self.0.min(b.0), self.1.min(b.1))
    }
    #[inline(always)]
    fn le(self, b: Self) -> SseM {
        SseM(self.0.cmple(b.0), self.1.cmple(b.1))
    }
    #[inline(always)]
    fn ge(self, b: Self) -> SseM {
        SseM(self.0.cmpge(b.0), self.1.cmpge(b.1))
    }
    #[inline(always)]
    fn gt(self, b: Self) -> SseM {
        SseM(self.0.cmpgt(b.0), self.1.cmpgt(b.1))
    }
    #[inline(always)]
    fn bitmask(m: SseM) -> u32 {
        m.0.bitmask() | (m.1.bitmask() << 4)
    }
    #[inline(always)]
    fn to_array(self) -> [f32; 8] {
        let (a, b) = (self.0.to_array(), self.1.to_array());
        [a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]]
    }
}

#[cfg(target_arch = "x86_64")]
pub use avx::{Avx8, AvxM};

#[cfg(target_arch = "x86_64")]
mod avx {
    use super::F8;
    use std::arch::x86_64::*;

    /// One AVX ymm register. Create and use it only inside functions compiled with
    /// `#[target_feature(enable = "avx2")]` that run after [`crate::math::simd::isa`] reported
    /// AVX2 (as `geometry::accel::traverse` does), which is what makes the intrinsic calls below
    /// sound; there its `#[inline(always)]` methods inline into AVX2 code.
    #[derive(Clone, Copy)]
    pub struct Avx8(__m256);

    /// Comparison result of [`Avx8`] (all-ones lanes for true).
    #[derive(Clone, Copy)]
    pub struct AvxM(__m256);

    impl std::ops::BitAnd for AvxM {
        type Output = AvxM;
        #[inline(always)]
        fn bitand(self, b: AvxM) -> AvxM {
            // SAFETY: see `Avx8`: only reached on CPUs with AVX2.
            AvxM(unsafe { _mm256_and_ps(self.0, b.0) })
        }
    }

    // SAFETY (every `unsafe` block below): see `Avx8`: these run only in AVX2 builds of the
    // traversal on CPUs with AVX2; `load` reads exactly the eight f32 of the reference.
    impl F8 for Avx8 {
        type M = AvxM;
        #[inline(always)]
        fn load(a: &[f32; 8]) -> Self {
            Avx8(unsafe { _mm256_loadu_ps(a.as_ptr()) })
        }
        #[inline(always)]
        fn splat(x: f32) -> Self {
            Avx8(unsafe { _mm256_set1_ps(x) })
        }
        #[inline(always)]
        fn add(self, b: Self) -> Self {
            Avx8(unsafe { _mm256_add_ps(self.0, b.0) })
        }
        #[inline(always)]
        fn sub(self, b: Self) -> Self {
            Avx8(unsafe { _mm256_sub_ps(self.0, b.0) })
        }
        #[inline(always)]
        fn mul(self, b: Self) -> Self {
            Avx8(unsafe { _mm256_mul_ps(self.0, b.0) })
        }
        #[inline(always)]
        fn div(self, b: Self) -> Self {
            Avx8(unsafe { _mm256_div_ps(self.0, b.0) })
        }
        #[inline(always)]
        fn abs(self) -> Self {
            Avx8(unsafe { _mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0) })
        }
        #[inline(always)]
        fn mul_sign(self, s: Self) -> Self {
            let sign = unsafe { _mm256_and_ps(_mm256_set1_ps(-0.0), s.0) };
            Avx8(unsafe { _mm256_xor_ps(self.0, sign) })
        }
        #[inline(always)]
        fn max(self, b: Self) -> Self {
            Avx8(unsafe { _mm256_max_ps(self.0, b.0) })
        }
        #[inline(always)]
        fn min(self, b: Self) -> Self {
            Avx8(unsafe { _mm256_min_ps(self.0, b.0) })
        }
        #[inline(always)]
        fn le(self, b: Self) -> AvxM {
            AvxM(unsafe { _mm256_cmp_ps::<_CMP_LE_OQ>(self.0, b.0) })
        }
        #[inline(always)]
        fn ge(self, b: Self) -> AvxM {
            AvxM(unsafe { _mm256_cmp_ps::<_CMP_GE_OQ>(self.0, b.0) })
        }
        #[inline(always)]
        fn gt(self, b: Self) -> AvxM {
            AvxM(unsafe { _mm256_cmp_ps::<_CMP_GT_OQ>(self.0, b.0) })
        }
        #[inline(always)]
        fn bitmask(m: AvxM) -> u32 {
            (unsafe { _mm256_movemask_ps(m.0) }) as u32
        }
        #[inline(always)]
        fn to_array(self) -> [f32; 8] {
            let mut a = [0.0f32; 8];
            unsafe { _mm256_storeu_ps(a.as_mut_ptr(), self.0) };
            a
        }
    }
}
