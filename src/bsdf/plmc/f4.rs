//! Four f32 lanes (R, G, B, pad of one view) for the evaluation kernel: one SSE register on
//! x86_64 (SSE2 is part of the x86_64 baseline, so no runtime detection), plain arrays elsewhere.
//! Only the operations the kernel needs, including the branch-free exp2/log2 bit tricks.
//!
//! Multiply-adds go through an [`Isa`] token: [`Sse2`] (mul then add, the baseline) or, on CPUs
//! that have them, [`Avx2Fma`] (one fused `vfmadd`, half the latency of the dependent chains);
//! code generic over the token is compiled for AVX2+FMA inside a `#[target_feature]` function.

#[cfg(target_arch = "x86_64")]
use core::arch::x86_64::*;

/// Four f32 lanes.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct F4(__m128);

/// Four f32 lanes.
#[cfg(not(target_arch = "x86_64"))]
#[derive(Clone, Copy)]
#[repr(C, align(16))]
pub struct F4([f32; 4]);

/// How `a · b + c` is computed: the instruction set a kernel instance is compiled for.
pub trait Isa: Copy + std::fmt::Debug {
    /// `a · b + c` lane-wise (fused or not).
    fn fma(self, a: F4, b: F4, c: F4) -> F4;
}

/// `a · b + c` rounded once per lane (`f32::mul_add`, llvm.fma): one `vfmadd` where the caller
/// is compiled with FMA, libm's `fmaf` elsewhere. Every [`Isa`] uses it, so the builds agree.
#[inline(always)]
fn fused_lanes(a: F4, b: F4, c: F4) -> F4 {
    let (a, b, c) = (a.to_array(), b.to_array(), c.to_array());
    F4::from_array([
        a[0].mul_add(b[0], c[0]),
        a[1].mul_add(b[1], c[1]),
        a[2].mul_add(b[2], c[2]),
        a[3].mul_add(b[3], c[3]),
    ])
}

/// The x86_64 baseline (or plain lanes elsewhere). Its multiply-add is fused too, in software
/// where the CPU has no FMA unit (`mul_add`, which rounds once by definition), so every build
/// of the kernel returns the same bits: slow, but only CPUs from before FMA (2013) take it.
#[derive(Clone, Copy, Debug)]
pub struct Sse2;

impl Isa for Sse2 {
    #[inline(always)]
    fn fma(self, a: F4, b: F4, c: F4) -> F4 {
        fused_lanes(a, b, c)
    }
}

/// Proof that the CPU has AVX2 and FMA: only [`Avx2Fma::detect`] makes one.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
pub struct Avx2Fma(());

