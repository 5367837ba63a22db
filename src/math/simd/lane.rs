//! One-lane bodies of the 16-lane functions of [`super`]: branch-free (selects, not jumps) so a
//! loop over lanes vectorises, and free of fused multiply-adds so every ISA returns the same bits.

/// π/2 in three parts (Cody–Waite): the first two have few mantissa bits, so j·part is exact.
const PIO2_1: f32 = 1.570_312_5;
const PIO2_2: f32 = 4.837_513e-4;
const PIO2_3: f32 = 7.549_79e-8;

/// 1.5 · 2²³: adding and subtracting it rounds |x| < 2²² to the nearest integer (ties to even)
/// in any ISA's plain adds, and leaves that integer in the low mantissa bits of the sum.
const ROUND_MAGIC: f32 = 12_582_912.0;

/// (sin x, cos x): x reduced to r ∈ [−π/4, π/4] by the nearest multiple j of π/2, Cephes'
/// minimax polynomials on r, then the quadrant j mod 4 swaps and negates them.
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

/// (ln 2)^k / k!, k = 1..6: the Taylor series of 2^f = e^(f ln 2) after the 1.
const EXP2_C: [f32; 6] = {
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

/// 2^x = 2^n · 2^f with n = round(x), f ∈ [−½, ½] by the degree-6 series; the exponent is
/// built in the float's bits.
#[inline(always)]
pub fn exp2(x: f32) -> f32 {
    let xc = x.clamp(-127.0, 128.0);
    let nm = xc + ROUND_MAGIC;
    let f = xc - (nm - ROUND_MAGIC);
    let c = EXP2_C;
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
/// log2 m = 2/ln 2 · atanh t, t = (m − 1)/(m + 1), odd series to t⁹.
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
    const K: f32 = 2.0 / std::f32::consts::LN_2;
    let s = t * (K + t2 * (K / 3.0 + t2 * (K / 5.0 + t2 * (K / 7.0 + t2 * (K / 9.0)))));
    let v = e + s;
    let v = if x == 0.0 { f32::NEG_INFINITY } else { v };
    let v = if x == f32::INFINITY { x } else { v };
    if x < 0.0 || x.is_nan() { f32::NAN } else { v }
}
