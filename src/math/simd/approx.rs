//! Every polynomial approximation of a transcendental function in the crate, each written once,
//! with its error bound and where it is used. Instead of libm on hot paths: branch-free (selects,
//! not jumps, so a loop over lanes vectorises) and, apart from the fused family, free of fused
//! multiply-adds, so every instruction set returns the same bits.
//!
//! | function | form | error (f32 inputs against f64) | used by |
//! |---|---|---|---|
//! | [`sin_cos`] | Cody–Waite reduction, Cephes minimax | ≤ 2.5e-7 absolute, \|x\| ≤ 8192 | warps, spheres, light sampling, lobes |
//! | [`exp2`] | n + f split, degree-6 Horner | < 3e-7 relative (normal results) | PLM-C lobes and tables, filters |
//! | [`log2`] | e + atanh series to t⁹, Horner | < 3e-7 absolute near 1, relative elsewhere | PLM-C lobes and tables |
//! | [`exp`] | x·log2 e split, degree-6 Horner in f·ln 2 | < 4e-7 + \|x\|·1.2e-7 relative | the lobe fitter |
//! | [`ln`] | e·ln 2 + 2 atanh series to s⁹ | < 3e-7 · max(1, \|ln x\|) | the lobe fitter |
//! | [`atan2`] | octant reduction, Cephes `atanf` | ≤ 2e-7 absolute | the environment map |
//! | [`fused_exp2_f4`], [`fused_exp2_16`] | as [`exp2`], Estrin, fused | < 3e-7 relative | the PLM-C evaluation kernels |
//! | [`fused_log2_f4`], [`fused_log2_16`] | as [`log2`], Estrin, fused | < 2e-7 + 1.2e-7·\|log2 x\| | the PLM-C evaluation kernels |
//!
//! Why several of one function: the unfused ones ([`exp2`], [`log2`]) handle every input (0, ∞,
//! NaN, subnormals) and compute the same bits in scalar code and in any 16-lane build, which the
//! packet integrator's lane-for-lane equality with the scalar one needs. The fused ones serve
//! the PLM-C evaluation kernel: Estrin form and fused multiply-adds halve the latency of its
//! dependent chains, the inputs are positive normal floats by construction, and every build of
//! that kernel fuses the same operations (docs/architecture.md, "Determinism across CPUs"); the
//! F4 and the AVX-512 versions compute the same bits. [`exp`] and [`ln`] are the fitter's: the
//! same series in another base and order, kept because the fitted models depend on their bits.
//! Each function's `_x` form ([`sin_cos_x`], [`atan2_x`], …) runs it over the 16 lanes of an
//! [`F16`], with the same bits per lane.

use super::WIDTH;
use super::f4::F4;
use super::f16::{F16, lanes};

#[cfg(target_arch = "x86_64")]
use core::arch::x86_64::*;

/// π/2 in three parts (Cody–Waite): the first two have few mantissa bits, so j·part is exact.
const PIO2_1: f32 = 1.570_312_5;
const PIO2_2: f32 = 4.837_513e-4;
const PIO2_3: f32 = 7.549_79e-8;

/// 1.5 · 2²³: adding and subtracting it rounds |x| < 2²² to the nearest integer (ties to even)
/// in any ISA's plain adds, and leaves that integer in the low mantissa bits of the sum.
const ROUND_MAGIC: f32 = 12_582_912.0;

