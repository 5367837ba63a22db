//! Fitting PLM's per-image correction: histogram matching of the model image onto the original image, and
//! a least-squares polynomial Ỹ = Σ_{j=0..4} a_j Y^j fitted to the resulting mapping.
//!
//! Histogram matching is done exactly, by ranks: both images are sorted and the k-th smallest
//! model value is paired with the k-th smallest original value (the limit of matching cumulative
//! histograms with one bin per distinct value; no bin-width choice, ties handled by averaging in
//! the least-squares fit).

use crate::math::order_key::{key, unkey};
use crate::math::simd::isa;
use crate::model::polynomial::{E_RANGE, IDENTITY, Poly, decode, eval, quantise};

/// Grid points on which monotonicity of a fitted mapping is checked.
const MONOTONE_GRID: usize = 64;

/// Reusable buffers so fitting many images allocates nothing per image.
#[derive(Default, Debug)]
pub struct Scratch {
    model: Vec<f32>,
    orig: Vec<f32>,
    keys: Vec<u32>,
    tmp: Vec<u32>,
    pair_keys: Vec<u64>,
    pair_tmp: Vec<u64>,
    xs: Vec<f32>,
    ys: Vec<f32>,
}

impl Scratch {
    /// The pairs (`x[i]`, `y(i)`) sorted by x ascending in `f32::total_cmp` order, ties in index
    /// order (a stable LSD radix sort on the x key: the order, and so every sum over the pairs,
    /// is fixed), as the slices (xs, ys). y travels with its key as the sort's payload, so `y` is
    /// read in index order (no gather after the sort).
    pub fn sort_pairs(&mut self, x: &[f32], y: impl Fn(usize) -> f32) -> (&[f32], &[f32]) {
        let n = x.len();
        self.pair_keys.clear();
        self.pair_keys.extend(
            x.iter()
                .enumerate()
                .map(|(i, &v)| ((key(v) as u64) << 32) | y(i).to_bits() as u64),
        );
        self.pair_tmp.clear();
        self.pair_tmp.resize(n, 0);
        radix_passes(&mut self.pair_keys, &mut self.pair_tmp, |k, pass| {
            ((k >> (32 + 8 * pass)) & 0xff) as usize
        });
        self.xs.clear();
        self.ys.clear();
        for &k in &self.pair_keys {
            self.xs.push(unkey((k >> 32) as u32));
            self.ys.push(f32::from_bits(k as u32));
        }
        (&self.xs, &self.ys)
    }
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
    radix_passes(keys, tmp, |k, pass| ((k >> (8 * pass)) & 0xff) as usize);
    for (o, &k) in v.iter_mut().zip(keys.iter()) {
        *o = unkey(k);
    }
}

