//! Baseline: per-view PCA of the reflectance field (Sattler et al. 2003): every texel's vector of
//! lights × RGB values is approximated by the view's mean plus k eigen-vectors, with per-texel
//! weights. Stored as f16 (mean, k basis vectors, k weight images), so its size is
//! 2·(D + k·D + k·texels) bytes per view with D = 3 · lights.

use half::f16;

/// Sweeps of subspace iteration (the spectrum of BTF data decays fast; 40 sweeps with 4 extra
/// vectors converge the leading components far below the f16 storage precision).
const SWEEPS: usize = 40;
/// Extra vectors iterated beyond k to speed convergence of the k-th.
const OVERSAMPLE: usize = 4;

/// Bytes of a k-component PCA of one view (f16 storage).
pub fn view_bytes(dims: usize, texels: usize, k: usize) -> usize {
    2 * (dims + k * dims + k * texels)
}

/// The k whose storage is closest to `budget` bytes per view (at least 1).
pub fn k_for_budget(dims: usize, texels: usize, budget: usize) -> usize {
    let per = 2 * (dims + texels);
    (((budget.saturating_sub(2 * dims)) as f64 / per as f64).round() as usize)
        .clamp(1, dims.min(texels).max(1))
}

/// Reconstructs one view (`data` = `[light][texel][rgb]`, linear) from its k-component PCA with
/// all stored quantities rounded to f16, into `out` (same layout).
pub fn reconstruct_view(data: &[f32], texels: usize, k: usize, out: &mut Vec<f32>) {
    let dims = data.len() / texels.max(1);
    let at = |t: usize, d: usize| data[(d / 3 * texels + t) * 3 + d % 3] as f64;
    let k = k.min(dims).min(texels);
    out.clear();
    out.resize(data.len(), 0.0);
    if texels == 0 || dims == 0 {
        return;
    }
    let mut mean = vec![0.0f64; dims];
    for t in 0..texels {
        for (d, m) in mean.iter_mut().enumerate() {
            *m += at(t, d);
        }
    }
    mean.iter_mut().for_each(|m| *m /= texels as f64);
    // Covariance (upper triangle, then mirrored).
    let mut cov = vec![0.0f64; dims * dims];
    let mut z = vec![0.0f64; dims];
    for t in 0..texels {
        for d in 0..dims {
            z[d] = at(t, d) - mean[d];
        }
        for i in 0..dims {
            let zi = z[i];
            let row = &mut cov[i * dims..(i + 1) * dims];
            for j in i..dims {
                row[j] += zi * z[j];
            }
        }
    }
    for i in 0..dims {
        for j in 0..i {
            cov[i * dims + j] = cov[j * dims + i];
        }
    }
    let basis = top_eigenvectors(&cov, dims, k);
    let q = |v: f64| f16::from_f64(v).to_f64();
    let mean_q: Vec<f64> = mean.iter().map(|&m| q(m)).collect();
    let basis_q: Vec<f64> = basis.iter().map(|&b| q(b)).collect();
    let mut w = vec![0.0f64; k];
    for t in 0..texels {
        for (j, wj) in w.iter_mut().enumerate() {
            let mut s = 0.0;
            for d in 0..dims {
                s += (at(t, d) - mean[d]) * basis[j * dims + d];
            }
            *wj = q(s);
        }
        for d in 0..dims {
            let mut v = mean_q[d];
            for (j, wj) in w.iter().enumerate() {
                v += wj * basis_q[j * dims + d];
            }
            out[(d / 3 * texels + t) * 3 + d % 3] = v.max(0.0) as f32;
        }
    }
}

/// The k leading unit eigenvectors (row-major `k × n`) of a symmetric positive semi-definite
/// `n × n` matrix, by subspace iteration with a final Rayleigh–Ritz step.
pub fn top_eigenvectors(a: &[f64], n: usize, k: usize) -> Vec<f64> {
    let m = (k + OVERSAMPLE).min(n);
    // Deterministic start: a fixed pseudo-random block.
    let mut rng = crate::math::Pcg32::new(0x5ca1ab1e, 3);
    let mut v: Vec<f64> = (0..m * n).map(|_| rng.next_f32() as f64 - 0.5).collect();
    orthonormalise(&mut v, n, m);
    let mut w = vec![0.0f64; m * n];
    for _ in 0..SWEEPS {
        multiply(a, n, &v, m, &mut w);
        std::mem::swap(&mut v, &mut w);
        orthonormalise(&mut v, n, m);
    }
    // Rayleigh–Ritz: H = Vᵀ A V, eigen-decomposed by cyclic Jacobi.
    multiply(a, n, &v, m, &mut w);
    let mut h = vec![0.0f64; m * m];
    for i in 0..m {
        for j in 0..m {
            h[i * m + j] = (0..n).map(|d| v[i * n + d] * w[j * n + d]).sum();
        }
    }
    let (vals, vecs) = jacobi_eigen(&mut h, m);
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|&a, &b| vals[b].total_cmp(&vals[a]));
    let mut out = vec![0.0f64; k * n];
    for (r, &e) in order.iter().take(k).enumerate() {
        for i in 0..m {
            let c = vecs[i * m + e];
            for d in 0..n {
                out[r * n + d] += c * v[i * n + d];
            }
        }
    }
    out
}