/// (ln 2)^k / k!, k = 1..6: the Taylor series of 2^f = e^(f ln 2) after the 1 (of [`exp2`] and
/// the fused exp2).
const EXP2_COEFFS: [f32; 6] = {
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

/// 2/ln 2: log2 m = 2/ln 2 · atanh t, t = (m − 1)/(m + 1) (of [`log2`] and the fused log2).
const LOG2_ATANH: f32 = 2.0 / std::f32::consts::LN_2;

// ---- Unfused, every input: the same bits in scalar code and in every 16-lane build ----

/// (sin x, cos x): x reduced to r ∈ [−π/4, π/4] by the nearest multiple j of π/2, Cephes'
/// minimax polynomials on r, then the quadrant j mod 4 swaps and negates them. Error ≤ 2.5e-7
/// absolute for |x| ≤ 8192.
#[inline(always)]
pub fn sin_cos(x: f32) -> (f32, f32) {
    let jm = x * std::f32::consts::FRAC_2_PI + ROUND_MAGIC;
    let j = jm - ROUND_MAGIC;
    let r = ((x - j * PIO2_1) - j * PIO2_2) - j * PIO2_3;
    let z = r * r;
    let s = r + r * z * (-1.666_665_5e-1 + z * (8.332_161e-3 + z * -1.951_529_6e-4));
    let c = 1.0 - 0.5 * z + z * z * (4.166_664_6e-2 + z * (-1.388_731_6e-3 + z * 2.443_315_7e-5));
    let q = jm.to_bits() & 3;
    let (sv, cv) = if q & 1 == 0 { (s, c) } else { (c, s) };
    let sin = if q & 2 == 0 { sv } else { -sv };
    let cos = if (q + 1) & 2 == 0 { cv } else { -cv };
    (sin, cos)
}

/// 2^x = 2^n · 2^f with n = round(x), f ∈ [−½, ½] by the degree-6 series; the exponent is
/// built in the float's bits. Relative error < 3e-7 for normal results; 0 below −127, ∞ from
/// 128, NaN stays NaN.
#[inline(always)]
pub fn exp2(x: f32) -> f32 {
    let xc = x.clamp(-127.0, 128.0);
    let nm = xc + ROUND_MAGIC;
    let f = xc - (nm - ROUND_MAGIC);
    let c = EXP2_COEFFS;
    let p = 1.0 + f * (c[0] + f * (c[1] + f * (c[2] + f * (c[3] + f * (c[4] + f * c[5])))));
    // n ∈ [−127, 128]: split 2^n in two factors so both stay normal (2^−127 = 2^−63 · 2^−64).
    let n = nm.to_bits() as i32 - ROUND_MAGIC.to_bits() as i32;
    let h = n >> 1;
    let a = f32::from_bits(((h + 127) as u32) << 23);
    let b = f32::from_bits(((n - h + 127) as u32) << 23);
    let v = p * a * b;
    let v = if x < -127.0 { 0.0 } else { v };
    let v = if x >= 128.0 { f32::INFINITY } else { v };
    if x.is_nan() { x } else { v }
}

/// log2 x = e + log2 m, m ∈ [√½, √2) from the float's bits (subnormals scaled by 2²⁴ first),
/// log2 m = 2/ln 2 · atanh t, t = (m − 1)/(m + 1), odd series to t⁹. Error < 3e-7 absolute
/// near 1, < 2e-7 relative elsewhere; −∞ at 0, NaN below 0, subnormals exact.
#[inline(always)]
pub fn log2(x: f32) -> f32 {
    let sub = x < f32::MIN_POSITIVE;
    let xs = if sub { x * 16_777_216.0 } else { x };
    let bits = xs.to_bits();
    let mut e = ((bits >> 23) & 0xff) as i32 - 127;
    let mut m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    let big = m > std::f32::consts::SQRT_2;
    m = if big { m * 0.5 } else { m };
    e += big as i32;
    let e = e as f32 - if sub { 24.0 } else { 0.0 };
    let t = (m - 1.0) / (m + 1.0);
    let t2 = t * t;
    const K: f32 = LOG2_ATANH;
    let s = t * (K + t2 * (K / 3.0 + t2 * (K / 5.0 + t2 * (K / 7.0 + t2 * (K / 9.0)))));
    let v = e + s;
    let v = if x == 0.0 { f32::NEG_INFINITY } else { v };
    let v = if x == f32::INFINITY { x } else { v };
    if x < 0.0 || x.is_nan() { f32::NAN } else { v }
}

/// eˣ for x ∈ [−87, 88] (clamped): t = x·log2 e split into n + f' by [`ROUND_MAGIC`], then the
/// degree-6 series of e^f with f = f'·ln 2. Relative error < 4e-7 + |x|·1.2e-7 (the f32
/// rounding of x·log2 e alone costs |x|·6e-8).
#[inline(always)]
pub fn exp(x: f32) -> f32 {
    let t = x.clamp(-87.0, 88.0) * std::f32::consts::LOG2_E;
    let shifted = t + ROUND_MAGIC;
    let i = shifted.to_bits() as i32 - ROUND_MAGIC.to_bits() as i32;
    let f = (t - (shifted - ROUND_MAGIC)) * std::f32::consts::LN_2; // in [-ln2/2, ln2/2]
    let p = 1.0
        + f * (1.0
            + f * (0.5
                + f * (1.0 / 6.0 + f * (1.0 / 24.0 + f * (1.0 / 120.0 + f * (1.0 / 720.0))))));
    p * f32::from_bits(((i + 127) as u32) << 23)
}

/// ln x for positive normal x: e·ln 2 + 2 atanh s, s = (m − 1)/(m + 1), m ∈ [√½, √2), odd
/// series to s⁹. Error < 3e-7 · max(1, |ln x|).
#[inline(always)]
pub fn ln(x: f32) -> f32 {
    let bits = x.to_bits();
    let mut e = ((bits >> 23) & 0xff) as i32 - 127;
    let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    // Move m from [1, 2) into [√½, √2) so the series argument stays small.
    let big = m > std::f32::consts::SQRT_2;
    let m = if big { 0.5 * m } else { m };
    e += big as i32;
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    let series = 1.0 + s2 * (1.0 / 3.0 + s2 * (1.0 / 5.0 + s2 * (1.0 / 7.0 + s2 * (1.0 / 9.0))));
    e as f32 * std::f32::consts::LN_2 + 2.0 * s * series
}

/// k·π/4 for k = 0..4 rounded to f32 (high parts) and the remainders k·π/4 − high (low parts):
/// every atan2 result is one of these plus or minus atan of a reduced argument. Padded to 8 so
/// the index can be masked instead of bounds-checked.
const QUARTER_PI_HI: [f32; 8] = [
    0.0,
    std::f32::consts::FRAC_PI_4,
    std::f32::consts::FRAC_PI_2,
    2.356_194_5,
    std::f32::consts::PI,
    0.0,
    0.0,
    0.0,
];
const QUARTER_PI_LO: [f32; 8] = [
    0.0,
    -2.185_569_5e-8,
    -4.371_139e-8,
    -5.962_440_3e-9,
    -8.742_278e-8,
    0.0,
    0.0,
    0.0,
];
/// tan(π/8): above it the atan argument is moved by π/4.
const TAN_PI_8: f32 = 0.414_213_57;

/// Cephes `atanf`: atan(q) ≈ q + q·z·P(z), z = q², for |q| ≤ tan(π/8).
#[inline(always)]
fn atan_poly(q: f32) -> f32 {
    let z = q * q;
    let p = ((8.053_744_5e-2 * z - 1.387_768_6e-1) * z + 1.997_771_1e-1) * z - 3.333_295e-1;
    q + q * z * p
}

/// `if c { a } else { b }` by masks on the bits (LLVM may still make it a branch; see
/// [`gt_mask`]).
#[inline(always)]
fn select(c: bool, a: f32, b: f32) -> f32 {
    blend((c as u32).wrapping_neg(), a, b)
}

/// All ones if a > b, else 0, for finite a, b: the sign of b − a (exact: a float difference is
/// negative exactly when b < a, with gradual underflow), spread by an arithmetic shift. Not a
/// comparison, so that LLVM does not turn the blends it feeds into branches (it does for selects
/// next to a division or square root, and these conditions depend on random directions, so they
/// would mispredict).
#[inline(always)]
fn gt_mask(a: f32, b: f32) -> u32 {
    ((b - a).to_bits() as i32 >> 31) as u32
}

/// a where the mask `m` is all ones, b where it is 0.
#[inline(always)]
fn blend(m: u32, a: f32, b: f32) -> f32 {
    f32::from_bits((a.to_bits() & m) | (b.to_bits() & !m))
}

/// a where the mask `m` is all ones, 0 where it is 0.
#[inline(always)]
fn and(a: f32, m: u32) -> f32 {
    f32::from_bits(a.to_bits() & m)
}

/// atan2(y, x) in radians, in [−π, π], within 2e-7 of the exact value for finite inputs, with
/// libm's signed-zero conventions (atan2(±0, +0) = ±0, atan2(±0, −0) = ±π); NaN if either
/// input is NaN. Both inputs infinite is not supported (NaN). Branch-free: the argument is
/// reduced to |q| ≤ tan(π/8) by the octant symmetries and atan(a) = π/4 + atan((a − 1)/(a + 1)),
/// the cases chosen with bit masks, and the multiples of π/4 added as a high and a low part.
/// Instead of libm's `atan2f`/`acosf` in the environment map's lat-long mapping, where they cost
/// more than the rest of the lookup.
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let swap = ay > ax;
    let (mn, mx) = (select(swap, ax, ay), select(swap, ay, ax));
    // atan(mn/mx) ∈ [0, π/4]; above tan(π/8) use atan(a) = π/4 + atan((a − 1)/(a + 1)), whose
    // argument is (mn − mx)/(mn + mx): one division either way.
    let far = gt_mask(mn, TAN_PI_8 * mx);
    let num = mn - and(mx, far);
    let den = mx + and(mn, far);
    // den = 0 only for atan2(±0, ±0): q = 0 there instead of 0/0 (NaN inputs are handled last).
    let q = num / den;
    let q = select(q.is_nan(), 0.0, q);
    // |atan2| = k·π/4 ± atan(q): k = 1 if far; |y| > |x| reflects about π/4 (k → 2 − k,
    // sign flips), x < 0 (including −0) about π/2 (k → 4 − k, sign flips). The high part is
    // added last so the result is rounded about once.
    let xneg = x.is_sign_negative();
    let k1 = if swap {
        2 - (far & 1) as usize
    } else {
        (far & 1) as usize
    };
    let k = if xneg { 4 - k1 } else { k1 } & 7;
    let flip = ((swap ^ xneg) as u32) << 31;
    let t = f32::from_bits(atan_poly(q).to_bits() ^ flip);
    let r = QUARTER_PI_HI[k] + (t + QUARTER_PI_LO[k]);
    select(x.is_nan() | y.is_nan(), f32::NAN, r.copysign(y))
}

