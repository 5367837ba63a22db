//! Branch-free single-precision `atan2` for the environment map's lat-long mapping, where libm's
//! (`__atan2f`, `__atanf`) and the `acosf` it replaces cost more than the rest of the lookup.
//!
//! The argument is reduced to |q| ≤ tan(π/8) by the octant symmetries and atan(a) = π/4 +
//! atan((a − 1)/(a + 1)), where the Cephes single-precision odd polynomial is evaluated; the
//! cases are chosen with bit masks instead of branches, since they depend on random directions.
//! The multiples of π/4 are added as a high and a low part, so the result stays within 2e-7
//! (absolute) of the exact value (tests below). No fused multiply-adds: the crate is built
//! without a target CPU, where `mul_add` would be a libm call.

use crate::math::simd::wide::{Fx, lanes};

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
/// input is NaN. Both inputs infinite is not supported (NaN). Branch-free.
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

/// [`atan2`] per lane (the packet kernels' twin: the same bits).
#[inline(always)]
pub fn atan2_x(y: Fx, x: Fx) -> Fx {
    Fx(lanes(|l| atan2(y.0[l], x.0[l])))
}

/// [`floor_small`] per lane (the same bits).
#[inline(always)]
pub fn floor_small_x(x: Fx) -> Fx {
    let t = Fx(lanes(|l| x.0[l] as i32 as f32));
    Fx::select(t.gt(x), t - 1.0, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// |f − exact| for the f64 reference evaluated at the same f32 inputs.
    fn err(got: f32, want: f64) -> f64 {
        (got as f64 - want).abs()
    }

    #[test]
    fn atan2_is_within_2e7_on_a_dense_sweep() {
        let mut worst = 0.0f64;
        let n = 1 << 20;
        let mut rng = crate::math::Pcg32::new(5, 17);
        for k in 0..=n {
            // Angles over the whole circle, with radii over many octaves.
            let t = (k as f64 / n as f64 - 0.5) * 2.0 * std::f64::consts::PI;
            let r = 2f64.powf(rng.next_f32() as f64 * 40.0 - 20.0);
            let (y, x) = ((r * t.sin()) as f32, (r * t.cos()) as f32);
            let e = err(atan2(y, x), (y as f64).atan2(x as f64));
            worst = worst.max(e);
            assert!(
                e <= 2e-7,
                "atan2({y}, {x}) = {} vs {}",
                atan2(y, x),
                (y as f64).atan2(x as f64)
            );
        }
        // Near the octant boundaries (|y| = |x|, |y| = tan(π/8) |x|) and the axes, ulp by ulp.
        for base in [1.0f32, TAN_PI_8, 0.0, 1e-6] {
            let mut y = base;
            for _ in 0..2000 {
                for (sy, sx) in [(1.0, 1.0), (-1.0, 1.0), (1.0, -1.0), (-1.0, -1.0)] {
                    for (yy, xx) in [(y, 1.0f32), (1.0f32, y)] {
                        let (yy, xx) = (sy * yy, sx * xx);
                        let e = err(atan2(yy, xx), (yy as f64).atan2(xx as f64));
                        worst = worst.max(e);
                        assert!(e <= 2e-7, "atan2({yy}, {xx})");
                    }
                }
                y = y.next_up();
            }
        }
        eprintln!("atan2 max abs error {worst:e}");
    }

    #[test]
    fn atan2_special_values_match_libm() {
        let pi = std::f32::consts::PI;
        let h = std::f32::consts::FRAC_PI_2;
        for (y, x, want) in [
            (0.0f32, 0.0f32, 0.0f32),
            (-0.0, 0.0, -0.0),
            (0.0, -0.0, pi),
            (-0.0, -0.0, -pi),
            (0.0, 1.0, 0.0),
            (-0.0, 1.0, -0.0),
            (0.0, -1.0, pi),
            (-0.0, -1.0, -pi),
            (1.0, 0.0, h),
            (1.0, -0.0, h),
            (-1.0, 0.0, -h),
            (-1.0, -0.0, -h),
            (1.0, f32::INFINITY, 0.0),
            (f32::INFINITY, 1.0, h),
        ] {
            let got = atan2(y, x);
            assert_eq!(
                got.is_sign_negative(),
                want.is_sign_negative(),
                "atan2({y}, {x})"
            );
            assert!((got - want).abs() <= 2e-7, "atan2({y}, {x}) = {got}");
            assert!((got - y.atan2(x)).abs() <= 2e-7);
        }
        assert!(atan2(f32::NAN, 1.0).is_nan());
        assert!(atan2(1.0, f32::NAN).is_nan());
        assert!(atan2(0.0, f32::NAN).is_nan());
    }

    /// The envmap's polar angle atan2(√(x² + z²), y) against the f64 atan2 of the same inputs
    /// over the whole range of y, including the poles (r = 0) and unnormalised lengths.
    #[test]
    fn polar_angle_is_within_2e7() {
        let n = 1 << 20;
        for k in 0..=n {
            let y = (2.0 * k as f64 / n as f64 - 1.0) as f32;
            for len in [1.0f32, 0.37, 3.0e3] {
                let yy = y * len;
                let r = ((1.0 - y * y).max(0.0)).sqrt() * len;
                let e = err(atan2(r, yy), (r as f64).atan2(yy as f64));
                assert!(e <= 2e-7, "atan2({r}, {yy})");
            }
        }
        assert_eq!(atan2(0.0, 1.0), 0.0);
        assert_eq!(atan2(0.0, -1.0), std::f32::consts::PI);
    }

    #[test]
    fn floor_small_is_floor() {
        let mut rng = crate::math::Pcg32::new(1, 2);
        let mut xs = vec![0.0f32, -0.0, 1.0, -1.0, 0.5, -0.5, 1e-30, -1e-30, 2e9, -2e9];
        xs.extend([1.0f32, -1.0, 0.0, 3.0].map(|x| x.next_up()));
        xs.extend([1.0f32, -1.0, 0.0, 3.0].map(|x| x.next_down()));
        xs.extend((0..100_000).map(|_| (rng.next_f32() - 0.5) * 100.0));
        for x in xs {
            assert_eq!(floor_small(x), x.floor(), "{x}");
            assert_eq!(x - floor_small(x), x - x.floor(), "{x}");
        }
        assert!((f32::NAN - floor_small(f32::NAN)).is_nan());
    }
}
