//! Four f32 lanes ([`F4`]): one SSE register on x86_64 (SSE2 is part of the x86_64 baseline,
//! so it needs no runtime detection), plain arrays elsewhere. The PLM-C evaluation kernel puts
//! the R, G, B and a pad lane of one view in it. Only the operations that kernel needs.
//!
//! [`F4::mul_add`] is fused (one rounding per lane) in every build: one `vfmadd` where the
//! caller is compiled with FMA, libm's `fmaf` elsewhere, so the builds return the same bits.
//! Its exp2 and log2 are [`super::approx::fused_exp2_f4`] and [`super::approx::fused_log2_f4`].

#[cfg(target_arch = "x86_64")]
use core::arch::x86_64::*;

/// Four f32 lanes.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct F4(pub(super) __m128);

/// Four f32 lanes.
#[cfg(not(target_arch = "x86_64"))]
#[derive(Clone, Copy)]
#[repr(C, align(16))]
pub struct F4(pub(super) [f32; 4]);

impl F4 {
    /// `self · b + c` rounded once per lane (`f32::mul_add`, llvm.fma): one `vfmadd…ps` where
    /// the caller is compiled with FMA, libm's `fmaf` elsewhere (slow, but only CPUs from
    /// before FMA (2013) take it). Not `_mm_fmadd_ps`: a `#[target_feature]` intrinsic is never
    /// inlined into a feature-less method, so it would stay a function call per multiply-add.
    #[inline(always)]
    pub fn mul_add(self, b: F4, c: F4) -> F4 {
        let (a, b, c) = (self.to_array(), b.to_array(), c.to_array());
        F4::from_array([
            a[0].mul_add(b[0], c[0]),
            a[1].mul_add(b[1], c[1]),
            a[2].mul_add(b[2], c[2]),
            a[3].mul_add(b[3], c[3]),
        ])
    }
}

#[cfg(target_arch = "x86_64")]
impl F4 {
    /// All lanes `x`.
    #[inline(always)]
    pub fn splat(x: f32) -> Self {
        // SAFETY: SSE and SSE2 are x86_64 baseline features, always enabled.
        unsafe { F4(_mm_set1_ps(x)) }
    }
    /// From an array (lane by lane: no round trip through memory for values in registers).
    #[inline(always)]
    pub fn from_array(a: [f32; 4]) -> Self {
        // SAFETY: SSE and SSE2 are x86_64 baseline features, always enabled.
        unsafe { F4(_mm_setr_ps(a[0], a[1], a[2], a[3])) }
    }
    /// The first 4 values of a slice as one (unaligned) vector load.
    #[inline(always)]
    pub fn load(s: &[f32]) -> Self {
        let a: [f32; 4] = [s[0], s[1], s[2], s[3]];
        F4(bytemuck::cast(a))
    }
    /// To an array.
    #[inline(always)]
    pub fn to_array(self) -> [f32; 4] {
        bytemuck::cast(self.0)
    }
    /// Three `[ρ, Dx, Dy, Dz, n, …]` records (R, G, B) transposed to lanes ρ, Dx, Dy, Dz, n
    /// (pad lane 0): two vector loads per record and a 4 × 4 shuffle transpose.
    #[inline(always)]
    pub fn transpose3(r: &[f32; 8], g: &[f32; 8], b: &[f32; 8]) -> [F4; 5] {
        let (r0, g0, b0) = (
            F4::load(&r[..4]).0,
            F4::load(&g[..4]).0,
            F4::load(&b[..4]).0,
        );
        // SAFETY: SSE and SSE2 are x86_64 baseline features, always enabled.
        unsafe {
            let z = _mm_setzero_ps();
            let t0 = _mm_unpacklo_ps(r0, g0); // r0 g0 r1 g1
            let t1 = _mm_unpacklo_ps(b0, z); // b0 0 b1 0
            let t2 = _mm_unpackhi_ps(r0, g0); // r2 g2 r3 g3
            let t3 = _mm_unpackhi_ps(b0, z); // b2 0 b3 0
            let rg_n = _mm_unpacklo_ps(_mm_set_ss(r[4]), _mm_set_ss(g[4])); // nr ng 0 0
            [
                F4(_mm_movelh_ps(t0, t1)),
                F4(_mm_movehl_ps(t1, t0)),
                F4(_mm_movelh_ps(t2, t3)),
                F4(_mm_movehl_ps(t3, t2)),
                F4(_mm_movelh_ps(rg_n, _mm_set_ss(b[4]))),
            ]
        }
    }
    /// Lane-wise minimum (`self` where either is NaN... as `minps`: the second operand).
    #[inline(always)]
    pub fn min(self, o: Self) -> Self {
        // SAFETY: SSE and SSE2 are x86_64 baseline features, always enabled.
        unsafe { F4(_mm_min_ps(self.0, o.0)) }
    }
    /// Lane-wise maximum (as `maxps`: `o` where either is NaN).
    #[inline(always)]
    pub fn max(self, o: Self) -> Self {
        // SAFETY: SSE and SSE2 are x86_64 baseline features, always enabled.
        unsafe { F4(_mm_max_ps(self.0, o.0)) }
    }
    /// `self > o ? a : 0` per lane.
    #[inline(always)]
    pub fn gt_or_zero(self, o: Self, a: Self) -> Self {
        // SAFETY: SSE and SSE2 are x86_64 baseline features, always enabled.
        unsafe { F4(_mm_and_ps(_mm_cmpgt_ps(self.0, o.0), a.0)) }
    }
    /// `self <= o ? a : b` per lane.
    #[inline(always)]
    pub fn le_select(self, o: Self, a: Self, b: Self) -> Self {
        // SAFETY: SSE and SSE2 are x86_64 baseline features, always enabled.
        unsafe {
            let m = _mm_cmple_ps(self.0, o.0);
            F4(_mm_or_ps(_mm_and_ps(m, a.0), _mm_andnot_ps(m, b.0)))
        }
    }
}

