//! K-means with k-means++ seeding (seeded, deterministic) and Hamerly's bound-based acceleration
//! of Lloyd iterations (exactly the same result as plain Lloyd, most distance scans skipped).

use crate::math::Pcg32;

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

#[inline]
fn dist2(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// Clusters `data` (`n × dim`, row-major) into at most `k` clusters. Points with identical
/// features never seed two clusters, so constant data give one cluster and `k > n` is fine.
/// Empty clusters during iteration are re-seeded at the points farthest from their centres.
pub fn kmeans(data: &[f32], dim: usize, k: usize, seed: u64, max_iter: usize) -> KMeans {
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
    let point = |i: usize| &data[i * dim..(i + 1) * dim];
    let mut rng = Pcg32::new(seed, 0x6b6d_6561_6e73);

    // k-means++ seeding.
    let mut centers: Vec<f32> = Vec::with_capacity(k * dim);
    let first = rng.next_below(n as u32) as usize;
    centers.extend_from_slice(point(first));
    let mut d2: Vec<f32> = (0..n).map(|i| dist2(point(i), point(first))).collect();
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
                d2[i] = d;
                assign[i] = c as u32;
            }
        }
    }
    let k = centers.len() / dim;

    // Hamerly's algorithm: upper bound to own centre, lower bound to the second closest.
    let mut upper: Vec<f32> = d2.iter().map(|v| v.sqrt()).collect();
    let mut lower = vec![0.0f32; n];
    let mut sums = vec![0.0f64; k * dim];
    let mut counts = vec![0usize; k];
    let mut half_sep = vec![0.0f32; k];
    let mut moved = vec![0.0f32; k];
    let mut iterations = 0;
    // Initial second-closest bounds need one full scan.
    let mut first_pass = true;
    let mut changed;
    let mut max_moved = 1.0f32;
    // Stop when centres no longer move (the assignment is then stable and consistent).
    while iterations < max_iter && max_moved > 0.0 {
        iterations += 1;
        changed = false;
        // Half the distance from each centre to its nearest other centre.
        for a in 0..k {
            let mut m = f32::INFINITY;
            for b in 0..k {
                if a != b {
                    m = m.min(dist2(
                        &centers[a * dim..(a + 1) * dim],
                        &centers[b * dim..(b + 1) * dim],
                    ));
                }
            }
            half_sep[a] = 0.5 * m.sqrt();
        }
        for i in 0..n {
            let a = assign[i] as usize;
            let bound = half_sep[a].max(lower[i]);
            if !first_pass && upper[i] <= bound {
                continue;
            }
            let p = point(i);
            upper[i] = dist2(p, &centers[a * dim..(a + 1) * dim]).sqrt();
            if !first_pass && upper[i] <= bound {
                continue;
            }
            let (mut best, mut best_d, mut second_d) = (a, f32::INFINITY, f32::INFINITY);
            for c in 0..k {
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
            }
            upper[i] = best_d.sqrt();
            lower[i] = second_d.sqrt();
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
        for c in 0..k {
            let old: Vec<f32> = centers[c * dim..(c + 1) * dim].to_vec();
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