/// ⌊x⌋ for |x| < 2³¹ by truncation, without libm's `floorf` (the baseline x86-64 target has no
/// rounding instruction, so `f32::floor` is a call); larger values are out of its range, NaN gives
/// 0 (so `x − floor(x)` is NaN either way).
#[inline]
pub fn floor_small(x: f32) -> f32 {
    let t = x as i32 as f32;
    if t > x { t - 1.0 } else { t }
}

// ---- The same per lane of an `F16` (the packet kernels' twins: the same bits) ----

/// [`sin_cos`] per lane.
#[inline(always)]
pub fn sin_cos_x(x: F16) -> (F16, F16) {
    let mut s = [0.0; WIDTH];
    let mut c = [0.0; WIDTH];
    for i in 0..WIDTH {
        (s[i], c[i]) = sin_cos(x.0[i]);
    }
    (F16(s), F16(c))
}

/// [`exp2`] per lane.
#[inline(always)]
pub fn exp2_x(x: F16) -> F16 {
    F16(lanes(|l| exp2(x.0[l])))
}

/// [`log2`] per lane.
#[inline(always)]
pub fn log2_x(x: F16) -> F16 {
    F16(lanes(|l| log2(x.0[l])))
}

/// [`atan2`] per lane.
#[inline(always)]
pub fn atan2_x(y: F16, x: F16) -> F16 {
    F16(lanes(|l| atan2(y.0[l], x.0[l])))
}

