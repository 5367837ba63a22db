//! One-lobe Lafortune model Y = ρ·max(0, D·u)^n fitted per (view, texel, channel) over the light
//! directions u by a specialised, allocation-free 5-parameter Levenberg–Marquardt solver.
//!
//! Parameters are stored as `[ρ, Dx, Dy, Dz, n]`. ρ and |D| are redundant (ρ·(sD·u)^n =
//! ρsⁿ·(D·u)^n); the solver keeps |D| = 1 after every accepted step so results are canonical
//! (which also makes averaging parameters of several texels meaningful).

use crate::math::Vec3;
use crate::math::simd::{Isa, approx, isa};
use crate::model::lobe::{Lobe, ZERO_LOBE};

/// Lower bound of the exponent n (below it b^n has an unbounded derivative at b → 0).
pub const N_MIN: f64 = 0.1;
/// Upper bound of the exponent n (sharper lobes than this are not resolved by 81 lights).
pub const N_MAX: f64 = 200.0;
/// Maximum number of Levenberg–Marquardt iterations (accepted or rejected steps).
const MAX_ITER: usize = 40;

/// Evaluates one lobe at the light directions of a [`LobeFitter`] (`out.len()` = lights).
pub fn eval_all(p: &Lobe, fitter: &LobeFitter, out: &mut [f32]) {
    for (i, o) in out.iter_mut().enumerate() {
        let b = p[1] * fitter.ux[i] + p[2] * fitter.uy[i] + p[3] * fitter.uz[i];
        *o = if b <= 0.0 { 0.0 } else { p[0] * b.powf(p[4]) };
    }
}

/// Lights processed per block of the Levenberg–Marquardt kernel (stack buffers of this size).
const BLOCK: usize = 128;
/// SIMD lanes the kernel's reductions are split into (independent accumulators vectorise).
const LANES: usize = 8;

/// The light directions in SoA form (f32, padded with zero directions to a whole number of
/// blocks; a zero direction has base 0 and contributes nothing) plus the pseudo-inverse used for
/// initialisation.
#[derive(Clone, Debug)]
pub struct LobeFitter {
    ux: Vec<f32>,
    uy: Vec<f32>,
    uz: Vec<f32>,
    /// Number of real lights (the padded arrays are longer).
    lights: usize,
    /// (UᵀU)⁻¹Uᵀ, 3 rows × lights: maps a light curve Y to the LSQ g of Y ≈ g·u.
    pinv: [Vec<f64>; 3],
    /// The instruction set the kernel runs in (the elementwise pass 16 lanes wide on AVX-512,
    /// 8 on AVX2; the same bits either way).
    isa: Isa,
}

/// Result of one fit: parameters and the sum of squared residuals over the lights.
#[derive(Clone, Copy, Debug)]
pub struct LobeFit {
    pub lobe: Lobe,
    pub sse: f64,
    /// Model evaluations (SSE + Jacobian at one parameter vector) the fit used.
    pub evaluations: u32,
}

/// Residual sum of squares, JᵀJ (upper triangle) and Jᵀr at one parameter vector.
struct Normal {
    sse: f64,
    jtj: [[f64; 5]; 5],
    jtr: [f64; 5],
}

impl LobeFitter {
    /// Prepares a fitter for the given light directions (at least 3, not coplanar with 0).
    pub fn new(lights: &[Vec3]) -> crate::Result<Self> {
        let n = lights.len();
        let padded = n.div_ceil(BLOCK).max(1) * BLOCK;
        let mut ux = vec![0.0f32; padded];
        let mut uy = vec![0.0f32; padded];
        let mut uz = vec![0.0f32; padded];
        // UᵀU (3×3) and its inverse.
        let mut m = [[0.0f64; 3]; 3];
        for (i, l) in lights.iter().enumerate() {
            (ux[i], uy[i], uz[i]) = (l.x, l.y, l.z);
            let u = [l.x as f64, l.y as f64, l.z as f64];
            for r in 0..3 {
                for c in 0..3 {
                    m[r][c] += u[r] * u[c];
                }
            }
        }
        let inv = invert3(&m).ok_or_else(|| {
            crate::Error::Invalid(format!(
                "the {n} light directions do not span 3-D space; a Lafortune lobe cannot be fitted"
            ))
        })?;
        let mut pinv = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        for (i, l) in lights.iter().enumerate() {
            let u = [l.x as f64, l.y as f64, l.z as f64];
            for (r, row) in pinv.iter_mut().enumerate() {
                row[i] = inv[r][0] * u[0] + inv[r][1] * u[1] + inv[r][2] * u[2];
            }
        }
        Ok(LobeFitter {
            ux,
            uy,
            uz,
            lights: n,
            pinv,
            isa: isa(),
        })
    }

