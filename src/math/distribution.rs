//! Discrete distributions for importance sampling: emitter triangles, environment-map rows and
//! columns, and the light-direction tables of measured BTFs.

// `!(x > 0.0)` deliberately also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::math::simd::WIDTH;
use crate::math::simd::f16::{F16, lanes};

/// A discrete distribution over `n` bins proportional to non-negative weights.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    /// Normalised cumulative sums; `cdf[i]` = P(bin < i + 1), last entry exactly 1.
    cdf: Vec<f32>,
    /// `cdf` shifted right by one with a leading 0 (`lower[i]` = P(bin < i)): each bin's lower
    /// edge without a branch on i = 0.
    lower: Vec<f32>,
    /// Probability of each bin.
    pmf: Vec<f32>,
    /// Guide table: entry i is the bin sampled at u = i / len, so a sample starts its scan next
    /// to its answer instead of a binary search whose branches mispredict (equal results); with
    /// that bin's lower edge, cdf and probability, so [`Distribution1D::sample_bin`] reads one
    /// 16-byte entry where the guided search reads the bin's edges and probability after it.
    guide: Vec<GuideBin>,
    /// Sum of the (sanitised) weights.
    total: f64,
}

impl Distribution1D {
    /// Builds from weights; negative and non-finite weights count as 0. Returns None if the sum
    /// is 0 (nothing to sample).
    pub fn new(weights: impl IntoIterator<Item = f64>) -> Option<Self> {
        let w: Vec<f64> = weights
            .into_iter()
            .map(|x| if x.is_finite() && x > 0.0 { x } else { 0.0 })
            .collect();
        let total: f64 = w.iter().sum();
        if !(total > 0.0) || !total.is_finite() {
            return None;
        }
        let mut acc = 0.0f64;
        let mut cdf = Vec::with_capacity(w.len());
        let mut pmf = Vec::with_capacity(w.len());
        for &x in &w {
            acc += x;
            cdf.push((acc / total) as f32);
            pmf.push((x / total) as f32);
        }
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        let n = cdf.len();
        let lower: Vec<f32> = std::iter::once(0.0)
            .chain(cdf[..n - 1].iter().copied())
            .collect();
        let guide = (0..n)
            .map(|i| {
                let u = i as f32 / n as f32;
                let t = cdf.partition_point(|&c| c <= u).min(n - 1);
                GuideBin {
                    lower: lower[t],
                    cdf: cdf[t],
                    pmf: pmf[t],
                    bin: t as u32,
                }
            })
            .collect();
        Some(Distribution1D {
            lower,
            cdf,
            pmf,
            guide,
            total,
        })
    }

    /// Number of bins.
    pub fn len(&self) -> usize {
        self.pmf.len()
    }

    /// True if there are no bins (never, for a constructed distribution).
    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }

    /// Sum of the weights it was built from.
    pub fn total(&self) -> f64 {
        self.total
    }

    /// Probability of bin `i`.
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf[i]
    }

    /// `cdf.partition_point(|c| c <= u).min(len − 1)`, started from the guide table entry: a
    /// scan of about one step in either direction (backward only if the rounding of `u · len`
    /// put `u` in the cell after its own).
    #[inline]
    fn search(&self, u: f32) -> usize {
        let n = self.cdf.len();
        let cell = ((u.max(0.0) * n as f32) as usize).min(n - 1);
        let mut t = self.guide[cell].bin as usize;
        // The loop conditions are written without short-circuits (both sides are in bounds):
        // a well-guided search takes neither loop, so the one branch of each predicts, where
        // `t > 0 &&` / `t + 1 < n &&` branched on which bin u fell in.
        while (t > 0) & (self.lower[t] > u) {
            t -= 1;
        }
        while (t + 1 < n) & (self.cdf[t] <= u) {
            t += 1;
        }
        t
    }

    /// The bin [`Distribution1D::sample`] picks for `u` (the same value), for callers that need
    /// only the bin: when the guide entry's bin holds `u` and has weight (the common case) it
    /// is the answer, read from one entry; else the full search.
    #[inline]
    pub fn sample_bin(&self, u: f32) -> usize {
        let n = self.cdf.len();
        let cell = ((u.max(0.0) * n as f32) as usize).min(n - 1);
        let GuideBin {
            lower,
            cdf,
            pmf,
            bin,
        } = self.guide[cell];
        let t = bin as usize;
        // `search` takes no step from t (neither of its loops' first tests holds), and
        // `sample` none back over a zero bin.
        if !((t > 0) & (lower > u)) & !((t + 1 < n) & (cdf <= u)) & ((pmf != 0.0) | (t == 0)) {
            t
        } else {
            self.sample(u).0
        }
    }

    /// Picks a bin for `u` in [0, 1); returns (bin, its probability, u re-scaled to [0, 1) inside the bin).
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32, f32) {
        // First bin whose cdf exceeds u; bins with zero probability are never chosen.
        let mut i = self.search(u);
        while self.pmf[i] == 0.0 && i > 0 {
            i -= 1;
        }
        let lo = self.lower[i];
        let p = self.pmf[i];
        let rem = if p > 0.0 {
            ((u - lo) / p).clamp(0.0, 1.0 - f32::EPSILON / 2.0)
        } else {
            0.5
        };
        (i, p, rem)
    }
}

