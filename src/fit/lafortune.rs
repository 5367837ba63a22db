//! One-lobe Lafortune model Y = ρ·max(0, D·u)^n fitted per (view, texel, channel) over the light
//! directions u by a specialised, allocation-free 5-parameter Levenberg–Marquardt solver.
//!
//! Parameters are stored as `[ρ, Dx, Dy, Dz, n]`. ρ and |D| are redundant (ρ·(sD·u)^n =
//! ρsⁿ·(D·u)^n); the solver keeps |D| = 1 after every accepted step so results are canonical
//! (which also makes averaging parameters of several texels meaningful).

use crate::math::Vec3;

/// Lower bound of the exponent n (below it b^n has an unbounded derivative at b → 0).
pub const N_MIN: f64 = 0.1;
/// Upper bound of the exponent n (sharper lobes than this are not resolved by 81 lights).
pub const N_MAX: f64 = 200.0;
/// Maximum number of Levenberg–Marquardt iterations (accepted or rejected steps).
const MAX_ITER: usize = 40;

/// Lafortune parameters `[ρ, Dx, Dy, Dz, n]`.
pub type Lobe = [f32; 5];

/// A lobe with zero albedo (the fit of an all-zero signal).
pub const ZERO_LOBE: Lobe = [0.0, 0.0, 0.0, 1.0, 1.0];

/// Evaluates one lobe for the light direction `u` (base clamped at 0).
#[inline]
pub fn eval(p: &Lobe, u: Vec3) -> f32 {
    let b = p[1] * u.x + p[2] * u.y + p[3] * u.z;
    if b <= 0.0 { 0.0 } else { p[0] * b.powf(p[4]) }
}

/// Evaluates one lobe at the light directions of a [`LobeFitter`] (`out.len()` = lights).
pub fn eval_all(p: &Lobe, fitter: &LobeFitter, out: &mut [f32]) {
    for (i, o) in out.iter_mut().enumerate() {
        let b =
            p[1] * fitter.ux[i] as f32 + p[2] * fitter.uy[i] as f32 + p[3] * fitter.uz[i] as f32;
        *o = if b <= 0.0 { 0.0 } else { p[0] * b.powf(p[4]) };
    }
}

/// The light directions in SoA form plus the precomputed pseudo-inverse used for initialisation.
#[derive(Clone, Debug)]
pub struct LobeFitter {
    ux: Vec<f64>,
    uy: Vec<f64>,
    uz: Vec<f64>,
    /// (UᵀU)⁻¹Uᵀ, 3 rows × lights: maps a light curve Y to the LSQ g of Y ≈ g·u.
    pinv: [Vec<f64>; 3],
}

/// Result of one fit: parameters and the sum of squared residuals over the lights.
#[derive(Clone, Copy, Debug)]
pub struct LobeFit {
    pub lobe: Lobe,
    pub sse: f64,
}

/// Residual sum of squares, JᵀJ (upper triangle packed row-wise) and Jᵀr at one parameter vector.
struct Normal {
    sse: f64,
    jtj: [[f64; 5]; 5],
    jtr: [f64; 5],
}

impl LobeFitter {
    /// Prepares a fitter for the given light directions (at least 3, not coplanar with 0).
    pub fn new(lights: &[Vec3]) -> crate::Result<Self> {
        let ux: Vec<f64> = lights.iter().map(|u| u.x as f64).collect();
        let uy: Vec<f64> = lights.iter().map(|u| u.y as f64).collect();
        let uz: Vec<f64> = lights.iter().map(|u| u.z as f64).collect();
        // UᵀU (3×3) and its inverse.
        let mut m = [[0.0f64; 3]; 3];
        for i in 0..lights.len() {
            let u = [ux[i], uy[i], uz[i]];
            for r in 0..3 {
                for c in 0..3 {
                    m[r][c] += u[r] * u[c];
                }
            }
        }
        let inv = invert3(&m).ok_or_else(|| {
            crate::Error::Invalid(format!(
                "the {} light directions do not span 3-D space; a Lafortune lobe cannot be fitted",
                lights.len()
            ))
        })?;
        let mut pinv = [
            vec![0.0; lights.len()],
            vec![0.0; lights.len()],
            vec![0.0; lights.len()],
        ];
        for i in 0..lights.len() {
            let u = [ux[i], uy[i], uz[i]];
            for (r, row) in pinv.iter_mut().enumerate() {
                row[i] = inv[r][0] * u[0] + inv[r][1] * u[1] + inv[r][2] * u[2];
            }
        }
        Ok(LobeFitter { ux, uy, uz, pinv })
    }

    /// Number of light directions.
    pub fn lights(&self) -> usize {
        self.ux.len()
    }

