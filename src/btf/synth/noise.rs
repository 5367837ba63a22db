//! Periodic (tileable) procedural noise: gradient noise, fBm and Worley cells whose lattice wraps
//! with integer periods, so every micro-geometry built from them tiles without seams.

use crate::math::rng::mix64;

/// A hash of an integer lattice point and a seed to 64 well-mixed bits.
#[inline]
pub fn hash2(i: i64, j: i64, seed: u64) -> u64 {
    mix64((i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ mix64((j as u64) ^ mix64(seed)))
}

/// Uniform in [0, 1) from 24 bits of a hash.
#[inline]
pub fn hash_unit(h: u64) -> f32 {
    (h >> 40) as f32 * (1.0 / 16_777_216.0)
}

#[inline]
fn fade(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

#[inline]
fn grad(i: i64, j: i64, px: i64, py: i64, seed: u64, dx: f32, dy: f32) -> f32 {
    let h = hash2(i.rem_euclid(px), j.rem_euclid(py), seed);
    let a = hash_unit(h) * std::f32::consts::TAU;
    let (s, c) = a.sin_cos();
    c * dx + s * dy
}

/// Gradient (Perlin) noise in roughly [-0.7, 0.7], periodic with integer periods `(px, py)` in
/// lattice units (a point and the point shifted by a period give the same value).
pub fn periodic_noise(x: f32, y: f32, px: u32, py: u32, seed: u64) -> f32 {
    let (px, py) = (px.max(1) as i64, py.max(1) as i64);
    let (fx, fy) = (x.floor(), y.floor());
    let (i, j) = (fx as i64, fy as i64);
    let (dx, dy) = (x - fx, y - fy);
    let n00 = grad(i, j, px, py, seed, dx, dy);
    let n10 = grad(i + 1, j, px, py, seed, dx - 1.0, dy);
    let n01 = grad(i, j + 1, px, py, seed, dx, dy - 1.0);
    let n11 = grad(i + 1, j + 1, px, py, seed, dx - 1.0, dy - 1.0);
    let (u, v) = (fade(dx), fade(dy));
    let a = n00 + u * (n10 - n00);
    let b = n01 + u * (n11 - n01);
    a + v * (b - a)
}

/// Fractal sum of [`periodic_noise`] octaves (each doubles frequency and period, halves amplitude),
/// evaluated at (u, v) ∈ [0, 1)² of a tile holding `(px, py)` base cells.
pub fn periodic_fbm(u: f32, v: f32, px: u32, py: u32, octaves: u32, seed: u64) -> f32 {
    let mut sum = 0.0;
    let mut amp = 1.0;
    let mut norm = 0.0;
    for k in 0..octaves {
        let f = 1u32 << k;
        sum += amp
            * periodic_noise(
                u * (px * f) as f32,
                v * (py * f) as f32,
                px * f,
                py * f,
                seed.wrapping_add(k as u64 * 0x51),
            );
        norm += amp;
        amp *= 0.5;
    }
    if norm > 0.0 { sum / norm } else { 0.0 }
}

/// Worley (cellular) noise at (u, v) ∈ [0, 1)² of a tile of `(px, py)` jittered cells: distances
/// (in cell units) to the nearest and second-nearest feature point, and the nearest cell's hash.
pub fn periodic_worley(u: f32, v: f32, px: u32, py: u32, seed: u64) -> (f32, f32, u64) {
    let (pxi, pyi) = (px.max(1) as i64, py.max(1) as i64);
    let (x, y) = (u * pxi as f32, v * pyi as f32);
    let (ci, cj) = (x.floor() as i64, y.floor() as i64);
    let mut f1 = f32::INFINITY;
    let mut f2 = f32::INFINITY;
    let mut id = 0;
    for dj in -1..=1 {
        for di in -1..=1 {
            let (i, j) = (ci + di, cj + dj);
            let h = hash2(i.rem_euclid(pxi), j.rem_euclid(pyi), seed);
            let fx = i as f32 + 0.1 + 0.8 * hash_unit(h);
            let fy = j as f32 + 0.1 + 0.8 * hash_unit(mix64(h));
            let d = ((fx - x).powi(2) + (fy - y).powi(2)).sqrt();
            if d < f1 {
                f2 = f1;
                f1 = d;
                id = h;
            } else if d < f2 {
                f2 = d;
            }
        }
    }
    (f1, f2, id)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_is_periodic_and_bounded() {
        for k in 0..50 {
            let x = k as f32 * 0.173;
            let y = k as f32 * 0.311;
            let a = periodic_noise(x, y, 5, 3, 9);
            assert!((a - periodic_noise(x + 5.0, y - 3.0, 5, 3, 9)).abs() < 1e-4);
            assert!(a.abs() <= 1.0);
            let u = (k as f32 * 0.0371).fract();
            let w = (k as f32 * 0.0913).fract();
            let f = periodic_fbm(u, w, 2, 3, 4, 1);
            assert!((f - periodic_fbm(u + 1.0, w + 1.0, 2, 3, 4, 1)).abs() < 1e-4);
            let (f1, f2, _) = periodic_worley(u, w, 4, 4, 2);
            let (g1, g2, _) = periodic_worley(u + 1.0, w, 4, 4, 2);
            assert!((f1 - g1).abs() < 1e-4 && (f2 - g2).abs() < 1e-4 && f1 <= f2);
        }
        // Not constant.
        assert!(
            (periodic_noise(0.3, 0.4, 4, 4, 1) - periodic_noise(1.7, 2.2, 4, 4, 1)).abs() > 1e-3
        );
    }
}
