use super::*;
use crate::math::simd::{Isa, isa};

/// Runs `f` over `xs` in 16-lane batches (the tail padded with the last value).
fn batched(xs: &[f32], mut f: impl FnMut(F16, usize)) {
    for (k, c) in xs.chunks(WIDTH).enumerate() {
        let mut x = [*c.last().unwrap(); WIDTH];
        x[..c.len()].copy_from_slice(c);
        f(F16(x), k * WIDTH);
    }
}

fn sweep(lo: f32, hi: f32, n: usize) -> Vec<f32> {
    (0..n)
        .map(|i| lo + (hi - lo) * (i as f64 / (n - 1) as f64) as f32)
        .collect()
}

#[test]
fn sin_cos_matches_f64_and_is_identical_on_every_isa() {
    let mut xs = sweep(-100.0, 100.0, 200_001);
    xs.extend([0.0, -0.0, 1e-30, std::f32::consts::PI, 8192.0, -8192.0]);
    let mut first: Option<Vec<u32>> = None;
    for isa in Isa::available() {
        let mut bits = Vec::new();
        let mut worst = 0.0f64;
        batched(&xs, |x, _| {
            let (F16(s), F16(c)) = sin_cos_isa(isa, x);
            let x = x.0;
            for i in 0..WIDTH {
                let (rs, rc) = (x[i] as f64).sin_cos();
                worst = worst
                    .max((s[i] as f64 - rs).abs())
                    .max((c[i] as f64 - rc).abs());
                bits.push(s[i].to_bits());
                bits.push(c[i].to_bits());
            }
        });
        assert!(worst < 2.5e-7, "{isa:?}: sin/cos error {worst:e}");
        match &first {
            None => first = Some(bits),
            Some(b) => assert!(*b == bits, "{isa:?} differs from the portable build"),
        }
    }
}

#[test]
fn exp2_and_log2_match_f64_and_are_identical_on_every_isa() {
    let xs = sweep(-126.0, 127.9, 100_003);
    let ys: Vec<f32> = sweep(-40.0, 40.0, 100_003)
        .iter()
        .map(|&e| (e as f64).exp2() as f32)
        .chain([
            1.0,
            0.999_999_9,
            1.000_000_1,
            f32::MIN_POSITIVE,
            1e-40,
            f32::MAX,
        ])
        .collect();
    let mut first: Option<Vec<u32>> = None;
    for isa in Isa::available() {
        let mut bits = Vec::new();
        let mut worst_exp = 0.0f64;
        batched(&xs, |x, _| {
            let (v, x) = (exp2_isa(isa, x).0, x.0);
            for i in 0..WIDTH {
                let r = (x[i] as f64).exp2();
                worst_exp = worst_exp.max(((v[i] as f64 - r) / r).abs());
                bits.push(v[i].to_bits());
            }
        });
        let mut worst_log = 0.0f64;
        batched(&ys, |x, _| {
            let (v, x) = (log2_isa(isa, x).0, x.0);
            for i in 0..WIDTH {
                let r = (x[i] as f64).log2();
                let err = (v[i] as f64 - r).abs() / r.abs().max(1.0);
                worst_log = worst_log.max(err);
                bits.push(v[i].to_bits());
            }
        });
        assert!(
            worst_exp < 3e-7,
            "{isa:?}: exp2 relative error {worst_exp:e}"
        );
        assert!(worst_log < 3e-7, "{isa:?}: log2 error {worst_log:e}");
        match &first {
            None => first = Some(bits),
            Some(b) => assert!(*b == bits, "{isa:?} differs from the portable build"),
        }
    }
}

#[test]
fn special_values() {
    let i = isa();
    let mut x = [1.0f32; WIDTH];
    x[..6].copy_from_slice(&[0.0, -1.0, f32::INFINITY, f32::NAN, 1e-45, -0.0]);
    let l = log2_isa(i, F16(x)).0;
    assert_eq!(l[0], f32::NEG_INFINITY);
    assert!(l[1].is_nan() && l[3].is_nan());
    assert_eq!(l[2], f32::INFINITY);
    assert!((l[4] - (-149.0)).abs() < 1e-5, "{}", l[4]);
    assert_eq!(l[5], f32::NEG_INFINITY);
    assert_eq!(l[6], 0.0);
    x[..5].copy_from_slice(&[-200.0, 200.0, f32::NAN, 0.0, 10.0]);
    let e = exp2_isa(i, F16(x)).0;
    assert_eq!(e[0], 0.0);
    assert_eq!(e[1], f32::INFINITY);
    assert!(e[2].is_nan());
    assert_eq!(e[3], 1.0);
    assert!((e[4] - 1024.0).abs() < 1e-3);
}

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

