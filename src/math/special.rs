//! Special functions in single precision exactly as Dr.Jit evaluates them (the same polynomial
//! fits), so that code ported from Mitsuba 3 (Beckmann visible-normal sampling) reproduces it.

/// Dr.Jit's `erf` fit for `float` on [0, 1] (polynomial in x², max error 1.98 ulp).
const ERF_C0: [f32; 6] = [
    f32::from_bits(0x3f906eba), // 0x1.20dd74p+0
    f32::from_bits(0xbec09339), // -0x1.812672p-2
    f32::from_bits(0x3de7049a), // 0x1.ce0934p-4
    f32::from_bits(0xbcdad19a), // -0x1.b5a334p-6
    f32::from_bits(0x3ba1235a), // 0x1.4246b4p-8
    f32::from_bits(0xba139fd6), // -0x1.273facp-11
];

/// Dr.Jit's `erf` fit for `float` on [1, 4] (exponent of 1 − erf, polynomial in |x|).
const ERF_C1: [f32; 7] = [
    f32::from_bits(0xbfd06b8d), // -0x1.a0d71ap+0
    f32::from_bits(0xbf6a8f1d), // -0x1.d51e3ap-1
    f32::from_bits(0xbe1d4826), // -0x1.3a904cp-3
    f32::from_bits(0x3d0e1cae), // 0x1.1c395cp-5
    f32::from_bits(0xbbb42b5f), // -0x1.6856bep-8
    f32::from_bits(0x3a0c078f), // 0x1.180f1ep-11
    f32::from_bits(0xb7c654fb), // -0x1.8ca9f6p-16
];

/// Giles' erfinv fit for w = −ln(1 − x²) < 5, in w − 2.5.
const ERFINV_P1: [f64; 9] = [
    1.50140941,
    0.246640727,
    -0.00417768164,
    -0.00125372503,
    0.00021858087,
    -4.39150654e-06,
    -3.5233877e-06,
    3.43273939e-07,
    2.81022636e-08,
];

/// Giles' erfinv fit for w ≥ 5, in √w − 3.
const ERFINV_P2: [f64; 9] = [
    2.83297682,
    1.00167406,
    0.00943887047,
    -0.0076224613,
    0.00573950773,
    -0.00367342844,
    0.00134934322,
    0.000100950558,
    -0.000200214257,
];

/// Σ c_i x^i (coefficients in ascending order, at most 9) by Estrin's scheme with fused
/// multiply-adds, the evaluation order of Dr.Jit's `estrin` (so the roundings are its own).
#[inline]
fn poly(x: f32, c: &[f32]) -> f32 {
    let mut buf = [0.0f32; 9];
    let mut n = c.len();
    buf[..n].copy_from_slice(c);
    let mut x = x;
    while n > 1 {
        let pairs = n / 2;
        for i in 0..pairs {
            buf[i] = x.mul_add(buf[2 * i + 1], buf[2 * i]);
        }
        if n % 2 == 1 {
            buf[pairs] = buf[n - 1];
        }
        n = n.div_ceil(2);
        x *= x;
    }
    buf[0]
}

/// [`poly`] with f64 coefficients rounded to f32 first (as Dr.Jit's `Value(double)`).
#[inline]
fn poly64(x: f32, c: &[f64; 9]) -> f32 {
    poly(x, &c.map(|ci| ci as f32))
}

/// The error function (Dr.Jit's single-precision fit, ≤ 3.8 ulp on [−6, 6]; ±1 at ±∞).
#[inline]
pub fn erf(x: f32) -> f32 {
    let xa = x.abs();
    if xa < 1.0 {
        return x * poly(x * x, &ERF_C0);
    }
    let xb = 1.0 - (poly(xa, &ERF_C1) * xa).exp2();
    // At ±∞ the fit gives NaN; Dr.Jit selects 1 there.
    (if xb.is_finite() { xb } else { 1.0 }).copysign(x)
}

/// The inverse error function on (−1, 1) (Giles 2010, "Approximating the erfinv function").
#[inline]
pub fn erfinv(x: f32) -> f32 {
    let w = -((1.0 - x) * (1.0 + x)).ln();
    let p = if w < 5.0 {
        poly64(w - 2.5, &ERFINV_P1)
    } else {
        poly64(w.sqrt() - 3.0, &ERFINV_P2)
    };
    p * x
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erf_matches_known_values_and_limits() {
        // erf(0.5), erf(1), erf(2), erf(3.5) from tables (Abramowitz & Stegun 7.1).
        for &(x, e) in &[
            (0.5f32, 0.520_499_9f32),
            (1.0, 0.842_700_8),
            (2.0, 0.995_322_3),
            (3.5, 0.999_999_3),
        ] {
            assert!((erf(x) - e).abs() < 3e-7, "erf({x}) = {} vs {e}", erf(x));
            assert!((erf(-x) + e).abs() < 3e-7);
        }
        assert_eq!(erf(0.0), 0.0);
        assert_eq!(erf(f32::INFINITY), 1.0);
        assert_eq!(erf(f32::NEG_INFINITY), -1.0);
    }

    #[test]
    fn erfinv_inverts_erf() {
        for i in -99..100 {
            let y = i as f32 / 100.0;
            let x = erfinv(y);
            assert!((erf(x) - y).abs() < 2e-6, "erf(erfinv({y})) = {}", erf(x));
        }
    }
}