/// [`floor_small`] per lane.
#[inline(always)]
pub fn floor_small_x(x: F16) -> F16 {
    let t = F16(lanes(|l| x.0[l] as i32 as f32));
    F16::select(t.gt(x), t - 1.0, t)
}

crate::isa_dispatch! {
    /// [`sin_cos_x`] built for `isa` (every build returns the same bits; to compare them).
    pub fn sin_cos_isa(x: F16) -> (F16, F16) = sin_cos_x;
}

crate::isa_dispatch! {
    /// [`exp2_x`] built for `isa` (every build returns the same bits; to compare them).
    pub fn exp2_isa(x: F16) -> F16 = exp2_x;
}

crate::isa_dispatch! {
    /// [`log2_x`] built for `isa` (every build returns the same bits; to compare them).
    pub fn log2_isa(x: F16) -> F16 = log2_x;
}

// ---- Fused, positive normal inputs: the PLM-C evaluation kernels (F4 and AVX-512) ----

/// 2^f on [−½, ½]: the degree-6 series of [`exp2`] in Estrin form (three independent pairs,
/// then f² combines them: 3 dependent steps, not 6), every step one fused multiply-add.
#[inline(always)]
fn fused_exp2_poly_f4(f: F4) -> F4 {
    let c = EXP2_COEFFS;
    let s = F4::splat;
    let f2 = f * f;
    let p01 = s(c[0]).mul_add(f, s(1.0)); // 1 + c1 f
    let p23 = s(c[2]).mul_add(f, s(c[1])); // c2 + c3 f
    let p45 = s(c[4]).mul_add(f, s(c[3])); // c4 + c5 f
    let q = s(c[5]).mul_add(f2, p45); // c4 + c5 f + c6 f²
    let q = q.mul_add(f2, p23);
    q.mul_add(f2, p01)
}