/// The 4 byte passes of a stable LSD radix sort of `keys` (`tmp` as long, scratch), `byte(key,
/// pass)` the pass's digit. The four digit histograms are counted in one read of the keys; a pass
/// where every key has the same digit is skipped (it would not move anything).
#[inline]
fn radix_passes<T: Copy>(keys: &mut Vec<T>, tmp: &mut Vec<T>, byte: impl Fn(T, u32) -> usize) {
    let n = keys.len();
    let mut counts = [[0usize; 256]; 4];
    for &k in keys.iter() {
        for (pass, count) in counts.iter_mut().enumerate() {
            count[byte(k, pass as u32)] += 1;
        }
    }
    for (pass, count) in counts.iter_mut().enumerate() {
        if count.contains(&n) {
            continue;
        }
        let mut sum = 0;
        for c in count.iter_mut() {
            let m = *c;
            *c = sum;
            sum += m;
        }
        for &k in keys.iter() {
            let b = byte(k, pass as u32);
            tmp[count[b]] = k;
            count[b] += 1;
        }
        std::mem::swap(keys, tmp);
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

/// Least-squares polynomial through sorted (x, y) pairs, degree ≤ 4, monotone over the x range;
/// the domain the mapping is conditioned on is `[0, max(|x|, floor)]` (see [`fit_pairs_in`]).
pub fn fit_pairs(x: &[f32], y: &[f32]) -> Poly {
    fit_pairs_in(x, y, 0.0)
}

/// Largest growth of a kept mapping over its domain: Σ_j |a_j|·D^j ≤ `MAX_GROWTH`·max|y|. It bounds
/// both the cancellation of a power-basis evaluation in f32 (error ≲ 5·2⁻²⁴·`MAX_GROWTH`·max|y|)
/// and what the mapping does for lobe values between the measured ones anywhere in `[0, D]`.
const MAX_GROWTH: f64 = 64.0;

/// [`fit_pairs`] with the mapping conditioned on the domain `[0, D]`, D = max(|x|, `floor`).
///
/// The fit is solved in the normalised variable t = (x − centre)/half-range ∈ [−1, 1] (well
/// conditioned even for a narrow x range far from 0) with degree ≤ min(4, distinct x − 1); a
/// degree is kept only if its mapping is non-decreasing over the x range and its power-basis
/// coefficients satisfy the growth bound on `[0, D]`. `floor` is the scale the model values of
/// the other images of the view reach (the renderer evaluates the mapping anywhere up to it): an
/// image whose model values are all tiny relative to it gets a low-degree or constant mapping
/// instead of coefficients of 10³⁸. Constant, all-zero and single-valued images map to the mean.
/// The result is snapped to the file's quantised encoding ([`PackedPoly`](crate::model::polynomial::PackedPoly)) when that costs less than
/// [`SNAP_TOLERANCE`] of the output scale on the image's range of model values.
pub fn fit_pairs_in(x: &[f32], y: &[f32], floor: f32) -> Poly {
    let n = x.len().min(y.len());
    let (x, y) = (&x[..n], &y[..n]);
    let s = PairStats::new(x, y, floor);
    s.solve(&moments(x, y, &s))
}

/// Residual floor of [`fit_pairs_l1`]'s reweighting, relative to max|y| (weights ≤ 1/floor).
const L1_EPS: f64 = 1e-3;

/// The mapping through sorted (x, y) pairs with the least *absolute* error (the MAE the model is
/// judged by; [`fit_pairs_in`] minimises the squared error), by `rounds` of iteratively
/// reweighted least squares (weights 1/max(|residual|, ε)) from the least-squares mapping, under
/// the same degree, monotonicity and growth rules. Returns the round with the lowest absolute
/// error (outputs clamped at 0 as the model clamps them), never worse than the least-squares one,
/// and that error Σ|max(p(x), 0) − y|.
///
/// One pass over the pairs per round: the residuals of the current mapping give both its
/// absolute error and the next round's weights, and pairs of equal x (a clustered model image has
/// at most K distinct values) are summed into their run before the moments are formed.
pub fn fit_pairs_l1(x: &[f32], y: &[f32], floor: f32, rounds: usize) -> (Poly, f64) {
    fit_pairs_l1_isa(isa(), x, y, floor, rounds)
}

crate::isa_dispatch! {
    /// [`fit_pairs_l1`] built for an instruction set (the lane-split sums are fixed: same bits).
    fn fit_pairs_l1_isa(x: &[f32], y: &[f32], floor: f32, rounds: usize) -> (Poly, f64) = fit_pairs_l1_impl;
}

#[inline(always)]
fn fit_pairs_l1_impl(x: &[f32], y: &[f32], floor: f32, rounds: usize) -> (Poly, f64) {
    let n = x.len().min(y.len());
    let (x, y) = (&x[..n], &y[..n]);
    let stats = PairStats::new(x, y, floor);
    let lsq = stats.solve(&moments(x, y, &stats));
    let eps = (L1_EPS * stats.y_abs).max(1e-12) as f32;
    let mut best = lsq;
    let mut best_e = f64::INFINITY;
    let mut cur = lsq;
    for _ in 0..rounds {
        let (e, m) = residual_moments(x, y, &stats, &cur, eps);
        if e < best_e {
            (best, best_e) = (cur, e);
        }
        cur = stats.solve(&m);
    }
    let e = abs_error(x, y, &cur);
    if e < best_e {
        (best, best_e) = (cur, e);
    }
    (best, best_e)
}

/// Lanes of the per-run sums (independent accumulators, so the loops vectorise).
const RUN_LANES: usize = 8;

/// Over one run's values `ys` at model output `v`: (Σ r, Σ w, Σ w·y) with r = |v − y| and
/// w = 1/max(r, `eps`); `eps` = ∞ gives (Σ r, ·, ·) alone. Lane-split f64 sums of f32 terms.
#[inline(always)]
fn run_sums(ys: &[f32], v: f32, eps: f32) -> (f64, f64, f64) {
    let mut out = [0.0f64; 3];
    let chunks = ys.chunks_exact(RUN_LANES);
    let tail = chunks.remainder();
    if ys.len() >= RUN_LANES {
        let mut acc = [[0.0f64; RUN_LANES]; 3];
        for c in chunks {
            for l in 0..RUN_LANES {
                let r = (v - c[l]).abs();
                let w = 1.0 / r.max(eps);
                acc[0][l] += r as f64;
                acc[1][l] += w as f64;
                acc[2][l] += w as f64 * c[l] as f64;
            }
        }
        for (o, a) in out.iter_mut().zip(&acc) {
            *o = a.iter().sum();
        }
    }
    for &o in tail {
        let r = (v - o).abs();
        let w = 1.0 / r.max(eps);
        out[0] += r as f64;
        out[1] += w as f64;
        out[2] += w as f64 * o as f64;
    }
    (out[0], out[1], out[2])
}

/// Σ|max(p(x), 0) − y| over the pairs (lane-split sums in a fixed order).
#[inline(always)]
pub fn abs_error(x: &[f32], y: &[f32], a: &Poly) -> f64 {
    pair_sums::<true>(x, y, None, a, 1.0).0
}

/// The end of the run of values equal to `x[lo]` that starts at `lo` in the sorted `x`.
#[inline(always)]
fn run_end(x: &[f32], lo: usize) -> usize {
    let v = x[lo];
    let mut hi = lo + 1;
    while hi < x.len() && x[hi] == v {
        hi += 1;
    }
    hi
}

/// What the normal equations of one set of sorted pairs need besides the moments: the
/// normalisation t = (x − centre)/half, the degree limit and the bounds of the result.
struct PairStats {
    centre: f64,
    inv_half: f64,
    half: f64,
    /// The mapping when no polynomial of degree ≥ 1 is determined: the mean of y.
    constant: Poly,
    /// min(4, distinct x − 1); 0 = constant.
    max_degree: usize,
    /// max|y| (the output scale of the growth bound).
    y_abs: f64,
    /// The domain the mapping is conditioned on, max(|x|, floor).
    domain: f64,
    /// max|x| (the image's own range, for snapping).
    x_abs: f64,
    /// Whether the sums go pair by pair ([`pair_sums`]) rather than run by run: most x are
    /// distinct (a texel-wise model image), so runs would be a loop of length one.
    by_pair: bool,
}

impl PairStats {
    fn new(x: &[f32], y: &[f32], floor: f32) -> Self {
        let n = x.len();
        let mean_y = y.iter().map(|&v| v as f64).sum::<f64>() / n.max(1) as f64;
        let constant = [mean_y as f32, 0.0, 0.0, 0.0, 0.0];
        let lo = x.iter().copied().fold(f32::INFINITY, f32::min) as f64;
        let hi = x.iter().copied().fold(f32::NEG_INFINITY, f32::max) as f64;
        let y_abs = y.iter().fold(0.0f64, |m, &v| m.max((v as f64).abs()));
        let (centre, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        let mut max_degree = 0;
        if n > 0 && lo.is_finite() && hi.is_finite() && mean_y.is_finite() {
            // Distinct x values (the pairs are sorted): a polynomial of degree ≥ distinct is not
            // determined.
            let distinct = 1 + x.windows(2).filter(|w| w[1] != w[0]).take(4).count();
            max_degree = (distinct - 1).min(4);
            if half <= 1e-7 * hi.abs().max(lo.abs()) || y_abs == 0.0 {
                max_degree = 0;
            }
        }
        let x_abs = hi.abs().max(lo.abs());
        let runs = 1 + x.windows(2).filter(|w| w[1] != w[0]).count();
        PairStats {
            by_pair: runs * PAIR_RUN_LENGTH > n,
            centre,
            inv_half: 1.0 / half,
            half,
            constant,
            max_degree,
            y_abs,
            domain: x_abs.max(floor as f64),
            x_abs,
        }
    }

    /// The highest admissible degree's mapping from the (weighted) moments: monotone on the x
    /// range, within the growth bound on the domain, snapped to the file's encoding when that is
    /// harmless; the constant when no degree is.
    fn solve(&self, m: &Moments) -> Poly {
        if self.max_degree == 0 {
            return self.constant;
        }
        for degree in (1..=self.max_degree).rev() {
            let Some(b) = solve_moments(&m.mom, &m.rhs, degree + 1) else {
                continue;
            };
            if degree > 1 && !monotone(&b, degree, -1.0, 1.0) {
                continue;
            }
            let a = to_power_basis(&b, degree, self.centre, self.half);
            let bounded = |a: &Poly| {
                let growth: f64 = (0..5)
                    .map(|j| (a[j] as f64).abs() * self.domain.powi(j as i32))
                    .sum();
                a.iter().all(|v| v.is_finite()) && growth <= MAX_GROWTH * self.y_abs
            };
            if bounded(&a) {
                // The snapped mapping must keep the growth bound too (quantisation noise in high
                // coefficients of a tiny domain is amplified on the view's domain).
                let snapped = snap(&a, self.x_abs as f32, self.y_abs as f32);
                return if bounded(&snapped) { snapped } else { a };
            }
        }
        self.constant
    }
}

/// Power moments Σ w·t^k (k ≤ 8) and Σ w·y·t^k (k ≤ 4) of the normal equations in t.
#[derive(Default)]
struct Moments {
    mom: [f64; 9],
    rhs: [f64; 5],
}

impl Moments {
    /// Adds a run at `t` of summed weight `w` and summed weighted value `wy`.
    #[inline(always)]
    fn add(&mut self, t: f64, w: f64, wy: f64) {
        let (mut p, mut q) = (w, wy);
        for k in 0..9 {
            self.mom[k] += p;
            if k < 5 {
                self.rhs[k] += q;
            }
            p *= t;
            q *= t;
        }
    }
}

/// The unweighted moments of sorted pairs.
#[inline(always)]
fn moments(x: &[f32], y: &[f32], s: &PairStats) -> Moments {
    let mut m = Moments::default();
    if s.max_degree == 0 {
        return m;
    }
    if s.by_pair {
        return pair_sums::<false>(x, y, Some(s), &IDENTITY, 0.0).1;
    }
    let mut lo = 0;
    while lo < x.len() {
        let hi = run_end(x, lo);
        let t = (x[lo] as f64 - s.centre) * s.inv_half;
        let sy = y[lo..hi].iter().map(|&v| v as f64).sum::<f64>();
        m.add(t, (hi - lo) as f64, sy);
        lo = hi;
    }
    m
}

/// One IRLS step's pass: the absolute error of `a` on the pairs and the moments weighted by
/// 1/max(|residual of a|, `eps`).
#[inline(always)]
fn residual_moments(x: &[f32], y: &[f32], s: &PairStats, a: &Poly, eps: f32) -> (f64, Moments) {
    if s.by_pair {
        return pair_sums::<true>(x, y, Some(s), a, eps);
    }
    let mut m = Moments::default();
    let (mut e, mut lo) = (0.0f64, 0);
    while lo < x.len() {
        let hi = run_end(x, lo);
        let xv = x[lo];
        let (r, sw, swy) = run_sums(&y[lo..hi], eval(a, xv).max(0.0), eps);
        e += r;
        if s.max_degree > 0 {
            m.add((xv as f64 - s.centre) * s.inv_half, sw, swy);
        }
        lo = hi;
    }
    (e, m)
}

/// Runs shorter than this on average make [`PairStats`] sum pair by pair.
const PAIR_RUN_LENGTH: usize = 4;

/// Lanes of [`pair_sums`]' accumulators (8 f64: one AVX-512 register, two AVX2 ones; the sums
/// are split into these lanes in the same fixed order in every build, so the bits agree).
const PAIR_LANES: usize = 8;

/// The moments over the pairs one by one, lane-split: unweighted (`WEIGHTED` = false: w = 1,
/// no error) or weighted by w = 1/max(|max(a(x), 0) − y|, `eps`) with Σ|max(a(x), 0) − y| as the
/// first result; `s` = None: the error alone. For images whose x are mostly distinct, where run sums ([`run_sums`]) degrade
/// to a serial chain of f64 adds per pair.
#[inline(always)]
fn pair_sums<const WEIGHTED: bool>(
    x: &[f32],
    y: &[f32],
    s: Option<&PairStats>,
    a: &Poly,
    eps: f32,
) -> (f64, Moments) {
    let (centre, inv_half) = s.map_or((0.0, 0.0), |s| (s.centre, s.inv_half));
    let degree = s.is_some_and(|s| s.max_degree > 0);
    let one = |xv: f32, yv: f32| -> (f64, f64, f64, f64) {
        let t = (xv as f64 - centre) * inv_half;
        if WEIGHTED {
            let r = (eval(a, xv).max(0.0) - yv).abs();
            let w = 1.0 / r.max(eps);
            (r as f64, t, w as f64, w as f64 * yv as f64)
        } else {
            (0.0, t, 1.0, yv as f64)
        }
    };
    let mut e = [0.0f64; PAIR_LANES];
    let mut mom = [[0.0f64; PAIR_LANES]; 9];
    let mut rhs = [[0.0f64; PAIR_LANES]; 5];
    let xc = x.chunks_exact(PAIR_LANES);
    let yc = y.chunks_exact(PAIR_LANES);
    let (xt, yt) = (xc.remainder(), yc.remainder());
    for (xs, ys) in xc.zip(yc) {
        for l in 0..PAIR_LANES {
            let (r, t, w, wy) = one(xs[l], ys[l]);
            e[l] += r;
            if degree {
                let (mut p, mut q) = (w, wy);
                for k in 0..9 {
                    mom[k][l] += p;
                    if k < 5 {
                        rhs[k][l] += q;
                    }
                    p *= t;
                    q *= t;
                }
            }
        }
    }
    let mut m = Moments::default();
    let mut err: f64 = e.iter().sum();
    for (o, a) in m.mom.iter_mut().zip(&mom) {
        *o = a.iter().sum();
    }
    for (o, a) in m.rhs.iter_mut().zip(&rhs) {
        *o = a.iter().sum();
    }
    for (&xv, &yv) in xt.iter().zip(yt) {
        let (r, t, w, wy) = one(xv, yv);
        err += r;
        if degree {
            m.add(t, w, wy);
        }
    }
    (err, m)
}

/// p(x) = Σ_j b_j ((x − c)/h)^j expanded into powers of x (f64, rounded once to f32).
fn to_power_basis(b: &[f64; 5], degree: usize, c: f64, h: f64) -> Poly {
    const BINOM: [[f64; 5]; 5] = [
        [1.0, 0.0, 0.0, 0.0, 0.0],
        [1.0, 1.0, 0.0, 0.0, 0.0],
        [1.0, 2.0, 1.0, 0.0, 0.0],
        [1.0, 3.0, 3.0, 1.0, 0.0],
        [1.0, 4.0, 6.0, 4.0, 1.0],
    ];
    let mut a = [0.0f64; 5];
    for j in 0..=degree {
        let bj = b[j] / h.powi(j as i32);
        for i in 0..=j {
            a[i] += bj * BINOM[j][i] * (-c).powi((j - i) as i32);
        }
    }
    a.map(|v| v as f32)
}

/// Largest error, relative to the output scale max|y|, a fitted mapping may take on by being
/// snapped to the file's quantised encoding (1e-4 of an 8-bit sRGB range is 0.026 levels).
pub const SNAP_TOLERANCE: f64 = 1e-4;
/// `a` snapped to the quantised encoding on [0, 2^e] ⊇ [0, `domain`] (the image's own model values)
/// if that changes it there by at most [`SNAP_TOLERANCE`]·`y_abs`; otherwise `a` itself. Beyond the
/// domain the change grows like the Bernstein basis' absolute sum (2t − 1)⁴: ≤ 81× at twice the
/// domain, so ≤ 0.81 % of the output scale there.
fn snap(a: &Poly, domain: f32, y_abs: f32) -> Poly {
    let e = (domain as f64)
        .log2()
        .ceil()
        .clamp(*E_RANGE.start() as f64, *E_RANGE.end() as f64);
    match quantise(a, e as i32, None) {
        Some(p) if 0.5 * (p.s as f64).exp2() <= SNAP_TOLERANCE * y_abs as f64 => {
            decode(&p).unwrap_or(*a)
        }
        _ => *a,
    }
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
    use crate::model::polynomial::encode;

    #[test]
    fn l1_mapping_ignores_outliers_and_lowers_the_absolute_error() {
        // y = 0.1 + 0.6 x with small noise, and 10 % of the pairs pulled far up (texels the model
        // misses): least squares bends towards them, least absolute error keeps the line.
        let mut rng = Pcg32::new(4, 4);
        let n = 2000;
        let x: Vec<f32> = (0..n).map(|i| i as f32 / n as f32).collect();
        let y: Vec<f32> = x
            .iter()
            .map(|&v| {
                let base = 0.1 + 0.6 * v + 0.002 * (rng.next_f32() - 0.5);
                if rng.next_f32() < 0.1 {
                    base + 0.3
                } else {
                    base
                }
            })
            .collect();
        let abs_err = |a: &Poly| {
            x.iter()
                .zip(&y)
                .map(|(&m, &o)| (eval(a, m).max(0.0) - o).abs() as f64)
                .sum::<f64>()
        };
        let lsq = fit_pairs_in(&x, &y, 0.0);
        let (l1, l1_err) = fit_pairs_l1(&x, &y, 0.0, 6);
        // The error it reports is the absolute error of the mapping it returns.
        assert!((l1_err - abs_err(&l1)).abs() <= 1e-9 * l1_err, "{l1_err}");
        assert!(
            abs_err(&l1) < 0.8 * abs_err(&lsq),
            "{} {}",
            abs_err(&l1),
            abs_err(&lsq)
        );
        for &v in &[0.1f32, 0.5, 0.9] {
            assert!((eval(&l1, v) - (0.1 + 0.6 * v)).abs() < 0.01, "{v}: {l1:?}");
        }
        // Zero rounds is the least-squares mapping; constant data stay constant.
        assert_eq!(fit_pairs_l1(&x, &y, 0.0, 0).0, lsq);
        assert_eq!(fit_pairs_l1(&x, &[0.25; 2000], 0.0, 4).0[1..], [0.0; 4]);
        // A clustered image (few distinct x, each a long run): the runs are summed before the
        // moments, which must give the mapping of the pairs taken one by one (here: the same
        // line through the run means, to rounding).
        let xc: Vec<f32> = (0..n).map(|i| (i % 7) as f32 / 7.0).collect();
        let mut pairs: Vec<(f32, f32)> = xc
            .iter()
            .map(|&v| (v, 0.2 + 0.5 * v + 0.01 * (rng.next_f32() - 0.5)))
            .collect();
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (xs, ys): (Vec<f32>, Vec<f32>) = pairs.into_iter().unzip();
        let a = fit_pairs_in(&xs, &ys, 0.0);
        for j in 0..7 {
            let v = j as f32 / 7.0;
            let run: Vec<f32> = (0..n).filter(|&i| xs[i] == v).map(|i| ys[i]).collect();
            let mean = run.iter().sum::<f32>() / run.len() as f32;
            assert!(
                (eval(&a, v) - mean).abs() < 2e-3,
                "{v}: {} vs {mean}",
                eval(&a, v)
            );
        }
    }

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

    fn growth(a: &Poly, d: f64) -> f64 {
        (0..5).map(|j| (a[j] as f64).abs() * d.powi(j as i32)).sum()
    }

    #[test]
    fn tiny_and_narrow_model_ranges_keep_bounded_coefficients() {
        let mut rng = Pcg32::new(3, 1);
        // Model values ~1e-9 (a sharp lobe at a grazing light) while the view reaches 1: the old
        // fit scaled by 2e-9 and returned a_4 ~ 1e35.
        let mut x: Vec<f32> = (0..1000).map(|_| 1e-9 * (1.0 + rng.next_f32())).collect();
        x.sort_unstable_by(f32::total_cmp);
        let y: Vec<f32> = x
            .iter()
            .map(|&v| 0.2 + 0.1 * ((v - 1e-9) / 1e-9).powi(2))
            .collect();
        let a = fit_pairs_in(&x, &y, 1.0);
        assert!(growth(&a, 1.0) <= MAX_GROWTH * 0.3, "{a:?}");
        assert!(
            y.iter()
                .zip(&x)
                .all(|(&yi, &xi)| (eval(&a, xi) - yi).abs() <= 0.1),
            "{a:?}"
        );
        // A narrow range far from 0: normalised fit, bounded growth, still follows the data.
        let x: Vec<f32> = (0..1000).map(|i| 0.5 + 1e-4 * i as f32 / 999.0).collect();
        let y: Vec<f32> = x.iter().map(|&v| 0.3 + 1e3 * (v - 0.5)).collect();
        let a = fit_pairs_in(&x, &y, 1.0);
        assert!(growth(&a, 1.0) <= MAX_GROWTH * 0.4, "{a:?}");
        let err = x
            .iter()
            .zip(&y)
            .map(|(&xi, &yi)| (eval(&a, xi) - yi).abs())
            .fold(0.0, f32::max);
        assert!(err < 0.06, "{err} {a:?}");
    }

    #[test]
    fn few_distinct_model_values_get_a_low_degree_exact_mapping() {
        // Three distinct model values with ties: a degree-2 mapping through the three means.
        let x: Vec<f32> = [0.1f32; 5]
            .iter()
            .chain(&[0.4; 5])
            .chain(&[0.8; 5])
            .copied()
            .collect();
        let y: Vec<f32> = (0..15)
            .map(|i| [0.05, 0.3, 0.9][i / 5] + 0.01 * (i % 5) as f32 - 0.02)
            .collect();
        let a = fit_pairs(&x, &y);
        for (xv, yv) in [(0.1f32, 0.05f32), (0.4, 0.3), (0.8, 0.9)] {
            assert!((eval(&a, xv) - yv).abs() < 1e-4, "{a:?}");
        }
        // Two distinct values: linear; all-zero originals: zero.
        let a = fit_pairs(&[0.2, 0.2, 0.6], &[0.1, 0.1, 0.5]);
        assert!(a[2..].iter().all(|&v| v.abs() < 1e-6) && (eval(&a, 0.6) - 0.5).abs() < 1e-5);
        assert_eq!(fit_pairs(&[0.1, 0.2, 0.3], &[0.0; 3]), [0.0; 5]);
    }

    #[test]
    fn packed_polynomials_round_trip_exactly_with_a_bounded_error() {
        let mut rng = Pcg32::new(8, 8);
        let mut packed = 0;
        for i in 0..500 {
            let scale = [1.0f32, 0.01, 3.0, 1e-5][i % 4];
            let x: Vec<f32> = {
                let mut v: Vec<f32> = (0..200).map(|_| scale * rng.next_f32()).collect();
                v.sort_unstable_by(f32::total_cmp);
                v
            };
            let g = 0.6 + rng.next_f32();
            let y: Vec<f32> = x
                .iter()
                .map(|&v| 0.8 * (v / scale).powf(g) + 0.01)
                .collect();
            let a = fit_pairs_in(&x, &y, scale);
            // The unsnapped fit differs from the snapped one by ≤ the tolerance on the data range.
            if let Some(p) = encode(&a) {
                packed += 1;
                assert_eq!(decode(&p), Some(a));
            }
            let err = x
                .iter()
                .zip(&y)
                .map(|(&xi, &yi)| (eval(&a, xi) - yi).abs())
                .fold(0.0, f32::max);
            assert!(err < 0.08, "{err} {a:?}");
        }
        assert!(
            packed >= 490,
            "{packed} of 500 fitted mappings have a packed form"
        );
        // Arbitrary coefficients: the quantisation error is within half a step on the domain.
        for _ in 0..200 {
            let a: Poly = std::array::from_fn(|_| rng.next_f32() * 4.0 - 2.0);
            let p = quantise(&a, 0, None).unwrap();
            let d = decode(&p).unwrap();
            let half = 0.5 * (p.s as f32).exp2();
            for g in 0..=64 {
                let t = g as f32 / 64.0;
                assert!((eval(&a, t) - eval(&d, t)).abs() <= half * 1.01 + 1e-6);
            }
        }
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
