//! Walker's alias method (Vose's construction) for discrete distributions sampled in O(1): a
//! sample reads one bin (its threshold and alias) instead of searching a CDF, so 16 lanes draw
//! at once with a gather each and no data-dependent loop. Several distributions of equal length
//! (the columns of each row of an environment map) share one flat table, one per row.
//!
//! The mapping from u to a bin is not monotone (unlike CDF inversion), which costs nothing with
//! independent random numbers; u is re-scaled inside the bin it picks so the continuous position
//! inside the bin stays uniform.

// `!(x > 0.0)` deliberately also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::math::simd::WIDTH;
use crate::math::simd::f16::{F16, lanes};

/// The largest f32 below 1: re-scaled numbers stay in [0, 1).
const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

/// One or more discrete distributions over `len` bins each, as alias tables.
#[derive(Clone, Debug)]
pub struct AliasTable {
    /// Bins per distribution.
    len: usize,
    /// Per bin (all rows, row-major): probability of keeping the bin when u lands in it.
    keep: Vec<f32>,
    /// Per bin: the bin taken otherwise (an index inside the same row).
    alias: Vec<u32>,
    /// Per bin: its probability within its row.
    pmf: Vec<f32>,
    /// Per row: the sum of its (sanitised) weights; 0 for a row with nothing to sample.
    totals: Vec<f64>,
}

impl AliasTable {
    /// One distribution over the weights; negative and non-finite weights count as 0. None if
    /// there are no bins or the weights sum to 0.
    pub fn new(weights: &[f64]) -> Option<AliasTable> {
        let t = AliasTable::rows(weights, weights.len())?;
        (t.totals[0] > 0.0).then_some(t)
    }

    /// A distribution per row of `len` consecutive weights (`weights.len()` a multiple of
    /// `len`); a row whose weights sum to 0 is uniform (never sampled by a caller that weighs
    /// rows by their totals) and has total 0. None if `len` is 0 or does not divide the weights.
    pub fn rows(weights: &[f64], len: usize) -> Option<AliasTable> {
        if len == 0 || weights.is_empty() || !weights.len().is_multiple_of(len) {
            return None;
        }
        let mut t = AliasTable {
            len,
            keep: vec![1.0; weights.len()],
            alias: vec![0; weights.len()],
            pmf: vec![0.0; weights.len()],
            totals: Vec::with_capacity(weights.len() / len),
        };
        let (mut small, mut large) = (Vec::new(), Vec::new());
        let mut scaled = vec![0f64; len];
        for (r, row) in weights.chunks_exact(len).enumerate() {
            let base = r * len;
            let clean = |x: f64| if x.is_finite() && x > 0.0 { x } else { 0.0 };
            let total: f64 = row.iter().map(|&x| clean(x)).sum();
            if !(total > 0.0) || !total.is_finite() {
                t.totals.push(0.0);
                for i in 0..len {
                    t.alias[base + i] = i as u32;
                    t.pmf[base + i] = 1.0 / len as f32;
                }
                continue;
            }
            t.totals.push(total);
            small.clear();
            large.clear();
            for (i, &x) in row.iter().enumerate() {
                let p = clean(x) / total;
                t.pmf[base + i] = p as f32;
                scaled[i] = p * len as f64;
                if scaled[i] < 1.0 {
                    small.push(i);
                } else {
                    large.push(i);
                }
            }
            // Vose: fill each under-full bin from an over-full one.
            while let (Some(&s), Some(&g)) = (small.last(), large.last()) {
                small.pop();
                t.keep[base + s] = scaled[s] as f32;
                t.alias[base + s] = g as u32;
                scaled[g] -= 1.0 - scaled[s];
                if scaled[g] < 1.0 {
                    large.pop();
                    small.push(g);
                }
            }
            // What is left is full up to rounding.
            for &i in small.iter().chain(&large) {
                t.keep[base + i] = 1.0;
                t.alias[base + i] = i as u32;
            }
            // Rounding must not make a zero-weight bin reachable: it always defers to a bin
            // with weight (there is one, the row's total is positive).
            let some = (0..len).find(|&i| t.pmf[base + i] > 0.0).unwrap_or(0) as u32;
            for i in 0..len {
                if t.pmf[base + i] == 0.0 {
                    t.keep[base + i] = 0.0;
                    if t.pmf[base + t.alias[base + i] as usize] == 0.0 {
                        t.alias[base + i] = some;
                    }
                }
            }
        }
        Some(t)
    }

    /// Bins per row.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True if a row has no bins (never, for a constructed table).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Sum of the weights row `r` was built from (0 for a row with nothing to sample).
    pub fn total(&self, r: usize) -> f64 {
        self.totals[r]
    }

    /// Probability of bin `i` of row `r`.
    #[inline]
    pub fn pmf(&self, r: usize, i: usize) -> f32 {
        self.pmf[r * self.len + i]
    }

    /// Picks a bin of row `r` for `u` in [0, 1): (bin, u re-scaled to [0, 1) inside it). A
    /// bin of probability 0 is never picked in a row with a positive total; u outside [0, 1)
    /// or NaN is clamped into it.
    #[inline]
    pub fn sample(&self, r: usize, u: f32) -> (usize, f32) {
        let n = self.len;
        let x = u * n as f32;
        let x = if x > 0.0 { x } else { 0.0 };
        let k = (x as usize).min(n - 1);
        let f = x - k as f32;
        let at = (r * n + k).min(self.keep.len() - 1);
        let q = self.keep[at];
        let a = self.alias[at] as usize;
        let stay = f < q;
        let i = if stay { k } else { a };
        let num = if stay { f } else { f - q };
        let den = if stay { q } else { 1.0 - q };
        (i, clamp_unit(num / den))
    }

    /// [`AliasTable::sample`] for 16 lanes, each in its own row `r[l]`: the same bins and
    /// re-scaled numbers, with one read of each table per lane and no loop that depends on u.
    #[inline(always)]
    pub fn sample_x(&self, r: [u32; WIDTH], u: F16) -> ([u32; WIDTH], F16) {
        let n = self.len;
        let last = self.keep.len() - 1;
        let x = u * n as f32;
        let x = F16::select(x.gt(F16::splat(0.0)), x, F16::splat(0.0));
        let k: [u32; WIDTH] = lanes(|l| (x.0[l] as u32).min(n as u32 - 1));
        let kf = F16(lanes(|l| k[l] as f32));
        let f = x - kf;
        let at: [usize; WIDTH] = lanes(|l| (r[l] as usize * n + k[l] as usize).min(last));
        let q = F16(lanes(|l| self.keep[at[l]]));
        let a: [u32; WIDTH] = lanes(|l| self.alias[at[l]]);
        let stay = f.lt(q);
        let i = lanes(|l| if stay.0[l] { k[l] } else { a[l] });
        let num = F16::select(stay, f, f - q);
        let den = F16::select(stay, q, 1.0 - q);
        (i, clamp_unit_x(num / den))
    }
}

/// `v` clamped to [0, 1) with NaN (0/0 in a bin of probability 0 or 1) to 0.
#[inline(always)]
fn clamp_unit(v: f32) -> f32 {
    let v = if v >= 0.0 { v } else { 0.0 };
    if v < ONE_MINUS_EPS { v } else { ONE_MINUS_EPS }
}

/// [`clamp_unit`] per lane.
#[inline(always)]
fn clamp_unit_x(v: F16) -> F16 {
    let v = F16::select(v.ge(F16::splat(0.0)), v, F16::splat(0.0));
    let one = F16::splat(ONE_MINUS_EPS);
    F16::select(v.lt(one), v, one)
}

#[cfg(test)]
mod tests;