/// `e` + log2 m for m in [√½, √2): 2/ln 2 · atanh t, t = (m−1)/(m+1), the odd series of
/// [`log2`] to t⁹ in Estrin form in t²: (C + C/3 t²) + t⁴ ((C/5 + C/7 t²) + t⁴ C/9), fused.
#[inline(always)]
fn fused_log2_series_f4(m: F4, e: F4) -> F4 {
    let one = F4::splat(1.0);
    let t = (m - one) / (m + one);
    let t2 = t * t;
    const C: f32 = LOG2_ATANH;
    let s = F4::splat;
    let t4 = t2 * t2;
    let lo = s(C / 3.0).mul_add(t2, s(C));
    let hi = s(C / 7.0).mul_add(t2, s(C / 5.0));
    let hi = s(C / 9.0).mul_add(t4, hi);
    hi.mul_add(t4, lo).mul_add(t, e)
}

/// 2^x per lane for x in [−125, 127] (clamped): round-to-nearest split n + f, the fused series
/// on f, n added to the exponent bits. Relative error < 3e-7.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub fn fused_exp2_f4(x: F4) -> F4 {
    // SAFETY: SSE and SSE2 are x86_64 baseline features, always enabled.
    unsafe {
        let x = x.max(F4::splat(-125.0)).min(F4::splat(127.0));
        let i = _mm_cvtps_epi32(x.0); // round to nearest (default MXCSR)
        let f = x - F4(_mm_cvtepi32_ps(i));
        let p = fused_exp2_poly_f4(f);
        F4(_mm_castsi128_ps(_mm_add_epi32(
            _mm_castps_si128(p.0),
            _mm_slli_epi32::<23>(i),
        )))
    }
}

/// log2 per lane of positive normal lanes: exponent + the fused series on m ∈ [√½, √2). Error
/// < 2e-7 + 1.2e-7·|log2 x| (the series is good to ~1e-7; the sum adds half an ulp).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub fn fused_log2_f4(x: F4) -> F4 {
    // SAFETY: SSE and SSE2 are x86_64 baseline features, always enabled.
    unsafe {
        let bits = _mm_castps_si128(x.0);
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
        fused_log2_series_f4(m, F4(_mm_cvtepi32_ps(e)))
    }
}

