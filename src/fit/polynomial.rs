//! PLM's per-image correction: histogram matching of the model image onto the original image, and
//! a least-squares polynomial Ỹ = Σ_{j=0..4} a_j Y^j fitted to the resulting mapping.
//!
//! Histogram matching is done exactly, by ranks: both images are sorted and the k-th smallest
//! model value is paired with the k-th smallest original value (the limit of matching cumulative
//! histograms with one bin per distinct value; no bin-width choice, ties handled by averaging in
//! the least-squares fit).

/// Polynomial coefficients a_0..a_4 of Ỹ = Σ a_j Y^j.
pub type Poly = [f32; 5];

/// The identity mapping (used for plain LM models).
pub const IDENTITY: Poly = [0.0, 1.0, 0.0, 0.0, 0.0];

/// Grid points on which monotonicity of a fitted mapping is checked.
const MONOTONE_GRID: usize = 64;

/// Evaluates Σ a_j y^j (Horner); the caller clamps negative results if it needs reflectances.
#[inline]
pub fn eval(a: &Poly, y: f32) -> f32 {
    (((a[4] * y + a[3]) * y + a[2]) * y + a[1]) * y + a[0]
}

/// Reusable buffers so fitting many images allocates nothing per image.
#[derive(Default, Debug)]
pub struct Scratch {
    model: Vec<f32>,
    orig: Vec<f32>,
    keys: Vec<u32>,
    tmp: Vec<u32>,
}

/// Order-preserving map of f32 bits to u32 (the IEEE total order, as `f32::total_cmp`).
#[inline]
fn key(v: f32) -> u32 {
    let b = v.to_bits();
    if b & 0x8000_0000 != 0 {
        !b
    } else {
        b | 0x8000_0000
    }
}

#[inline]
fn unkey(k: u32) -> f32 {
    f32::from_bits(if k & 0x8000_0000 != 0 {
        k & 0x7fff_ffff
    } else {
        !k
    })
}

/// Sorts `v` ascending in `f32::total_cmp` order with an LSD radix sort (4 passes of 8 bits;
/// several times faster than a comparison sort for the 10³–10⁵ values of one image).
pub fn radix_sort(v: &mut [f32], keys: &mut Vec<u32>, tmp: &mut Vec<u32>) {
    if v.len() < 64 {
        v.sort_unstable_by(f32::total_cmp);
        return;
    }
    keys.clear();
    keys.extend(v.iter().map(|&x| key(x)));
    tmp.clear();
    tmp.resize(v.len(), 0);
    for pass in 0..4 {
        let shift = 8 * pass;
        let mut count = [0usize; 256];
        for &k in keys.iter() {
            count[((k >> shift) & 0xff) as usize] += 1;
        }
        if count.contains(&keys.len()) {
            continue; // all keys share this byte: the pass would not move anything
        }
        let mut sum = 0;
        for c in count.iter_mut() {
            let n = *c;
            *c = sum;
            sum += n;
        }
        for &k in keys.iter() {
            let b = ((k >> shift) & 0xff) as usize;
            tmp[count[b]] = k;
            count[b] += 1;
        }
        std::mem::swap(keys, tmp);
    }
    for (o, &k) in v.iter_mut().zip(keys.iter()) {
        *o = unkey(k);
    }
}

/// Rank-based histogram matching: returns the sorted model values and the original values of the
/// same ranks (the mapping model value → original value as pairs).
pub fn match_histograms<'a>(
    model: &[f32],
    orig: &[f32],
    s: &'a mut Scratch,
) -> (&'a [f32], &'a [f32]) {
    s.model.clear();
    s.model.extend_from_slice(model);
    s.orig.clear();
    s.orig.extend_from_slice(orig);
    radix_sort(&mut s.model, &mut s.keys, &mut s.tmp);
    radix_sort(&mut s.orig, &mut s.keys, &mut s.tmp);
    (&s.model, &s.orig)
}

