//! K-means with k-means++ seeding (seeded, deterministic) and Hamerly's bound-based acceleration
//! of Lloyd iterations (the same assignments as plain Lloyd, most distance scans skipped). A point
//! whose bounds fail scans only the centres nearer its own centre than twice its distance (each
//! centre's neighbours sorted by distance; the sorted-list form of Newling & Fleuret's Exponion,
//! 2016), not all K.
//!
//! Points and centres are stored padded to a multiple of [`LANES`] features with zeros, so every
//! distance is a fixed-width, lane-split loop that vectorises. Iterations stop when fewer than
//! [`STOP_FRACTION`] of the points change cluster; the result is taken right after that
//! assignment pass, so every point is still at its nearest centre.

use crate::math::Pcg32;
use crate::math::order_key::key;

/// Result of a clustering: `centers` is `k × dim`, `assign[i] < k` for every point.
#[derive(Clone, Debug)]
pub struct KMeans {
    /// Number of clusters actually produced (≤ requested: never more than distinct points).
    pub k: usize,
    pub dim: usize,
    pub centers: Vec<f32>,
    pub assign: Vec<u32>,
    /// Lloyd iterations run.
    pub iterations: usize,
}

/// Feature padding width (SIMD lanes of the distance loop).
const LANES: usize = 8;
/// Lloyd iterations stop once fewer than this fraction of the points changed cluster.
pub const STOP_FRACTION: f64 = 1e-3;

#[cfg(test)]
fn dist2(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// Squared distance of two padded vectors (length a multiple of [`LANES`]).
#[inline(always)]
fn dist2_padded(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0.0f32; LANES];
    for (ca, cb) in a.chunks_exact(LANES).zip(b.chunks_exact(LANES)) {
        for k in 0..LANES {
            let d = ca[k] - cb[k];
            acc[k] += d * d;
        }
    }
    acc.iter().sum()
}

/// For every centre `a` the other centres sorted by their distance from it (ties by index) into
/// `near[a·(k−1)..]`, with those distances in `near_d`; `cc` is k×k scratch.
fn neighbours(
    centers: &[f32],
    k: usize,
    dim: usize,
    cc: &mut [f32],
    near: &mut [u32],
    near_d: &mut [f32],
) {
    let centre = |c: usize| &centers[c * dim..(c + 1) * dim];
    for a in 0..k {
        cc[a * k + a] = 0.0;
        for b in a + 1..k {
            let d = dist2_padded(centre(a), centre(b)).sqrt();
            cc[a * k + b] = d;
            cc[b * k + a] = d;
        }
    }
    // Sorted as u64 keys (distance order key, then index): the same order as comparing
    // (distance by `f32::total_cmp`, index), with plain integer comparisons.
    let mut keys: Vec<u64> = Vec::with_capacity(k.saturating_sub(1));
    for a in 0..k {
        let dist = &cc[a * k..(a + 1) * k];
        keys.clear();
        keys.extend(
            (0..k)
                .filter(|&b| b != a)
                .map(|b| ((key(dist[b]) as u64) << 32) | b as u64),
        );
        keys.sort_unstable();
        let row = a * (k - 1)..(a + 1) * (k - 1);
        for ((n, d), &key) in near[row.clone()]
            .iter_mut()
            .zip(&mut near_d[row])
            .zip(&keys)
        {
            *n = key as u32;
            *d = dist[key as u32 as usize];
        }
    }
}

/// Clusters `data` (`n × dim`, row-major) into at most `k` clusters. Points with identical
/// features never seed two clusters, so constant data give one cluster and `k > n` is fine.
/// Empty clusters during iteration are re-seeded at the points farthest from their centres.
pub fn kmeans(data: &[f32], dim: usize, k: usize, seed: u64, max_iter: usize) -> KMeans {
    kmeans_isa(crate::math::simd::isa(), data, dim, k, seed, max_iter)
}

crate::isa_dispatch! {
    /// [`kmeans`] built for `isa` (wider distance loops; no fused multiply-adds, so the same
    /// clusters on every build).
    fn kmeans_isa(data: &[f32], dim: usize, k: usize, seed: u64, max_iter: usize) -> KMeans =
        kmeans_impl;
}