#[test]
fn ln_and_exp_are_accurate() {
    let mut x = 1e-30f32;
    while x < 1e30 {
        let e = (ln(x) as f64 - (x as f64).ln()).abs();
        assert!(e < 3e-7 * (x as f64).ln().abs().max(1.0), "ln {x}: {e}");
        x *= 1.37;
    }
    let mut t = -87.0f32;
    while t < 88.0 {
        let r = (exp(t) as f64 / (t as f64).exp() - 1.0).abs();
        // f32 rounding of t·log2(e) alone costs |t|·6e-8 relative.
        assert!(r < 4e-7 + 1.2e-7 * t.abs() as f64, "exp {t}: {r}");
        t += 0.0173;
    }
}

/// [`fused_exp2_f4`] and [`fused_log2_f4`] of the lanes `x` and `b`, built for AVX2 + FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn fused_f4_avx2(x: F4, b: F4) -> ([f32; 4], [f32; 4]) {
    (fused_exp2_f4(x).to_array(), fused_log2_f4(b).to_array())
}

/// The same on 16 AVX-512 lanes (the 4 values in lanes 0..4).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
fn fused_16(x: [f32; 4], b: [f32; 4]) -> ([f32; 4], [f32; 4]) {
    let wide = |v: [f32; 4]| {
        let mut a = [1.0f32; 16];
        a[..4].copy_from_slice(&v);
        // SAFETY: 16 f32 read from a 16-element array.
        unsafe { _mm512_loadu_ps(a.as_ptr()) }
    };
    let back = |v: __m512| {
        let mut a = [0f32; 16];
        // SAFETY: 16 f32 written to a 16-element array.
        unsafe { _mm512_storeu_ps(a.as_mut_ptr(), v) };
        [a[0], a[1], a[2], a[3]]
    };
    (back(fused_exp2_16(wide(x))), back(fused_log2_16(wide(b))))
}

#[test]
fn fused_exp2_and_log2_are_accurate_and_the_same_bits_in_every_build() {
    let mut rng = crate::math::Pcg32::new(11, 2);
    for _ in 0..20_000 {
        let x: [f32; 4] = std::array::from_fn(|_| (rng.next_f32() - 0.5) * 60.0);
        let b: [f32; 4] = std::array::from_fn(|_| (-20.0 * rng.next_f32()).exp2() * 3.0);
        let e = fused_exp2_f4(F4::from_array(x)).to_array();
        let l = fused_log2_f4(F4::from_array(b)).to_array();
        for k in 0..4 {
            let want = (x[k] as f64).exp2();
            assert!(((e[k] as f64 - want) / want).abs() < 3e-7, "exp2({})", x[k]);
            let lw = (b[k] as f64).log2();
            assert!(
                (l[k] as f64 - lw).abs() < 2e-7 + 1.2e-7 * lw.abs(),
                "log2({})",
                b[k]
            );
        }
        #[cfg(target_arch = "x86_64")]
        {
            let level = isa().level();
            if level >= crate::math::simd::Level::Avx2 {
                // SAFETY: this CPU has AVX2 and FMA (`isa()` checked).
                let f = unsafe { fused_f4_avx2(F4::from_array(x), F4::from_array(b)) };
                assert_eq!(f, (e, l), "AVX2 build of {x:?} {b:?}");
            }
            if level == crate::math::simd::Level::Avx512 {
                // SAFETY: this CPU has AVX-512F, AVX2 and FMA (`isa()` checked).
                let f = unsafe { fused_16(x, b) };
                assert_eq!(f, (e, l), "AVX-512 version of {x:?} {b:?}");
            }
        }
    }
    assert_eq!(
        fused_exp2_f4(F4::from_array([0.0, -3.0, 10.0, -1.0])).to_array(),
        [1.0, 0.125, 1024.0, 0.5]
    );
}