    /// The linear least-squares start: n = 1, ρD = g with g the LSQ solution of Y ≈ g·u.
    pub fn initial(&self, y: &[f32]) -> [f64; 5] {
        let mut g = [0.0f64; 3];
        for (r, gr) in g.iter_mut().enumerate() {
            *gr = self.pinv[r].iter().zip(y).map(|(a, &b)| a * b as f64).sum();
        }
        let len = (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt();
        if len > 1e-30 && g[2] > -0.5 * len {
            [len, g[0] / len, g[1] / len, g[2] / len, 1.0]
        } else {
            // Degenerate or pointing into the surface: fall back to the mean value as a flat lobe.
            let mean = y.iter().map(|&v| v as f64).sum::<f64>() / y.len().max(1) as f64;
            [mean.max(0.0), 0.0, 0.0, 1.0, N_MIN]
        }
    }

    /// Sum of squared residuals of `p` against `y`.
    pub fn sse(&self, p: &Lobe, y: &[f32]) -> f64 {
        let mut s = 0.0;
        for (i, &yi) in y.iter().enumerate() {
            let b = p[1] as f64 * self.ux[i] + p[2] as f64 * self.uy[i] + p[3] as f64 * self.uz[i];
            let f = if b > 0.0 {
                p[0] as f64 * b.powf(p[4] as f64)
            } else {
                0.0
            };
            s += (yi as f64 - f) * (yi as f64 - f);
        }
        s
    }

    fn normal(&self, p: &[f64; 5], y: &[f32]) -> Normal {
        let mut nm = Normal {
            sse: 0.0,
            jtj: [[0.0; 5]; 5],
            jtr: [0.0; 5],
        };
        let (rho, n) = (p[0], p[4]);
        for (i, &yi) in y.iter().enumerate() {
            let (ux, uy, uz) = (self.ux[i], self.uy[i], self.uz[i]);
            let b = p[1] * ux + p[2] * uy + p[3] * uz;
            let r;
            if b > 1e-300 {
                let lb = b.ln();
                let bn = (n * lb).exp();
                let f = rho * bn;
                r = yi as f64 - f;
                // ∂f/∂ρ, ∂f/∂D, ∂f/∂n
                let dd = rho * n * bn / b;
                let j = [bn, dd * ux, dd * uy, dd * uz, f * lb];
                for a in 0..5 {
                    nm.jtr[a] += j[a] * r;
                    for c in a..5 {
                        nm.jtj[a][c] += j[a] * j[c];
                    }
                }
            } else {
                r = yi as f64;
            }
            nm.sse += r * r;
        }
        nm
    }

    /// Fits one lobe to the light curve `y` (`y.len()` = lights) by Levenberg–Marquardt from the
    /// linear least-squares start. Never fails: degenerate data give a flat or zero lobe.
    pub fn fit(&self, y: &[f32]) -> LobeFit {
        debug_assert_eq!(y.len(), self.lights());
        let mut p = self.initial(y);
        self.refine(&mut p, y)
    }

    /// Fits from a caller-chosen start (used to compare initialisations).
    pub fn fit_from(&self, start: Lobe, y: &[f32]) -> LobeFit {
        let mut p = start.map(|v| v as f64);
        p[4] = p[4].clamp(N_MIN, N_MAX);
        self.refine(&mut p, y)
    }

    fn refine(&self, p: &mut [f64; 5], y: &[f32]) -> LobeFit {
        let mut cur = self.normal(p, y);
        let scale = y.iter().map(|&v| (v as f64) * (v as f64)).sum::<f64>();
        if scale == 0.0 {
            return LobeFit {
                lobe: ZERO_LOBE,
                sse: 0.0,
            };
        }
        let mut lambda = 1e-3;
        for _ in 0..MAX_ITER {
            let mut a = cur.jtj;
            for k in 0..5 {
                let d = cur.jtj[k][k].max(1e-12 * scale);
                a[k][k] = cur.jtj[k][k] + lambda * d;
            }
            let Some(delta) = solve_spd5(&a, &cur.jtr) else {
                lambda *= 10.0;
                if lambda > 1e12 {
                    break;
                }
                continue;
            };
            let mut q = [
                (p[0] + delta[0]).max(0.0),
                p[1] + delta[1],
                p[2] + delta[2],
                p[3] + delta[3],
                (p[4] + delta[4]).clamp(N_MIN, N_MAX),
            ];
            normalise(&mut q);
            let next = self.normal(&q, y);
            if next.sse < cur.sse {
                let gain = (cur.sse - next.sse) / cur.sse.max(1e-300);
                *p = q;
                cur = next;
                lambda = (lambda * 0.2).max(1e-9);
                if gain < 1e-6 || cur.sse <= 1e-14 * scale {
                    break;
                }
            } else {
                lambda *= 8.0;
                if lambda > 1e12 {
                    break;
                }
            }
        }
        LobeFit {
            lobe: p.map(|v| v as f32),
            sse: cur.sse,
        }
    }
}

/// Rescales D to unit length, folding the scale into ρ (the model value is unchanged).
#[inline]
fn normalise(p: &mut [f64; 5]) {
    let len = (p[1] * p[1] + p[2] * p[2] + p[3] * p[3]).sqrt();
    if len > 1e-30 {
        p[0] *= len.powf(p[4]);
        p[1] /= len;
        p[2] /= len;
        p[3] /= len;
    } else {
        p[0] = 0.0;
        p[1] = 0.0;
        p[2] = 0.0;
        p[3] = 1.0;
    }
}

/// Solves A x = b for a symmetric positive definite 5×5 A given by its upper triangle (LDLᵀ).
#[inline]
fn solve_spd5(a: &[[f64; 5]; 5], b: &[f64; 5]) -> Option<[f64; 5]> {
    let mut l = [[0.0f64; 5]; 5];
    let mut d = [0.0f64; 5];
    for j in 0..5 {
        let mut dj = a[j][j];
        for k in 0..j {
            dj -= l[j][k] * l[j][k] * d[k];
        }
        if dj <= 1e-300 || !dj.is_finite() {
            return None;
        }
        d[j] = dj;
        for i in j + 1..5 {
            let mut v = a[j][i];
            for k in 0..j {
                v -= l[i][k] * l[j][k] * d[k];
            }
            l[i][j] = v / dj;
        }
    }
    let mut x = *b;
    for i in 0..5 {
        for k in 0..i {
            x[i] -= l[i][k] * x[k];
        }
    }
    for i in 0..5 {
        x[i] /= d[i];
    }
    for i in (0..5).rev() {
        for k in i + 1..5 {
            x[i] -= l[k][i] * x[k];
        }
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

fn invert3(m: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    let tr = m[0][0] + m[1][1] + m[2][2];
    if det.abs() <= 1e-12 * tr * tr * tr || !det.is_finite() {
        return None;
    }
    let c = |r: usize, s: usize| {
        let (r0, r1) = ((r + 1) % 3, (r + 2) % 3);
        let (s0, s1) = ((s + 1) % 3, (s + 2) % 3);
        m[r0][s0] * m[r1][s1] - m[r0][s1] * m[r1][s0]
    };
    let mut inv = [[0.0; 3]; 3];
    for (r, row) in inv.iter_mut().enumerate() {
        for (s, v) in row.iter_mut().enumerate() {
            *v = c(s, r) / det;
        }
    }
    Some(inv)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::btf::DirectionSet;
    use crate::math::Pcg32;

    fn curve(p: &Lobe, f: &LobeFitter) -> Vec<f32> {
        let mut y = vec![0.0; f.lights()];
        eval_all(p, f, &mut y);
        y
    }

    #[test]
    fn recovers_known_parameters_from_noiseless_lobes() {
        let dirs = DirectionSet::ubo2003();
        let f = LobeFitter::new(&dirs.dirs).unwrap();
        let mut rng = Pcg32::new(3, 1);
        for _ in 0..200 {
            let th = rng.next_f32() * 0.9;
            let ph = rng.next_f32() * std::f32::consts::TAU;
            let d = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
            let truth: Lobe = [
                0.1 + rng.next_f32() * 2.0,
                d[0],
                d[1],
                d[2],
                0.5 + rng.next_f32() * 30.0,
            ];
            let y = curve(&truth, &f);
            let fit = f.fit(&y);
            let rel = (fit.sse / y.iter().map(|v| (v * v) as f64).sum::<f64>()).sqrt();
            assert!(rel < 1e-4, "truth {truth:?} fit {:?} rel {rel}", fit.lobe);
            for k in 0..5 {
                let tol = if k == 4 {
                    2e-3 * truth[4]
                } else {
                    2e-3 * truth[0].max(1.0)
                };
                assert!(
                    (fit.lobe[k] - truth[k]).abs() < tol,
                    "param {k}: truth {truth:?} fit {:?}",
                    fit.lobe
                );
            }
        }
    }

    #[test]
    fn lsq_start_beats_normal_start_at_grazing_lobes() {
        let dirs = DirectionSet::ubo2003();
        let f = LobeFitter::new(&dirs.dirs).unwrap();
        let th = 70f32.to_radians();
        let truth: Lobe = [1.0, th.sin(), 0.0, th.cos(), 12.0];
        let y = curve(&truth, &f);
        let lsq = f.fit(&y);
        let naive = f.fit_from([1.0, 0.0, 0.0, 1.0, 1.0], &y);
        assert!(lsq.sse <= naive.sse + 1e-12, "{} vs {}", lsq.sse, naive.sse);
        assert!(lsq.sse < 1e-8);
    }

    #[test]
    fn degenerate_curves_do_not_fail() {
        let dirs = DirectionSet::ubo2003();
        let f = LobeFitter::new(&dirs.dirs).unwrap();
        let zero = f.fit(&[0.0; 81]);
        assert_eq!(zero.lobe, ZERO_LOBE);
        let flat = f.fit(&[0.3; 81]);
        assert!(flat.lobe.iter().all(|v| v.is_finite()));
        assert!(flat.sse < 81.0 * 0.3 * 0.3);
        let neg = f.fit(&[-1.0; 81]);
        assert!(neg.lobe.iter().all(|v| v.is_finite()) && neg.lobe[0] >= 0.0);
    }

    #[test]
    fn coplanar_lights_are_rejected() {
        let d = vec![Vec3::X, Vec3::Y, (Vec3::X + Vec3::Y).normalize()];
        assert!(LobeFitter::new(&d).is_err());
    }
}