/// 2^x per lane for x in [−125, 127] (clamped): round-to-nearest split n + f, the fused series
/// on f, n added to the exponent bits. Relative error < 3e-7.
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
pub fn fused_exp2_f4(x: F4) -> F4 {
    let x = x.max(F4::splat(-125.0)).min(F4::splat(127.0));
    let i = x.0.map(|v| v.round_ties_even() as i32);
    let f = x - F4(i.map(|v| v as f32));
    let p = fused_exp2_poly_f4(f);
    F4(std::array::from_fn(|k| {
        f32::from_bits((p.0[k].to_bits() as i32).wrapping_add(i[k] << 23) as u32)
    }))
}

/// log2 per lane of positive normal lanes: exponent + the fused series on m ∈ [√½, √2). Error
/// < 2e-7 + 1.2e-7·|log2 x|.
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
pub fn fused_log2_f4(x: F4) -> F4 {
    let mut e = [0f32; 4];
    let mut m = [0f32; 4];
    for k in 0..4 {
        let bits = x.0[k].to_bits();
        let mut ek = ((bits >> 23) & 0xff) as i32 - 127;
        let mut mk = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
        if mk > std::f32::consts::SQRT_2 {
            mk *= 0.5;
            ek += 1;
        }
        e[k] = ek as f32;
        m[k] = mk;
    }
    fused_log2_series_f4(F4(m), F4(e))
}

/// All 16 lanes `x`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
#[inline]
fn splat16(x: f32) -> __m512 {
    _mm512_set1_ps(x)
}

/// [`fused_log2_f4`] on 16 lanes, to the bit: `vgetmant`/`vgetexp` (exact) instead of the bit
/// tricks, then the same series in the same order.
///
/// # Safety
/// The CPU must have AVX-512F, AVX2 and FMA ([`super::isa`] at [`super::Level::Avx512`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
#[inline]
pub fn fused_log2_16(x: __m512) -> __m512 {
    let m = _mm512_getmant_ps::<_MM_MANT_NORM_1_2, _MM_MANT_SIGN_SRC>(x);
    let e = _mm512_getexp_ps(x);
    let big = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(m, splat16(std::f32::consts::SQRT_2));
    let m = _mm512_mask_mul_ps(m, big, m, splat16(0.5));
    let e = _mm512_mask_add_ps(e, big, e, splat16(1.0));
    let one = splat16(1.0);
    let t = _mm512_div_ps(_mm512_sub_ps(m, one), _mm512_add_ps(m, one));
    let t2 = _mm512_mul_ps(t, t);
    const C: f32 = LOG2_ATANH;
    let t4 = _mm512_mul_ps(t2, t2);
    let lo = _mm512_fmadd_ps(splat16(C / 3.0), t2, splat16(C));
    let hi = _mm512_fmadd_ps(splat16(C / 7.0), t2, splat16(C / 5.0));
    let hi = _mm512_fmadd_ps(splat16(C / 9.0), t4, hi);
    _mm512_fmadd_ps(_mm512_fmadd_ps(hi, t4, lo), t, e)
}

/// [`fused_exp2_f4`] on 16 lanes, to the bit: the same clamp, nearest-integer split and series
/// in the same order, scaled by `vscalef` (exact: the result is a normal float).
///
/// # Safety
/// The CPU must have AVX-512F, AVX2 and FMA ([`super::isa`] at [`super::Level::Avx512`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
#[inline]
pub fn fused_exp2_16(x: __m512) -> __m512 {
    let x = _mm512_min_ps(_mm512_max_ps(x, splat16(-125.0)), splat16(127.0));
    let r = _mm512_roundscale_ps::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(x);
    let f = _mm512_sub_ps(x, r);
    let c = EXP2_COEFFS;
    let f2 = _mm512_mul_ps(f, f);
    let p01 = _mm512_fmadd_ps(splat16(c[0]), f, splat16(1.0));
    let p23 = _mm512_fmadd_ps(splat16(c[2]), f, splat16(c[1]));
    let p45 = _mm512_fmadd_ps(splat16(c[4]), f, splat16(c[3]));
    let q = _mm512_fmadd_ps(splat16(c[5]), f2, p45);
    let q = _mm512_fmadd_ps(q, f2, p23);
    _mm512_scalef_ps(_mm512_fmadd_ps(q, f2, p01), r)
}

