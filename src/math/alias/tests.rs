use super::*;
use crate::math::Pcg32;

/// Chi-square statistic of `counts` against `n · pmf`, and its degrees of freedom (bins with
/// expected count below 5 pooled into one).
fn chi2(counts: &[f64], pmf: &[f64], n: f64) -> (f64, usize) {
    let (mut c, mut dof, mut pooled) = (0.0, 0usize, (0.0, 0.0));
    for (&h, &p) in counts.iter().zip(pmf) {
        let e = p * n;
        if e < 5.0 {
            pooled.0 += h;
            pooled.1 += e;
            continue;
        }
        c += (h - e).powi(2) / e;
        dof += 1;
    }
    if pooled.1 >= 5.0 {
        c += (pooled.0 - pooled.1).powi(2) / pooled.1;
        dof += 1;
    }
    (c, dof.saturating_sub(1))
}

/// Wilson–Hilferty upper quantile of χ²(k) at α = 0.001.
fn critical(k: usize) -> f64 {
    let k = k.max(1) as f64;
    k * (1.0 - 2.0 / (9.0 * k) + 3.09 * (2.0 / (9.0 * k)).sqrt()).powi(3)
}

#[test]
fn frequencies_follow_the_weights_chi_square() {
    let w: Vec<f64> = (0..37)
        .map(|i| match i % 7 {
            0 => 0.0,
            3 => 25.0,
            _ => (i % 5) as f64 + 0.5,
        })
        .collect();
    let t = AliasTable::new(&w).unwrap();
    let total: f64 = w.iter().sum();
    let pmf: Vec<f64> = w.iter().map(|x| x / total).collect();
    let mut rng = Pcg32::new(4, 2);
    let n = 200_000;
    let mut counts = vec![0f64; w.len()];
    // The re-scaled number is uniform inside each bin: its mean over the bin's samples is ½.
    let mut rem = vec![0f64; w.len()];
    for _ in 0..n {
        let (i, r) = t.sample(0, rng.next_f32());
        assert!((0.0..1.0).contains(&r));
        counts[i] += 1.0;
        rem[i] += r as f64;
    }
    for i in 0..w.len() {
        assert_eq!(w[i] == 0.0, counts[i] == 0.0, "bin {i}");
        assert!((t.pmf(0, i) as f64 - pmf[i]).abs() < 1e-7);
        if counts[i] > 1000.0 {
            let m = rem[i] / counts[i];
            // 1/√(12 n): the mean's standard deviation; 5 of them.
            assert!(
                (m - 0.5).abs() < 5.0 / (12.0 * counts[i]).sqrt(),
                "bin {i}: {m}"
            );
        }
    }
    let (c, k) = chi2(&counts, &pmf, n as f64);
    assert!(c < critical(k), "chi2 {c} > {} (dof {k})", critical(k));
}

#[test]
fn rows_are_independent_distributions_and_empty_rows_are_marked() {
    #[rustfmt::skip]
    let w = [1.0, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, f64::NAN, -1.0, 2.0, 5.0];
    let t = AliasTable::rows(&w, 4).unwrap();
    assert_eq!((t.total(0), t.total(1), t.total(2)), (4.0, 0.0, 7.0));
    let mut rng = Pcg32::new(1, 8);
    let mut c = [[0u32; 4]; 3];
    for _ in 0..20_000 {
        for (r, cr) in c.iter_mut().enumerate() {
            cr[t.sample(r, rng.next_f32()).0] += 1;
        }
    }
    assert_eq!((c[0][2], c[0][3], c[2][0], c[2][1]), (0, 0, 0, 0));
    assert!((c[0][1] as f64 / 20_000.0 - 0.75).abs() < 0.02);
    assert!((c[2][3] as f64 / 20_000.0 - 5.0 / 7.0).abs() < 0.02);
    assert!(AliasTable::new(&[0.0, 0.0]).is_none());
    assert!(AliasTable::rows(&w, 5).is_none());
    assert!(AliasTable::rows(&w, 0).is_none());
}

/// Out-of-range and NaN numbers, and the edges of every bin, never pick a zero-weight bin and
/// re-scale into [0, 1).
#[test]
fn edges_and_bad_numbers_stay_in_range() {
    let w = [0.0, 1.0, 0.0, 1e-30, 4.0, 0.0];
    let t = AliasTable::new(&w).unwrap();
    let mut us = vec![
        0.0,
        -0.0,
        -1.0,
        1.0,
        2.0,
        f32::NAN,
        f32::INFINITY,
        -f32::INFINITY,
    ];
    for k in 0..=6 {
        let e = k as f32 / 6.0;
        us.extend([e, e.next_up(), e.next_down()]);
    }
    for u in us {
        let (i, r) = t.sample(0, u);
        assert!(w[i] > 0.0, "u = {u} picked bin {i}");
        assert!((0.0..1.0).contains(&r), "u = {u}: {r}");
    }
}

/// The 16-lane sampler returns the scalar one's bins and re-scaled numbers bit for bit, each
/// lane in its own row, on random numbers and at the edges.
#[test]
fn sample_x_is_sample_per_lane() {
    let mut rng = Pcg32::new(9, 3);
    let len = 13;
    let w: Vec<f64> = (0..len * 5)
        .map(|i| {
            if i % 4 == 1 || (26..39).contains(&i) {
                0.0
            } else {
                rng.next_f32() as f64
            }
        })
        .collect();
    let t = AliasTable::rows(&w, len).unwrap();
    let mut us: Vec<f32> = (0..800).map(|_| rng.next_f32()).collect();
    for k in 0..=len {
        let e = k as f32 / len as f32;
        us.extend([e, e.next_up(), e.next_down()]);
    }
    us.extend([-0.0, -0.5, 1.0, 1.5, f32::NAN, f32::INFINITY]);
    for (c, chunk) in us.chunks(WIDTH).enumerate() {
        let mut u = F16::splat(0.5);
        u.0[..chunk.len()].copy_from_slice(chunk);
        let rows: [u32; WIDTH] = lanes(|l| ((c + l) % 5) as u32);
        let (i, r) = t.sample_x(rows, u);
        for l in 0..WIDTH {
            let (si, sr) = t.sample(rows[l] as usize, u.0[l]);
            assert_eq!(i[l] as usize, si, "u = {}", u.0[l]);
            assert_eq!(r.0[l].to_bits(), sr.to_bits(), "u = {}", u.0[l]);
        }
    }
}