#[cfg(not(target_arch = "x86_64"))]
impl F4 {
    /// All lanes `x`.
    #[inline(always)]
    pub fn splat(x: f32) -> Self {
        F4([x; 4])
    }
    /// From an array.
    #[inline(always)]
    pub fn from_array(a: [f32; 4]) -> Self {
        F4(a)
    }
    /// To an array.
    #[inline(always)]
    pub fn to_array(self) -> [f32; 4] {
        self.0
    }
    /// The first 4 values of a slice.
    #[inline(always)]
    pub fn load(s: &[f32]) -> Self {
        F4([s[0], s[1], s[2], s[3]])
    }
    /// Three `[ρ, Dx, Dy, Dz, n, …]` records (R, G, B) transposed to lanes ρ, Dx, Dy, Dz, n
    /// (pad lane 0).
    #[inline(always)]
    pub fn transpose3(r: &[f32; 8], g: &[f32; 8], b: &[f32; 8]) -> [F4; 5] {
        std::array::from_fn(|p| F4([r[p], g[p], b[p], 0.0]))
    }
    /// Lane-wise minimum (as `minps`: the second operand where either is NaN).
    #[inline(always)]
    pub fn min(self, o: Self) -> Self {
        F4(std::array::from_fn(|i| {
            if self.0[i] < o.0[i] {
                self.0[i]
            } else {
                o.0[i]
            }
        }))
    }
    /// Lane-wise maximum (as `maxps`: the second operand where either is NaN).
    #[inline(always)]
    pub fn max(self, o: Self) -> Self {
        F4(std::array::from_fn(|i| {
            if self.0[i] > o.0[i] {
                self.0[i]
            } else {
                o.0[i]
            }
        }))
    }
    /// `self > o ? a : 0` per lane.
    #[inline(always)]
    pub fn gt_or_zero(self, o: Self, a: Self) -> Self {
        F4(std::array::from_fn(|i| {
            if self.0[i] > o.0[i] { a.0[i] } else { 0.0 }
        }))
    }
    /// `self <= o ? a : b` per lane.
    #[inline(always)]
    pub fn le_select(self, o: Self, a: Self, b: Self) -> Self {
        F4(std::array::from_fn(|i| {
            if self.0[i] <= o.0[i] { a.0[i] } else { b.0[i] }
        }))
    }
}

macro_rules! binop {
    ($tr:ident, $f:ident, $sse:ident, $op:tt) => {
        impl std::ops::$tr for F4 {
            type Output = F4;
            #[inline(always)]
            fn $f(self, o: F4) -> F4 {
                // SAFETY: SSE is an x86_64 baseline feature, always enabled.
                #[cfg(target_arch = "x86_64")]
                unsafe {
                    F4($sse(self.0, o.0))
                }
                #[cfg(not(target_arch = "x86_64"))]
                {
                    F4(std::array::from_fn(|i| self.0[i] $op o.0[i]))
                }
            }
        }
    };
}
binop!(Add, add, _mm_add_ps, +);
binop!(Sub, sub, _mm_sub_ps, -);
binop!(Mul, mul, _mm_mul_ps, *);
binop!(Div, div, _mm_div_ps, /);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lane_operations() {
        let a = F4::from_array([1.0, -2.0, 3.0, 0.0]);
        let z = F4::splat(0.0);
        assert_eq!(
            a.gt_or_zero(z, F4::splat(5.0)).to_array(),
            [5.0, 0.0, 5.0, 0.0]
        );
        assert_eq!(
            a.le_select(F4::splat(1.0), z, F4::splat(7.0)).to_array(),
            [0.0, 0.0, 7.0, 0.0]
        );
        assert_eq!(
            a.max(z).min(F4::splat(2.0)).to_array(),
            [1.0, 0.0, 2.0, 0.0]
        );
        // One rounding: 1 + 2^-23 squared is 1 + 2^-22 + 2^-46, which a separate multiply
        // would round to 1 + 2^-22 before subtracting it.
        let e = 1.0 + f32::EPSILON;
        let r = F4::splat(e).mul_add(F4::splat(e), F4::splat(-(1.0 + 2.0 * f32::EPSILON)));
        assert_eq!(r.to_array(), [f32::EPSILON * f32::EPSILON; 4]);
        let rec =
            |o: f32| std::array::from_fn::<f32, 8, _>(|i| if i < 5 { o + i as f32 } else { 0.0 });
        let t = F4::transpose3(&rec(10.0), &rec(20.0), &rec(30.0));
        for p in 0..5 {
            let p32 = p as f32;
            assert_eq!(t[p].to_array(), [10.0 + p32, 20.0 + p32, 30.0 + p32, 0.0]);
        }
        assert_eq!(
            F4::load(&[1.0, 2.0, 3.0, 4.0, 5.0]).to_array(),
            [1.0, 2.0, 3.0, 4.0]
        );
    }
}