#[inline(always)]
fn kmeans_impl(data: &[f32], dim: usize, k: usize, seed: u64, max_iter: usize) -> KMeans {
    let n = data.len().checked_div(dim).unwrap_or(0);
    if n == 0 || k == 0 {
        return KMeans {
            k: 0,
            dim,
            centers: Vec::new(),
            assign: vec![0; n],
            iterations: 0,
        };
    }
    // Padded copy of the points: `pd` floats per point, zeros beyond `dim`.
    let pd = dim.div_ceil(LANES) * LANES;
    let mut padded = vec![0.0f32; n * pd];
    for (dst, src) in padded.chunks_exact_mut(pd).zip(data.chunks_exact(dim)) {
        dst[..dim].copy_from_slice(src);
    }
    let point = |i: usize| &padded[i * pd..(i + 1) * pd];
    let dim_out = dim;
    let dim = pd;
    let dist2 = dist2_padded;
    let mut rng = Pcg32::new(seed, 0x6b6d_6561_6e73);

    // k-means++ seeding.
    let mut centers: Vec<f32> = Vec::with_capacity(k * dim);
    let first = rng.next_below(n as u32) as usize;
    centers.extend_from_slice(point(first));
    let mut d2: Vec<f32> = (0..n).map(|i| dist2(point(i), point(first))).collect();
    // Distance to the second-nearest centre so far, kept along so the first Lloyd pass needs no
    // full scan (it would recompute exactly these nearest and second-nearest distances).
    let mut second = vec![f32::INFINITY; n];
    let mut assign = vec![0u32; n];
    while centers.len() / dim < k {
        let total: f64 = d2.iter().map(|&v| v as f64).sum();
        if total <= 0.0 {
            break; // every point coincides with a centre already
        }
        let target = rng.next_f32() as f64 * total;
        let mut acc = 0.0;
        let mut pick = n;
        for (i, &v) in d2.iter().enumerate() {
            acc += v as f64;
            if acc > target && v > 0.0 {
                pick = i;
                break;
            }
        }
        if pick == n {
            pick = (0..n).rev().find(|&i| d2[i] > 0.0).unwrap_or(0);
        }
        let c = centers.len() / dim;
        centers.extend_from_slice(point(pick));
        for i in 0..n {
            let d = dist2(point(i), point(pick));
            if d < d2[i] {
                second[i] = d2[i];
                d2[i] = d;
                assign[i] = c as u32;
            } else if d < second[i] {
                second[i] = d;
            }
        }
    }
    let k = centers.len() / dim;

    // Hamerly's algorithm: upper bound to own centre, lower bound to the second closest.
    // The seeding already scanned every centre in index order with the same distance function,
    // so these are exactly the bounds a full first assignment pass would give (and `assign` is
    // its result: the lowest index among the nearest centres).
    let mut upper: Vec<f32> = d2.iter().map(|v| v.sqrt()).collect();
    let mut lower: Vec<f32> = second.iter().map(|v| v.sqrt()).collect();
    drop(second);
    let mut sums = vec![0.0f64; k * dim];
    let mut counts = vec![0usize; k];
    let mut half_sep = vec![0.0f32; k];
    let mut moved = vec![0.0f32; k];
    let mut cc = vec![0.0f32; k * k];
    let mut near = vec![0u32; k * k.saturating_sub(1)];
    let mut near_d = vec![0.0f32; near.len()];
    let mut iterations = 0;
    // The first iteration only moves the centres: the seeding made its assignment and bounds.
    let mut first_pass = true;
    let mut changed;
    let mut max_moved = 1.0f32;
    let stop_below = (STOP_FRACTION * n as f64) as usize;
    // Stop when centres no longer move (the assignment is then stable and consistent).
    while iterations < max_iter && max_moved > 0.0 {
        iterations += 1;
        changed = false;
        let mut reassigned = 0usize;
        // Each centre's other centres by distance (ties by index), and half the distance to the
        // nearest of them (not needed by the first pass, whose assignment the seeding made).
        if !first_pass {
            neighbours(&centers, k, dim, &mut cc, &mut near, &mut near_d);
            for a in 0..k {
                half_sep[a] = near_d.get(a * (k - 1)).map_or(f32::INFINITY, |d| 0.5 * d);
            }
        }
        for i in 0..n * usize::from(!first_pass) {
            let a = assign[i] as usize;
            let bound = half_sep[a].max(lower[i]);
            if upper[i] <= bound {
                continue;
            }
            let p = point(i);
            let own = dist2(p, &centers[a * dim..(a + 1) * dim]);
            let u = own.sqrt();
            upper[i] = u;
            if u <= bound {
                continue;
            }
            // Only centres c with |a − c| < 2u can be nearer than a (triangle inequality:
            // |p − c| ≥ |a − c| − u ≥ u): scan a's neighbours outwards up to that radius; every
            // centre beyond it is at least (its distance from a) − u away.
            let (mut best, mut best_d, mut second_d) = (a, own, f32::INFINITY);
            let mut beyond = f32::INFINITY;
            let row = a * (k - 1)..(a + 1) * (k - 1);
            for (&c, &dc) in near[row.clone()].iter().zip(&near_d[row]) {
                if dc >= 2.0 * u {
                    beyond = dc - u;
                    break;
                }
                let c = c as usize;
                let d = dist2(p, &centers[c * dim..(c + 1) * dim]);
                if d < best_d || (d == best_d && c < best) {
                    second_d = best_d;
                    best_d = d;
                    best = c;
                } else if d < second_d {
                    second_d = d;
                }
            }
            if best != a {
                assign[i] = best as u32;
                changed = true;
                reassigned += 1;
            }
            upper[i] = best_d.sqrt();
            lower[i] = second_d.sqrt().min(beyond);
        }
        // Nearly stable: stop here, where every point is at its nearest centre (the means of the
        // members moved by less than the few reassignments; callers use the assignment).
        if !first_pass && reassigned <= stop_below {
            break;
        }
        first_pass = false;
        // Recompute centres.
        sums.iter_mut().for_each(|s| *s = 0.0);
        counts.iter_mut().for_each(|c| *c = 0);
        for i in 0..n {
            let a = assign[i] as usize;
            counts[a] += 1;
            for (s, &v) in sums[a * dim..(a + 1) * dim].iter_mut().zip(point(i)) {
                *s += v as f64;
            }
        }
        let mut reseeded: Vec<usize> = Vec::new();
        let mut old = vec![0.0f32; dim];
        for c in 0..k {
            old.copy_from_slice(&centers[c * dim..(c + 1) * dim]);
            if counts[c] > 0 {
                for j in 0..dim {
                    centers[c * dim + j] = (sums[c * dim + j] / counts[c] as f64) as f32;
                }
            } else {
                // Empty cluster: move it onto the point farthest from its own centre.
                let far = (0..n)
                    .filter(|i| !reseeded.contains(i) && upper[*i] > 0.0)
                    .max_by(|&x, &y| upper[x].total_cmp(&upper[y]).then(y.cmp(&x)));
                if let Some(far) = far {
                    reseeded.push(far);
                    centers[c * dim..(c + 1) * dim].copy_from_slice(point(far));
                    changed = true;
                }
            }
            moved[c] = dist2(&old, &centers[c * dim..(c + 1) * dim]).sqrt();
        }
        max_moved = moved.iter().copied().fold(0.0, f32::max);
        if changed {
            max_moved = max_moved.max(f32::MIN_POSITIVE);
        }
        for i in 0..n {
            upper[i] += moved[assign[i] as usize];
            lower[i] -= max_moved;
        }
    }
    // Unpad the centres.
    let centers: Vec<f32> = centers
        .chunks_exact(dim)
        .flat_map(|c| c[..dim_out].iter().copied())
        .collect();
    let dim = dim_out;
    KMeans {
        k,
        dim,
        centers,
        assign,
        iterations,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blobs(centres: &[[f32; 3]], per: usize, spread: f32, seed: u64) -> Vec<f32> {
        let mut rng = Pcg32::new(seed, 5);
        let mut v = Vec::new();
        for _ in 0..per {
            for c in centres {
                for &x in c {
                    v.push(x + spread * (rng.next_f32() - 0.5));
                }
            }
        }
        v
    }

    #[test]
    fn finds_separable_clusters() {
        let centres = [
            [0.0, 0.0, 0.0],
            [5.0, 0.0, 0.0],
            [0.0, 5.0, 0.0],
            [0.0, 0.0, 5.0],
            [5.0, 5.0, 5.0],
        ];
        let data = blobs(&centres, 60, 1.0, 1);
        let r = kmeans(&data, 3, 5, 42, 100);
        assert_eq!(r.k, 5);
        // Points generated from the same centre share a label, different centres differ.
        for (i, &a) in r.assign.iter().enumerate() {
            let same = r.assign[i % 5];
            assert_eq!(a, same, "point {i}");
        }
        let mut labels: Vec<u32> = r.assign[..5].to_vec();
        labels.sort();
        labels.dedup();
        assert_eq!(labels.len(), 5);
        for c in 0..5 {
            let centre = &r.centers[r.assign[c] as usize * 3..r.assign[c] as usize * 3 + 3];
            assert!(dist2(centre, &centres[c]) < 0.1, "{centre:?}");
        }
        // Deterministic for a seed.
        assert_eq!(kmeans(&data, 3, 5, 42, 100).assign, r.assign);
    }

    #[test]
    fn equals_plain_lloyd_result() {
        // Overlapping blobs, many clusters: every point must end at its nearest centre.
        let data = blobs(&[[0.0, 0.0, 0.0], [1.0, 1.0, 0.0]], 200, 3.0, 7);
        let r = kmeans(&data, 3, 16, 3, 500);
        assert!(r.iterations < 500);
        for i in 0..data.len() / 3 {
            let p = &data[i * 3..i * 3 + 3];
            let own = dist2(p, &r.centers[r.assign[i] as usize * 3..][..3]);
            for c in 0..r.k {
                let o = dist2(p, &r.centers[c * 3..c * 3 + 3]);
                assert!(
                    own <= o + 1e-5,
                    "point {i} own {own} other {c} {o} iters {}",
                    r.iterations
                );
            }
        }
    }

    #[test]
    fn pruned_scans_find_the_nearest_centre_in_many_dimensions() {
        // The fit's shape: 20 features, K = 256, points on few blobs plus spread, so most scans
        // stop early at the 2u radius; every point must still end at its nearest centre.
        let mut rng = Pcg32::new(11, 1);
        let dim = 20;
        let blobs: Vec<f32> = (0..12 * dim).map(|_| rng.next_f32()).collect();
        let data: Vec<f32> = (0..3000 * dim)
            .map(|i| blobs[(i / dim % 12) * dim + i % dim] + 0.2 * (rng.next_f32() - 0.5))
            .collect();
        let r = kmeans(&data, dim, 256, 5, 60);
        assert_eq!(r.k, 256);
        assert!(r.iterations < 60, "stopped by the cap, not by convergence");
        for i in 0..3000 {
            let p = &data[i * dim..(i + 1) * dim];
            let own = dist2(p, &r.centers[r.assign[i] as usize * dim..][..dim]);
            for c in 0..r.k {
                let o = dist2(p, &r.centers[c * dim..(c + 1) * dim]);
                assert!(
                    own <= o * (1.0 + 1e-5),
                    "point {i}: own {own}, centre {c} {o}"
                );
            }
        }
    }

    #[test]
    fn degenerate_inputs() {
        let constant = vec![0.5f32; 40];
        let r = kmeans(&constant, 4, 256, 1, 10);
        assert_eq!(r.k, 1);
        assert!(r.assign.iter().all(|&a| a == 0));
        let few = [0.0f32, 1.0, 2.0, 2.0];
        let r = kmeans(&few, 1, 256, 1, 10);
        assert_eq!(r.k, 3);
        assert_eq!(r.assign[2], r.assign[3]);
        let empty = kmeans(&[], 3, 8, 1, 10);
        assert_eq!(empty.k, 0);
    }
}
