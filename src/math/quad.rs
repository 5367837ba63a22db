//! Gauss–Legendre quadrature on [−1, 1] (Mitsuba 3 `quad::gauss_legendre`: Newton iteration on
//! the Legendre polynomial from Chebyshev guesses, in f64).

/// (P_n(x), P_n'(x)) by the three-term recurrence.
fn legendre_pd(n: usize, x: f64) -> (f64, f64) {
    match n {
        0 => (1.0, 0.0),
        1 => (x, 1.0),
        _ => {
            let (mut l_nm2, mut l_nm1) = (1.0, x);
            let (mut d_nm2, mut d_nm1) = (0.0, 1.0);
            let (mut l_n, mut d_n) = (0.0, 0.0);
            for i in 2..=n {
                let k = i as f64;
                l_n = ((2.0 * k - 1.0) * x * l_nm1 - (k - 1.0) * l_nm2) / k;
                d_n = d_nm2 + (2.0 * k - 1.0) * l_nm1;
                l_nm2 = l_nm1;
                l_nm1 = l_n;
                d_nm2 = d_nm1;
                d_nm1 = d_n;
            }
            (l_n, d_n)
        }
    }
}

/// Nodes (ascending) and weights of the `n`-point rule (n ≥ 1): exact for polynomials of degree
/// up to 2n − 1; the weights sum to 2.
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let n = n.max(1);
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    if n == 1 {
        weights[0] = 2.0;
        return (nodes, weights);
    }
    let last = n - 1;
    for i in 0..n / 2 {
        let mut x = -((2 * i + 1) as f64 / (2 * n) as f64 * std::f64::consts::PI).cos();
        for _ in 0..50 {
            let (l, d) = legendre_pd(n, x);
            let step = l / d;
            x -= step;
            if step.abs() <= 4.0 * x.abs() * f64::EPSILON {
                break;
            }
        }
        let (_, d) = legendre_pd(n, x);
        let w = 2.0 / ((1.0 - x * x) * d * d);
        weights[i] = w;
        weights[last - i] = w;
        nodes[i] = x;
        nodes[last - i] = -x;
    }
    if n % 2 == 1 {
        let (_, d) = legendre_pd(n, 0.0);
        weights[n / 2] = 2.0 / (d * d);
        nodes[n / 2] = 0.0;
    }
    (nodes, weights)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrates_polynomials_exactly() {
        for n in [1usize, 2, 5, 32, 128] {
            let (x, w) = gauss_legendre(n);
            let sum: f64 = w.iter().sum();
            assert!((sum - 2.0).abs() < 1e-12, "n {n}: weights sum {sum}");
            assert!(
                x.windows(2).all(|p| p[0] < p[1]),
                "n {n}: nodes not ascending"
            );
            // ∫ x^(2n−2) over [−1, 1] = 2 / (2n − 1).
            let k = 2 * n as i32 - 2;
            let q: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(k)).sum();
            assert!((q - 2.0 / (k + 1) as f64).abs() < 1e-10, "n {n}: {q}");
        }
        // The classic 2-point rule.
        let (x, w) = gauss_legendre(2);
        assert!((x[1] - (1.0f64 / 3.0).sqrt()).abs() < 1e-15 && (w[0] - 1.0).abs() < 1e-15);
    }
}