    /// Number of light directions.
    pub fn lights(&self) -> usize {
        self.lights
    }

    /// Light direction `i` (f32 components as the kernel uses them).
    #[inline]
    fn dir(&self, i: usize) -> [f32; 3] {
        [self.ux[i], self.uy[i], self.uz[i]]
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

    /// Sum of squared residuals of `p` against `y` (exact `powf`, f64 sums).
    pub fn sse(&self, p: &Lobe, y: &[f32]) -> f64 {
        let mut s = 0.0;
        for (i, &yi) in y.iter().enumerate() {
            let [x, yy, z] = self.dir(i);
            let b = p[1] as f64 * x as f64 + p[2] as f64 * yy as f64 + p[3] as f64 * z as f64;
            let f = if b > 0.0 {
                p[0] as f64 * b.powf(p[4] as f64)
            } else {
                0.0
            };
            s += (yi as f64 - f) * (yi as f64 - f);
        }
        s
    }

    /// SSE, JᵀJ and Jᵀr at `p`, in the build for this fitter's instruction set.
    #[inline]
    fn normal(&self, p: &[f64; 5], y: &[f32]) -> Normal {
        normal_isa(self.isa, self, p, y)
    }

    /// The kernel: per block of lights, an elementwise pass (fast ln/exp) into stack buffers,
    /// then 21 lane-split dot products; f32 inside a block, f64 across blocks. Only the lights
    /// rounded up to whole [`LANES`] are processed (padding directions contribute exact zeros).
    #[inline(always)]
    fn normal_kernel(&self, p: &[f64; 5], y: &[f32]) -> Normal {
        let mut nm = Normal {
            sse: 0.0,
            jtj: [[0.0; 5]; 5],
            jtr: [0.0; 5],
        };
        let (rho, dx, dy, dz, n) = (
            p[0] as f32,
            p[1] as f32,
            p[2] as f32,
            p[3] as f32,
            p[4] as f32,
        );
        let mut j = [[0.0f32; BLOCK]; 5];
        let mut r = [0.0f32; BLOCK];
        let mut yb = [0.0f32; BLOCK];
        for start in (0..self.lights).step_by(BLOCK) {
            let len = (self.lights - start).min(BLOCK);
            let m = len.div_ceil(LANES) * LANES;
            yb[..len].copy_from_slice(&y[start..start + len]);
            yb[len..m].iter_mut().for_each(|v| *v = 0.0);
            let (ux, uy, uz) = (
                &self.ux[start..start + m],
                &self.uy[start..start + m],
                &self.uz[start..start + m],
            );
            for i in 0..m {
                let b = dx * ux[i] + dy * uy[i] + dz * uz[i];
                let valid = b > 1e-30;
                let bs = if valid { b } else { 1.0 };
                let lb = approx::ln(bs);
                let bn = if valid { approx::exp(n * lb) } else { 0.0 };
                let f = rho * bn;
                let dd = rho * n * bn / bs;
                j[0][i] = bn;
                j[1][i] = dd * ux[i];
                j[2][i] = dd * uy[i];
                j[3][i] = dd * uz[i];
                j[4][i] = f * lb;
                r[i] = yb[i] - f;
            }
            let dot = |a: &[f32; BLOCK], b: &[f32; BLOCK]| -> f64 {
                let mut acc = [0.0f32; LANES];
                for (ca, cb) in a[..m].chunks_exact(LANES).zip(b[..m].chunks_exact(LANES)) {
                    for k in 0..LANES {
                        acc[k] += ca[k] * cb[k];
                    }
                }
                acc.iter().map(|&v| v as f64).sum()
            };
            for a in 0..5 {
                nm.jtr[a] += dot(&j[a], &r);
                for c in a..5 {
                    nm.jtj[a][c] += dot(&j[a], &j[c]);
                }
            }
            nm.sse += dot(&r, &r);
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
        let scale = y.iter().map(|&v| (v as f64) * (v as f64)).sum::<f64>();
        if scale == 0.0 {
            return LobeFit {
                lobe: ZERO_LOBE,
                sse: 0.0,
                evaluations: 0,
            };
        }
        let mut cur = self.normal(p, y);
        let mut evaluations = 1;
        let mut lambda = 1e-3;
        for _ in 0..MAX_ITER {
            let mut a = cur.jtj;
            for k in 0..5 {
                let d = cur.jtj[k][k].max(1e-12 * scale);
                a[k][k] = cur.jtj[k][k] + lambda * d;
            }
            let Some(delta) = solve_spd5(&a, &cur.jtr) else {
                lambda *= 10.0;
                if lambda > LAMBDA_MAX {
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
            evaluations += 1;
            if next.sse < cur.sse {
                let gain = cur.sse - next.sse;
                *p = q;
                cur = next;
                lambda = (lambda * 0.2).max(1e-9);
                // Converged when a step improves the SSE by less than REL_TOL of itself (f32
                // residuals carry ~1e-7 relative noise) or the fit is exact.
                if gain < REL_TOL * cur.sse || cur.sse <= 1e-12 * scale {
                    break;
                }
            } else {
                lambda *= 8.0;
                if lambda > LAMBDA_MAX {
                    break;
                }
            }
        }
        LobeFit {
            lobe: p.map(|v| v as f32),
            sse: cur.sse,
            evaluations,
        }
    }
}

crate::isa_dispatch! {
    /// [`LobeFitter::normal_kernel`] built for an instruction set (the elementwise pass 16 lanes
    /// wide on AVX-512, 8 on AVX2; the dot products keep their 8-lane split: the same bits).
    fn normal_isa(f: &LobeFitter, p: &[f64; 5], y: &[f32]) -> Normal = LobeFitter::normal_kernel;
}

/// Relative SSE improvement below which Levenberg–Marquardt stops.
const REL_TOL: f64 = 1e-4;
/// Damping at which a fit is considered stuck (no descent direction left at f32 precision).
const LAMBDA_MAX: f64 = 1e7;

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
        // 1e-9: the f32 residual floor of an exact fit (81 residuals of ~1e-7·y).
        assert!(lsq.sse <= naive.sse + 1e-9, "{} vs {}", lsq.sse, naive.sse);
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
    fn kernels_of_every_instruction_set_give_the_same_bits() {
        let dirs = DirectionSet::ubo2003();
        let mut f = LobeFitter::new(&dirs.dirs).unwrap();
        let truth: Lobe = [0.8, 0.2, 0.1, (1.0f32 - 0.05).sqrt(), 4.0];
        let y = curve(&truth, &f);
        let p = [0.5, 0.0, 0.0, 1.0, 2.0];
        let b = f.normal_kernel(&p, &y);
        for i in Isa::available() {
            f.isa = i;
            let a = f.normal(&p, &y);
            assert_eq!(a.sse.to_bits(), b.sse.to_bits(), "{i:?}");
            for r in 0..5 {
                assert_eq!(a.jtr[r].to_bits(), b.jtr[r].to_bits(), "{i:?}");
                for c in r..5 {
                    assert_eq!(a.jtj[r][c].to_bits(), b.jtj[r][c].to_bits(), "{i:?}");
                }
            }
        }
    }

    #[test]
    fn more_lights_than_a_block_fit_the_same_lobe() {
        // Two blocks, the second partial and not a whole number of lanes.
        let mut rng = Pcg32::new(5, 5);
        let dirs: Vec<Vec3> = (0..BLOCK + 23)
            .map(|_| {
                let (a, b) = (rng.next_f32(), rng.next_f32());
                crate::math::warp::square_to_uniform_hemisphere(crate::math::Vec2::new(a, b))
            })
            .collect();
        let f = LobeFitter::new(&dirs).unwrap();
        let truth: Lobe = [0.7, 0.3, -0.2, (1.0f32 - 0.13).sqrt(), 6.0];
        let y = curve(&truth, &f);
        let fit = f.fit(&y);
        for k in 0..5 {
            assert!(
                (fit.lobe[k] - truth[k]).abs() < 2e-3 * truth[k].abs().max(1.0),
                "{fit:?}"
            );
        }
    }

    #[test]
    fn coplanar_lights_are_rejected() {
        let d = vec![Vec3::X, Vec3::Y, (Vec3::X + Vec3::Y).normalize()];
        assert!(LobeFitter::new(&d).is_err());
    }
}
