use super::*;

/// Runs `f` over `xs` in 16-lane batches (the tail padded with the last value).
fn batched(xs: &[f32], mut f: impl FnMut(&F32x16, usize)) {
    for (k, c) in xs.chunks(WIDTH).enumerate() {
        let mut x = [*c.last().unwrap(); WIDTH];
        x[..c.len()].copy_from_slice(c);
        f(&x, k * WIDTH);
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
            let (s, c) = sin_cos(isa, x);
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
            let v = exp2(isa, x);
            for i in 0..WIDTH {
                let r = (x[i] as f64).exp2();
                worst_exp = worst_exp.max(((v[i] as f64 - r) / r).abs());
                bits.push(v[i].to_bits());
            }
        });
        let mut worst_log = 0.0f64;
        batched(&ys, |x, _| {
            let v = log2(isa, x);
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
    let l = log2(i, &x);
    assert_eq!(l[0], f32::NEG_INFINITY);
    assert!(l[1].is_nan() && l[3].is_nan());
    assert_eq!(l[2], f32::INFINITY);
    assert!((l[4] - (-149.0)).abs() < 1e-5, "{}", l[4]);
    assert_eq!(l[5], f32::NEG_INFINITY);
    assert_eq!(l[6], 0.0);
    x[..5].copy_from_slice(&[-200.0, 200.0, f32::NAN, 0.0, 10.0]);
    let e = exp2(i, &x);
    assert_eq!(e[0], 0.0);
    assert_eq!(e[1], f32::INFINITY);
    assert!(e[2].is_nan());
    assert_eq!(e[3], 1.0);
    assert!((e[4] - 1024.0).abs() < 1e-3);
}