/// [`fused_log2_f4`] on 8 AVX2 lanes, to the bit: the same bit tricks, series and order.
///
/// # Safety
/// The CPU must have AVX2 and FMA ([`super::isa`] at [`super::Level::Avx2`] or above).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub fn fused_log2_8(x: __m256) -> __m256 {
    let s = _mm256_set1_ps;
    let bits = _mm256_castps_si256(x);
    let e = _mm256_sub_epi32(
        _mm256_and_si256(_mm256_srli_epi32::<23>(bits), _mm256_set1_epi32(0xff)),
        _mm256_set1_epi32(127),
    );
    let m = _mm256_castsi256_ps(_mm256_or_si256(
        _mm256_and_si256(bits, _mm256_set1_epi32(0x007f_ffff)),
        _mm256_set1_epi32(0x3f80_0000),
    ));
    let big = _mm256_cmp_ps::<_CMP_GT_OS>(m, s(std::f32::consts::SQRT_2));
    // m ← m/2 and e ← e+1 where big (the mask is −1 as an integer).
    let m = _mm256_blendv_ps(m, _mm256_mul_ps(m, s(0.5)), big);
    let e = _mm256_cvtepi32_ps(_mm256_sub_epi32(e, _mm256_castps_si256(big)));
    let one = s(1.0);
    let t = _mm256_div_ps(_mm256_sub_ps(m, one), _mm256_add_ps(m, one));
    let t2 = _mm256_mul_ps(t, t);
    const C: f32 = LOG2_ATANH;
    let t4 = _mm256_mul_ps(t2, t2);
    let lo = _mm256_fmadd_ps(s(C / 3.0), t2, s(C));
    let hi = _mm256_fmadd_ps(s(C / 7.0), t2, s(C / 5.0));
    let hi = _mm256_fmadd_ps(s(C / 9.0), t4, hi);
    _mm256_fmadd_ps(_mm256_fmadd_ps(hi, t4, lo), t, e)
}

/// [`fused_exp2_f4`] on 8 AVX2 lanes, to the bit: the same clamp, nearest-integer split,
/// series and exponent-bit scaling in the same order.
///
/// # Safety
/// The CPU must have AVX2 and FMA ([`super::isa`] at [`super::Level::Avx2`] or above).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub fn fused_exp2_8(x: __m256) -> __m256 {
    let s = _mm256_set1_ps;
    let x = _mm256_min_ps(_mm256_max_ps(x, s(-125.0)), s(127.0));
    let i = _mm256_cvtps_epi32(x); // round to nearest (default MXCSR)
    let f = _mm256_sub_ps(x, _mm256_cvtepi32_ps(i));
    let c = EXP2_COEFFS;
    let f2 = _mm256_mul_ps(f, f);
    let p01 = _mm256_fmadd_ps(s(c[0]), f, s(1.0));
    let p23 = _mm256_fmadd_ps(s(c[2]), f, s(c[1]));
    let p45 = _mm256_fmadd_ps(s(c[4]), f, s(c[3]));
    let q = _mm256_fmadd_ps(s(c[5]), f2, p45);
    let q = _mm256_fmadd_ps(q, f2, p23);
    let p = _mm256_fmadd_ps(q, f2, p01);
    _mm256_castsi256_ps(_mm256_add_epi32(
        _mm256_castps_si256(p),
        _mm256_slli_epi32::<23>(i),
    ))
}

#[cfg(test)]
mod tests;