/// Fits the histogram-matching mapping from `model` values to `orig` values (same texels, same
/// length) with a polynomial of degree ≤ 4. The highest degree whose polynomial is monotone
/// non-decreasing over the model values' range is kept (degree 1 always is, as the matched pairs
/// are both sorted).
pub fn fit_mapping(model: &[f32], orig: &[f32], s: &mut Scratch) -> Poly {
    debug_assert_eq!(model.len(), orig.len());
    if model.is_empty() {
        return IDENTITY;
    }
    let (m, o) = match_histograms(model, orig, s);
    fit_pairs(m, o)
}

/// [`fit_mapping`] with the original image already sorted ascending (it is shared by the PLM and
/// PLM-C fits of one image, so it is sorted once).
pub fn fit_mapping_sorted(model: &[f32], orig_sorted: &[f32], s: &mut Scratch) -> Poly {
    debug_assert_eq!(model.len(), orig_sorted.len());
    if model.is_empty() {
        return IDENTITY;
    }
    s.model.clear();
    s.model.extend_from_slice(model);
    radix_sort(&mut s.model, &mut s.keys, &mut s.tmp);
    fit_pairs(&s.model, orig_sorted)
}

/// Least-squares polynomial through sorted (x, y) pairs, degree ≤ 4, monotone over the x range.
pub fn fit_pairs(x: &[f32], y: &[f32]) -> Poly {
    let n = x.len();
    let mean_y = y.iter().map(|&v| v as f64).sum::<f64>() / n.max(1) as f64;
    let lo = x.iter().copied().fold(f32::INFINITY, f32::min) as f64;
    let hi = x.iter().copied().fold(f32::NEG_INFINITY, f32::max) as f64;
    let scale = hi.abs().max(lo.abs());
    if n == 0 || scale.is_nan() || scale <= 0.0 || hi - lo <= 1e-9 * scale {
        // A constant model image carries no ordering: map everything to the mean.
        return [mean_y as f32, 0.0, 0.0, 0.0, 0.0];
    }
    // Moments of t = x / scale ∈ [-1, 1] (in practice [0, 1]).
    let mut mom = [0.0f64; 9];
    let mut rhs = [0.0f64; 5];
    for (&xi, &yi) in x.iter().zip(y) {
        let t = xi as f64 / scale;
        let mut p = 1.0;
        for (k, m) in mom.iter_mut().enumerate() {
            *m += p;
            if k < 5 {
                rhs[k] += p * yi as f64;
            }
            p *= t;
        }
    }
    for degree in (1..=4usize).rev() {
        let Some(b) = solve_moments(&mom, &rhs, degree + 1) else {
            continue;
        };
        if degree > 1 && !monotone(&b, degree, lo / scale, hi / scale) {
            continue;
        }
        let mut a = [0.0f32; 5];
        let mut s = 1.0;
        for j in 0..=degree {
            a[j] = (b[j] / s) as f32;
            s *= scale;
        }
        if a.iter().all(|v| v.is_finite()) {
            return a;
        }
    }
    [mean_y as f32, 0.0, 0.0, 0.0, 0.0]
}

fn monotone(b: &[f64; 5], degree: usize, lo: f64, hi: f64) -> bool {
    let range = (0..=degree)
        .map(|j| b[j].abs())
        .fold(0.0, f64::max)
        .max(1e-30);
    (0..=MONOTONE_GRID).all(|g| {
        let t = lo + (hi - lo) * g as f64 / MONOTONE_GRID as f64;
        let mut d = 0.0;
        let mut p = 1.0;
        for (j, bj) in b.iter().enumerate().take(degree + 1).skip(1) {
            d += j as f64 * bj * p;
            p *= t;
        }
        d >= -1e-9 * range
    })
}

