//! Minimum-error boundary cuts (Efros & Freeman, exact dynamic programming) and the adaptive
//! blend radii along them.

/// Minimum-error path through an error map `err[i · band + j]` (i along the path, j across the
/// band): one j per i with |j(i+1) − j(i)| ≤ 1; `cyclic` also requires |j(len−1) − j(0)| ≤ 1 so
/// the path closes on itself (a wrapping seam). Returns the path and its summed error. Exact DP.
pub fn min_error_cut(err: &[f32], len: usize, band: usize, cyclic: bool) -> (Vec<usize>, f64) {
    assert!(band > 0 && len > 0 && err.len() == len * band);
    let mut cost = vec![f64::INFINITY; len * band];
    let mut from = vec![0u32; len * band];
    let solve = |start: Option<usize>, cost: &mut [f64], from: &mut [u32]| -> (usize, f64) {
        for j in 0..band {
            cost[j] = if start.is_none_or(|s| s == j) {
                err[j] as f64
            } else {
                f64::INFINITY
            };
        }
        for i in 1..len {
            for j in 0..band {
                let (mut best, mut arg) = (cost[(i - 1) * band + j], j);
                for k in [j.wrapping_sub(1), j + 1] {
                    if k < band && cost[(i - 1) * band + k] < best {
                        best = cost[(i - 1) * band + k];
                        arg = k;
                    }
                }
                cost[i * band + j] = best + err[i * band + j] as f64;
                from[i * band + j] = arg as u32;
            }
        }
        let mut end = (0, f64::INFINITY);
        for j in 0..band {
            let ok = start.is_none_or(|s| j.abs_diff(s) <= 1);
            let c = cost[(len - 1) * band + j];
            if ok && c < end.1 {
                end = (j, c);
            }
        }
        end
    };
    let backtrack = |end: usize, from: &[u32]| {
        let mut path = vec![0usize; len];
        path[len - 1] = end;
        for i in (1..len).rev() {
            path[i - 1] = from[i * band + path[i]] as usize;
        }
        path
    };
    if !cyclic || len < 3 {
        let (end, c) = solve(None, &mut cost, &mut from);
        return (backtrack(end, &from), c);
    }
    let mut best: Option<(Vec<usize>, f64)> = None;
    for s in 0..band {
        let (end, c) = solve(Some(s), &mut cost, &mut from);
        if c.is_finite() && best.as_ref().is_none_or(|b| c < b.1) {
            best = Some((backtrack(end, &from), c));
        }
    }
    best.unwrap_or_else(|| (vec![0; len], f64::INFINITY))
}

/// Weight of the "second" source at `pos` for a cut whose first second-side cell is `c`, blended
/// over `[c − r, c + r)`; r = 0 is a hard cut.
#[inline]
pub(super) fn ramp(pos: isize, c: usize, r: usize) -> f32 {
    let (c, r) = (c as isize, r as isize);
    ((pos - (c - r) + 1) as f32 / (2 * r + 1) as f32).clamp(0.0, 1.0)
}

/// Adaptive blend half-widths along a path: proportional to the local RMS cut error relative to
/// the band's mean, up to half the band, smoothed over 3 cells and kept inside the band.
pub(super) fn blend_radii(err: &[f32], band: usize, path: &[usize]) -> Vec<usize> {
    let mean = err.iter().map(|&e| e as f64).sum::<f64>() / err.len().max(1) as f64;
    let rmax = (band / 2) as f64;
    let raw: Vec<f64> = path
        .iter()
        .enumerate()
        .map(|(i, &c)| {
            if mean > 0.0 {
                rmax * (2.0 * (err[i * band + c] as f64 / mean).sqrt()).min(1.0)
            } else {
                0.0
            }
        })
        .collect();
    (0..path.len())
        .map(|i| {
            let lo = i.saturating_sub(1);
            let hi = (i + 2).min(path.len());
            let r = (raw[lo..hi].iter().sum::<f64>() / (hi - lo) as f64).round() as usize;
            r.min(path[i]).min(band - path[i])
        })
        .collect()
}