/// A guide entry: the bin sampled at its u and that bin's lower edge, cdf and probability, one
/// aligned 16-byte load.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
struct GuideBin {
    lower: f32,
    cdf: f32,
    pmf: f32,
    bin: u32,
}

/// Tables up to this many bins are searched in registers by [`Distribution1D::sample_x`] (an
/// area light's triangles in most scenes).
const SMALL: usize = 16;

impl Distribution1D {
    /// [`Distribution1D::sample`] for 16 lanes at once (the packet kernels' twin): per lane
    /// (bin, its probability, u re-scaled), the same values; a lane whose search needs a step
    /// takes it in a loop that runs until no lane does.
    #[inline(always)]
    pub fn sample_x(&self, u: F16) -> ([u32; WIDTH], F16, F16) {
        if self.cdf.len() <= SMALL {
            return self.sample_small_x(u);
        }
        let n = self.cdf.len();
        let last = n - 1;
        let mut t: [usize; WIDTH] = lanes(|l| {
            let cell = ((u.0[l].max(0.0) * n as f32) as usize).min(last);
            self.guide[cell].bin as usize
        });
        let gather = |v: &[f32], t: &[usize; WIDTH]| F16(lanes(|l| v[t[l].min(last)]));
        loop {
            let lo = gather(&self.lower, &t);
            let back: [bool; WIDTH] = lanes(|l| (t[l] > 0) & (lo.0[l] > u.0[l]));
            if !back.contains(&true) {
                break;
            }
            t = lanes(|l| t[l] - back[l] as usize);
        }
        loop {
            let c = gather(&self.cdf, &t);
            let fwd: [bool; WIDTH] = lanes(|l| (t[l] < last) & (c.0[l] <= u.0[l]));
            if !fwd.contains(&true) {
                break;
            }
            t = lanes(|l| t[l] + fwd[l] as usize);
        }
        loop {
            let p = gather(&self.pmf, &t);
            let zero: [bool; WIDTH] = lanes(|l| (p.0[l] == 0.0) & (t[l] > 0));
            if !zero.contains(&true) {
                break;
            }
            t = lanes(|l| t[l] - zero[l] as usize);
        }
        let lo = gather(&self.lower, &t);
        let p = gather(&self.pmf, &t);
        (t.map(|i| i as u32), p, rescale_x(u, lo, p))
    }

    /// [`Distribution1D::sample_x`] for a table of at most [`SMALL`] bins, in registers: the
    /// search ends at the CDF's partition point (the first entry above u, at most the last),
    /// which is counted with one compare per entry for all lanes at once (a NaN u never moves
    /// from its start cell, guide[0]: the count for u = 0), and the bin's values are picked by
    /// one select per entry instead of gathers.
    #[inline(always)]
    fn sample_small_x(&self, u: F16) -> ([u32; WIDTH], F16, F16) {
        let last = self.cdf.len() - 1;
        let uu = F16(lanes(|l| if u.0[l].is_nan() { 0.0 } else { u.0[l] }));
        let mut t = [0u32; WIDTH];
        for &c in &self.cdf[..last] {
            for l in 0..WIDTH {
                t[l] += (c <= uu.0[l]) as u32;
            }
        }
        let pick = |v: &[f32], t: &[u32; WIDTH]| {
            let mut o = [0.0f32; WIDTH];
            for (j, &x) in v.iter().enumerate() {
                for l in 0..WIDTH {
                    o[l] = if t[l] == j as u32 { x } else { o[l] };
                }
            }
            F16(o)
        };
        let mut p = pick(&self.pmf, &t);
        loop {
            let zero: [bool; WIDTH] = lanes(|l| (p.0[l] == 0.0) & (t[l] > 0));
            if !zero.contains(&true) {
                break;
            }
            t = lanes(|l| t[l] - zero[l] as u32);
            p = pick(&self.pmf, &t);
        }
        let lo = pick(&self.lower, &t);
        (t, p, rescale_x(u, lo, p))
    }
}