/// Solves the (size × size) normal equations given by power moments with Gaussian elimination
/// and partial pivoting. None if singular (fewer distinct x than coefficients).
fn solve_moments(mom: &[f64; 9], rhs: &[f64; 5], size: usize) -> Option<[f64; 5]> {
    let mut a = [[0.0f64; 6]; 5];
    for r in 0..size {
        a[r][..size].copy_from_slice(&mom[r..r + size]);
        a[r][5] = rhs[r];
    }
    let norm = mom[0].abs().max(1e-300);
    for col in 0..size {
        let piv = (col..size).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[piv][col].abs() <= 1e-13 * norm {
            return None;
        }
        a.swap(col, piv);
        for r in 0..size {
            if r != col {
                let f = a[r][col] / a[col][col];
                for c in col..6 {
                    a[r][c] -= f * a[col][c];
                }
            }
        }
    }
    let mut x = [0.0; 5];
    for r in 0..size {
        x[r] = a[r][5] / a[r][r];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Pcg32;

    #[test]
    fn matching_recovers_a_monotone_transform_of_the_image_exactly() {
        let mut rng = Pcg32::new(9, 2);
        let model: Vec<f32> = (0..4096).map(|_| rng.next_f32()).collect();
        // Original = monotone cubic of the model image, with texels shuffled (a permutation keeps the
        // histogram): the rank matching must find f exactly.
        let f = |y: f32| 0.05 + 0.3 * y + 0.5 * y * y * y;
        let mut orig: Vec<f32> = model.iter().map(|&y| f(y)).collect();
        for i in (1..orig.len()).rev() {
            let j = rng.next_below(i as u32 + 1) as usize;
            orig.swap(i, j);
        }
        let mut s = Scratch::default();
        let (m, o) = match_histograms(&model, &orig, &mut s);
        for (&mi, &oi) in m.iter().zip(o) {
            assert!((f(mi) - oi).abs() < 1e-6);
        }
        let a = fit_mapping(&model, &orig, &mut s);
        for y in [0.0f32, 0.1, 0.5, 0.9, 1.0] {
            assert!((eval(&a, y) - f(y)).abs() < 1e-4, "{a:?}");
        }
    }

    #[test]
    fn non_monotone_fits_fall_back_to_a_monotone_degree() {
        // A step mapping: degree-4 LSQ overshoots; the kept polynomial must be non-decreasing.
        let x: Vec<f32> = (0..200).map(|i| i as f32 / 199.0).collect();
        let y: Vec<f32> = x.iter().map(|&v| if v < 0.5 { 0.0 } else { 1.0 }).collect();
        let a = fit_pairs(&x, &y);
        let mut prev = f32::NEG_INFINITY;
        for i in 0..=100 {
            let v = eval(&a, i as f32 / 100.0);
            assert!(v >= prev - 1e-5, "{a:?}");
            prev = v;
        }
        assert!(eval(&a, 1.0) - eval(&a, 0.0) > 0.5);
    }

    #[test]
    fn radix_sort_matches_total_cmp() {
        let mut rng = Pcg32::new(4, 4);
        let mut v: Vec<f32> = (0..5000)
            .map(|i| match i % 7 {
                0 => -rng.next_f32() * 10.0,
                1 => 0.0,
                2 => -0.0,
                3 => rng.next_f32() * 1e-30,
                _ => rng.next_f32(),
            })
            .collect();
        let mut want = v.clone();
        want.sort_unstable_by(f32::total_cmp);
        let (mut k, mut t) = (Vec::new(), Vec::new());
        radix_sort(&mut v, &mut k, &mut t);
        assert!(v.iter().zip(&want).all(|(a, b)| a.to_bits() == b.to_bits()));
    }

    #[test]
    fn constant_images_give_constant_mappings() {
        let mut s = Scratch::default();
        let a = fit_mapping(&[0.2; 100], &[0.5; 100], &mut s);
        assert_eq!(a, [0.5, 0.0, 0.0, 0.0, 0.0]);
        let b = fit_mapping(&[0.0; 10], &[0.0; 10], &mut s);
        assert_eq!(eval(&b, 0.3), 0.0);
        assert_eq!(fit_mapping(&[], &[], &mut s), IDENTITY);
    }
}