#[cfg(target_arch = "x86_64")]
impl Avx2Fma {
    /// The token if this CPU supports AVX2 and FMA (runtime detection, cached by std).
    pub fn detect() -> Option<Self> {
        (is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")).then_some(Avx2Fma(()))
    }
}

#[cfg(target_arch = "x86_64")]
impl Isa for Avx2Fma {
    #[inline(always)]
    fn fma(self, a: F4, b: F4, c: F4) -> F4 {
        // Lane-wise `mul_add` (llvm.fma), which the `fma`-enabled caller compiles to one
        // `vfmadd…ps`. Not `_mm_fmadd_ps`: a `#[target_feature]` intrinsic is never inlined
        // into this feature-less method, so it stays a function call per multiply-add.
        fused_lanes(a, b, c)
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
    /// 2^x for x in [−125, 127] (clamped): round-to-nearest split, degree-6 series on [−½, ½].
    #[inline(always)]
    pub fn exp2<I: Isa>(self, isa: I) -> Self {
        // SAFETY: SSE and SSE2 are x86_64 baseline features, always enabled.
        unsafe {
            let x = self.max(F4::splat(-125.0)).min(F4::splat(127.0));
            let i = _mm_cvtps_epi32(x.0); // round to nearest (default MXCSR)
            let f = x - F4(_mm_cvtepi32_ps(i));
            let p = exp2_poly(isa, f);
            F4(_mm_castsi128_ps(_mm_add_epi32(
                _mm_castps_si128(p.0),
                _mm_slli_epi32::<23>(i),
            )))
        }
    }
    /// log2 of positive normal lanes: exponent + odd series in (m−1)/(m+1) on [√½, √2).
    #[inline(always)]
    pub fn log2<I: Isa>(self, isa: I) -> Self {
        // SAFETY: SSE and SSE2 are x86_64 baseline features, always enabled.
        unsafe {
            let bits = _mm_castps_si128(self.0);
            let e = _mm_sub_epi32(
                _mm_and_si128(_mm_srli_epi32::<23>(bits), _mm_set1_epi32(0xff)),
                _mm_set1_epi32(127),
            );
            let m = F4(_mm_castsi128_ps(_mm_or_si128(
                _mm_and_si128(bits, _mm_set1_epi32(0x007f_ffff)),
                _mm_set1_epi32(0x3f80_0000),
            )));
            let big = _mm_cmpgt_ps(m.0, _mm_set1_ps(std::f32::consts::SQRT_2));
            // m ← m/2 and e ← e+1 where big (the mask is −1 as an integer).
            let m = F4(_mm_or_ps(
                _mm_and_ps(big, (m * F4::splat(0.5)).0),
                _mm_andnot_ps(big, m.0),
            ));
            let e = _mm_sub_epi32(e, _mm_castps_si128(big));
            log2_series(isa, m, F4(_mm_cvtepi32_ps(e)))
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
    /// 2^x for x in [−125, 127] (clamped): round-to-nearest split, degree-6 series on [−½, ½].
    #[inline(always)]
    pub fn exp2<I: Isa>(self, isa: I) -> Self {
        let x = self.max(F4::splat(-125.0)).min(F4::splat(127.0));
        let i = x.0.map(|v| v.round_ties_even() as i32);
        let f = x - F4(i.map(|v| v as f32));
        let p = exp2_poly(isa, f);
        F4(std::array::from_fn(|k| {
            f32::from_bits((p.0[k].to_bits() as i32).wrapping_add(i[k] << 23) as u32)
        }))
    }
    /// log2 of positive normal lanes: exponent + odd series in (m−1)/(m+1) on [√½, √2).
    #[inline(always)]
    pub fn log2<I: Isa>(self, isa: I) -> Self {
        let mut e = [0f32; 4];
        let mut m = [0f32; 4];
        for k in 0..4 {
            let bits = self.0[k].to_bits();
            let mut ek = ((bits >> 23) & 0xff) as i32 - 127;
            let mut mk = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
            if mk > std::f32::consts::SQRT_2 {
                mk *= 0.5;
                ek += 1;
            }
            e[k] = ek as f32;
            m[k] = mk;
        }
        log2_series(isa, F4(m), F4(e))
    }
}

/// (ln 2)^k / k! for k = 1..6: the series coefficients of [`exp2_poly`] after the constant 1
/// (shared with the AVX-512 kernel, which evaluates the same series in the same order).
pub(super) const EXP2_COEFFS: [f32; 6] = {
    let l = std::f32::consts::LN_2;
    [
        l,
        l * l / 2.0,
        l * l * l / 6.0,
        l * l * l * l / 24.0,
        l * l * l * l * l / 120.0,
        l * l * l * l * l * l / 720.0,
    ]
};

/// 2^f on [−½, ½]: degree-6 Taylor series of e^(f ln 2) (relative error < 3e-7), in Estrin
/// form (three independent pairs, then f² and f⁴ combine them: 3 dependent steps, not 6).
#[inline(always)]
fn exp2_poly<I: Isa>(isa: I, f: F4) -> F4 {
    let c = EXP2_COEFFS;
    let s = F4::splat;
    let f2 = f * f;
    let p01 = isa.fma(s(c[0]), f, s(1.0)); // 1 + c1 f
    let p23 = isa.fma(s(c[2]), f, s(c[1])); // c2 + c3 f
    let p45 = isa.fma(s(c[4]), f, s(c[3])); // c4 + c5 f
    let q = isa.fma(s(c[5]), f2, p45); // c4 + c5 f + c6 f²
    let q = isa.fma(q, f2, p23);
    isa.fma(q, f2, p01)
}

/// `e` + log2 m for m in [√½, √2): 2/ln 2 · atanh t, t = (m−1)/(m+1), odd series to t⁹.
#[inline(always)]
fn log2_series<I: Isa>(isa: I, m: F4, e: F4) -> F4 {
    let one = F4::splat(1.0);
    let t = (m - one) / (m + one);
    let t2 = t * t;
    const C: f32 = 2.0 / std::f32::consts::LN_2;
    let s = F4::splat;
    // Estrin in t²: (C + C/3 t²) + t⁴ ((C/5 + C/7 t²) + t⁴ C/9).
    let t4 = t2 * t2;
    let lo = isa.fma(s(C / 3.0), t2, s(C));
    let hi = isa.fma(s(C / 7.0), t2, s(C / 5.0));
    let hi = isa.fma(s(C / 9.0), t4, hi);
    isa.fma(isa.fma(hi, t4, lo), t, e)
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
    fn lanes_match_the_scalar_kernels() {
        let mut rng = crate::math::Pcg32::new(11, 2);
        for _ in 0..20_000 {
            let x: [f32; 4] = std::array::from_fn(|_| (rng.next_f32() - 0.5) * 60.0);
            let b: [f32; 4] = std::array::from_fn(|_| (-20.0 * rng.next_f32()).exp2() * 3.0);
            check_exp2_log2(Sse2, x, b);
            #[cfg(target_arch = "x86_64")]
            if let Some(isa) = Avx2Fma::detect() {
                check_exp2_log2(isa, x, b);
            }
        }
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
        assert_eq!(exp2_check(), [1.0, 0.125, 1024.0, 0.5]);
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

    fn exp2_check() -> [f32; 4] {
        F4::from_array([0.0, -3.0, 10.0, -1.0])
            .exp2(Sse2)
            .to_array()
    }

    /// exp2 and log2 of `isa` against f64 libm.
    fn check_exp2_log2<I: Isa>(isa: I, x: [f32; 4], b: [f32; 4]) {
        let e = F4::from_array(x).exp2(isa).to_array();
        let l = F4::from_array(b).log2(isa).to_array();
        for k in 0..4 {
            let want = (x[k] as f64).exp2();
            assert!(
                ((e[k] as f64 - want) / want).abs() < 3e-7,
                "exp2({}) {isa:?}",
                x[k]
            );
            // The series is good to ~1e-7; the f32 sum adds half an ulp of the result.
            let lw = (b[k] as f64).log2();
            assert!(
                (l[k] as f64 - lw).abs() < 2e-7 + 1.2e-7 * lw.abs(),
                "log2({}) {isa:?}",
                b[k]
            );
        }
    }
}
