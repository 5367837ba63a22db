//! The standard normal tail and its inverse, in f64: enough for Šidák-corrected thresholds
//! (tail probabilities down to ~1e-300), without a statistics dependency.

/// Complementary error function, relative error < 1e-15 for x ≥ 0 (continued fraction for large x,
/// series for small x), symmetric extension for x < 0.
pub fn erfc(x: f64) -> f64 {
    if x.is_nan() {
        return f64::NAN;
    }
    if x < 0.0 {
        return 2.0 - erfc(-x);
    }
    if x < 2.0 {
        // erf(x) = 2/√π · Σ (−1)ⁿ x^(2n+1) / (n! (2n+1)); converges fast for x < 2.
        let mut term = x;
        let mut sum = x;
        let x2 = x * x;
        let mut n = 0.0;
        loop {
            n += 1.0;
            term *= -x2 / n;
            let add = term / (2.0 * n + 1.0);
            sum += add;
            if add.abs() <= 1e-17 * sum.abs() || n > 200.0 {
                break;
            }
        }
        1.0 - sum * std::f64::consts::FRAC_2_SQRT_PI
    } else {
        // Lentz's algorithm on erfc(x) = e^{−x²}/√π · 1/(x + (1/2)/(x + 1/(x + (3/2)/(x + …)))).
        let tiny = 1e-300;
        let mut f = x;
        let mut c = x;
        let mut d = 0.0;
        for k in 1..500 {
            let a = k as f64 * 0.5;
            d = x + a * d;
            d = if d.abs() < tiny { tiny } else { d };
            c = x + a / c;
            c = if c.abs() < tiny { tiny } else { c };
            d = 1.0 / d;
            let delta = c * d;
            f *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (-x * x).exp() / (f * std::f64::consts::PI.sqrt())
    }
}

/// Upper tail of the standard normal, P(Z > z).
pub fn normal_sf(z: f64) -> f64 {
    0.5 * erfc(z / std::f64::consts::SQRT_2)
}

/// Inverse upper tail: the z with P(Z > z) = p, for p in (0, 1). Acklam's rational approximation
/// refined by Newton steps on [`normal_sf`] (relative error ~1e-14).
pub fn normal_isf(p: f64) -> f64 {
    if !(p > 0.0 && p < 1.0) {
        return if p <= 0.0 {
            f64::INFINITY
        } else {
            f64::NEG_INFINITY
        };
    }
    // Acklam's approximation of the lower-tail quantile of q = 1 − p, computed from p directly.
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.38357751867269e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e1,
        1.615858368580409e2,
        -1.556989798598866e2,
        6.680131188771972e1,
        -1.328068155288572e1,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.54967134824342,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] = [
        7.784695709041462e-3,
        3.224671290700398e-1,
        2.445134137142996,
        3.754408661907416,
    ];
    let tail = |p: f64| {
        // Lower-tail quantile for small p (negative result).
        let q = (-2.0 * p.ln()).sqrt();
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    let mut z = if p < 0.02425 {
        -tail(p)
    } else if p > 1.0 - 0.02425 {
        tail(1.0 - p)
    } else {
        let q = 0.5 - p; // quantile of 1 − p is −quantile of p
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    };
    // Newton on sf(z) = p: d sf / dz = −φ(z).
    for _ in 0..3 {
        let pdf = (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt();
        if pdf <= 0.0 {
            break;
        }
        z += (normal_sf(z) - p) / pdf;
    }
    z
}

/// Two-sided |z| threshold at family-wise level `alpha` over `tests` independent tests (Šidák):
/// per-test level 1 − (1 − α)^(1/tests), split over both tails.
pub fn sidak_threshold(alpha: f64, tests: usize) -> f64 {
    let per_test = -((-alpha).ln_1p() / tests.max(1) as f64).exp_m1();
    normal_isf(0.5 * per_test)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erfc_known_values() {
        // Reference values: Python math.erfc (correctly rounded to ~1 ulp).
        for (x, want) in [
            (0.0, 1.0),
            (0.5, 0.4795001221869535),
            (1.0, 0.15729920705028513),
            (1.9, 0.0072095707647425325),
            (2.1, 0.002979466656332984),
            (3.0, 2.209049699858544e-5),
            (6.0, 2.1519736712498913e-17),
            (-1.0, 1.8427007929497148),
        ] {
            let got = erfc(x);
            assert!(
                ((got - want) / want).abs() < 1e-12,
                "erfc({x}) = {got}, want {want}"
            );
        }
    }

    #[test]
    fn isf_inverts_sf_and_matches_tables() {
        assert!((normal_isf(0.005) - 2.5758293035489004).abs() < 1e-10);
        assert!((normal_isf(0.025) - 1.959963984540054).abs() < 1e-10);
        assert!((normal_isf(0.5)).abs() < 1e-12);
        assert!((normal_isf(0.975) + 1.959963984540054).abs() < 1e-10);
        for p in [1e-300, 1e-100, 1e-12, 3e-7, 0.01, 0.3, 0.7, 0.99] {
            let z = normal_isf(p);
            assert!(((normal_sf(z) - p) / p).abs() < 1e-10, "p {p}: z {z}");
        }
    }

    #[test]
    fn sidak_matches_the_reference_pipeline() {
        // compare.py / calibrate.py (scipy) report 5.195 for 128² pixels and 5.225 for 160×120.
        assert!((sidak_threshold(0.01, 128 * 128 * 3) - 5.195).abs() < 5e-4);
        assert!((sidak_threshold(0.01, 160 * 120 * 3) - 5.225).abs() < 5e-4);
        // One test: the plain two-sided 1 % threshold.
        assert!((sidak_threshold(0.01, 1) - 2.5758293035489004).abs() < 1e-9);
    }
}