/// u re-scaled into its bin (lower edge `lo`, probability `p`) per lane, as
/// [`Distribution1D::sample`] does.
#[inline(always)]
fn rescale_x(u: F16, lo: F16, p: F16) -> F16 {
    F16(lanes(|l| {
        if p.0[l] > 0.0 {
            ((u.0[l] - lo.0[l]) / p.0[l]).clamp(0.0, 1.0 - f32::EPSILON / 2.0)
        } else {
            0.5
        }
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frequencies_follow_weights_and_zero_bins_are_skipped() {
        let d = Distribution1D::new([1.0, 0.0, 3.0, f64::NAN, -2.0]).unwrap();
        assert_eq!(d.len(), 5);
        let mut counts = [0u32; 5];
        let n = 40_000;
        for k in 0..n {
            let u = (k as f32 + 0.5) / n as f32;
            let (i, p, r) = d.sample(u);
            assert!((0.0..1.0).contains(&r));
            assert_eq!(p, d.pmf(i));
            counts[i] += 1;
        }
        assert_eq!(counts[1] + counts[3] + counts[4], 0);
        assert!((counts[0] as f32 / n as f32 - 0.25).abs() < 1e-3);
        assert!(Distribution1D::new([0.0, 0.0]).is_none());
    }

    #[test]
    fn guided_search_is_the_binary_search() {
        let mut rng = crate::math::Pcg32::new(3, 9);
        for n in [1usize, 2, 3, 7, 50, 257] {
            let w: Vec<f64> = (0..n)
                .map(|i| {
                    if i % 5 == 3 {
                        0.0
                    } else {
                        rng.next_f32() as f64
                    }
                })
                .collect();
            let Some(d) = Distribution1D::new(w) else {
                continue;
            };
            let mut us: Vec<f32> = (0..2000).map(|_| rng.next_f32()).collect();
            us.extend([0.0, 1.0 - f32::EPSILON, 1.0, 2.0, -1.0]);
            us.extend(d.cdf.iter().copied());
            us.extend(d.cdf.iter().map(|c| c.next_down()));
            us.extend(d.lower.iter().copied());
            us.extend([f32::NAN, -0.0, f32::INFINITY]);
            for u in us {
                let want = d.cdf.partition_point(|&c| c <= u).min(n - 1);
                if !u.is_nan() {
                    assert_eq!(d.search(u), want, "n={n} u={u}");
                }
                assert_eq!(d.sample_bin(u), d.sample(u).0, "n={n} u={u}");
            }
        }
    }

    /// The 16-lane search returns the scalar one's bins, probabilities and re-scaled numbers,
    /// also at the cdf steps, with zero bins, and for out-of-range u.
    #[test]
    fn sample_x_is_sample_per_lane() {
        let mut rng = crate::math::Pcg32::new(7, 1);
        for w in [
            vec![1.0, 1.0],
            vec![1.0, 0.0, 3.0, f64::NAN, -2.0, 0.5],
            vec![5.0],
            vec![0.0, 0.0, 2.0, 1.0, 0.0],
            (0..16).map(|i| (i % 3) as f64).collect(),
            (0..100).map(|i| ((i * 37) % 11) as f64).collect(),
        ] {
            let d = Distribution1D::new(w).unwrap();
            let mut us: Vec<f32> = (0..400).map(|_| rng.next_f32()).collect();
            us.extend(d.cdf.iter().copied());
            us.extend(d.cdf.iter().map(|c| c.next_down()));
            us.extend([0.0, -0.0, -0.5, 1.0, 1.5, f32::NAN, f32::INFINITY]);
            for c in us.chunks(WIDTH) {
                let mut u = F16::splat(0.25);
                u.0[..c.len()].copy_from_slice(c);
                let (i, p, r) = d.sample_x(u);
                for l in 0..c.len() {
                    let (si, sp, sr) = d.sample(u.0[l]);
                    assert_eq!(i[l] as usize, si, "u = {}", u.0[l]);
                    assert_eq!(p.0[l].to_bits(), sp.to_bits());
                    assert_eq!(r.0[l].to_bits(), sr.to_bits(), "u = {}", u.0[l]);
                }
            }
        }
    }
}