fn multiply(a: &[f64], n: usize, v: &[f64], m: usize, out: &mut [f64]) {
    for j in 0..m {
        let vj = &v[j * n..(j + 1) * n];
        for i in 0..n {
            out[j * n + i] = a[i * n..(i + 1) * n]
                .iter()
                .zip(vj)
                .map(|(x, y)| x * y)
                .sum();
        }
    }
}

fn orthonormalise(v: &mut [f64], n: usize, m: usize) {
    for j in 0..m {
        for i in 0..j {
            let dot: f64 = (0..n).map(|d| v[i * n + d] * v[j * n + d]).sum();
            for d in 0..n {
                v[j * n + d] -= dot * v[i * n + d];
            }
        }
        let len = (0..n)
            .map(|d| v[j * n + d] * v[j * n + d])
            .sum::<f64>()
            .sqrt();
        if len > 1e-300 {
            (0..n).for_each(|d| v[j * n + d] /= len);
        } else {
            // Rank-deficient: replace by a unit axis (re-orthogonalised next sweep).
            (0..n).for_each(|d| v[j * n + d] = if d == j % n { 1.0 } else { 0.0 });
        }
    }
}

/// Eigenvalues and eigenvectors (columns of the returned `m × m`) of a small symmetric matrix.
fn jacobi_eigen(a: &mut [f64], m: usize) -> (Vec<f64>, Vec<f64>) {
    let mut vec = vec![0.0f64; m * m];
    (0..m).for_each(|i| vec[i * m + i] = 1.0);
    for _ in 0..100 {
        let off: f64 = (0..m)
            .flat_map(|i| (0..m).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i * m + j] * a[i * m + j])
            .sum();
        let diag: f64 = (0..m).map(|i| a[i * m + i] * a[i * m + i]).sum();
        if off <= 1e-30 * diag.max(1e-300) {
            break;
        }
        for p in 0..m {
            for q in p + 1..m {
                let apq = a[p * m + q];
                if apq.abs() < 1e-300 {
                    continue;
                }
                let theta = (a[q * m + q] - a[p * m + p]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for r in 0..m {
                    let (arp, arq) = (a[r * m + p], a[r * m + q]);
                    a[r * m + p] = c * arp - s * arq;
                    a[r * m + q] = s * arp + c * arq;
                }
                for r in 0..m {
                    let (apr, aqr) = (a[p * m + r], a[q * m + r]);
                    a[p * m + r] = c * apr - s * aqr;
                    a[q * m + r] = s * apr + c * aqr;
                }
                for r in 0..m {
                    let (vrp, vrq) = (vec[r * m + p], vec[r * m + q]);
                    vec[r * m + p] = c * vrp - s * vrq;
                    vec[r * m + q] = s * vrp + c * vrq;
                }
            }
        }
    }
    ((0..m).map(|i| a[i * m + i]).collect(), vec)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Pcg32;

    #[test]
    fn rank_k_data_is_reconstructed_to_f16_precision() {
        // 2 lights × 3 channels = 6 dims, texels = mean + 2 components.
        let (texels, nl) = (50, 2);
        let mut rng = Pcg32::new(8, 8);
        let b1: Vec<f32> = (0..6).map(|_| rng.next_f32()).collect();
        let b2: Vec<f32> = (0..6).map(|_| rng.next_f32()).collect();
        let mut data = vec![0.0f32; nl * texels * 3];
        for t in 0..texels {
            let (w1, w2) = (rng.next_f32(), rng.next_f32());
            for d in 0..6 {
                data[(d / 3 * texels + t) * 3 + d % 3] = 0.5 + w1 * b1[d] - 0.3 * w2 * b2[d];
            }
        }
        let mut out = Vec::new();
        reconstruct_view(&data, texels, 2, &mut out);
        let err = data
            .iter()
            .zip(&out)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f32::max);
        assert!(err < 3e-3, "{err}");
        reconstruct_view(&data, texels, 1, &mut out);
        let err1 = data
            .iter()
            .zip(&out)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f32::max);
        assert!(err1 > 10.0 * err, "{err1} vs {err}");
    }

    #[test]
    fn eigenvectors_of_a_diagonal_matrix() {
        let n = 5;
        let mut a = vec![0.0; 25];
        for (i, v) in [1.0, 5.0, 3.0, 0.5, 4.0].iter().enumerate() {
            a[i * n + i] = *v;
        }
        let e = top_eigenvectors(&a, n, 2);
        assert!((e[1].abs() - 1.0).abs() < 1e-9);
        assert!((e[n + 4].abs() - 1.0).abs() < 1e-9);
        assert_eq!(k_for_budget(6, 50, 2 * (6 + 2 * 56)), 2);
    }
}
