//! Lat-long environment map with Mitsuba 3's `envmap` mapping and bilinear lookup, importance
//! sampled by a piecewise-constant distribution over the cells of the bilinear interpolant.
//!
//! Mapping (local frame, +y up): direction d ↔ uv = (atan2(d.x, −d.z)/2π, acos(d.y)/π), both
//! evaluated as atan2 by [`crate::math::fastmath`] (no normalisation needed); the image
//! is looked up bilinearly with texel centres at u = (i + ½)/W (periodic in u) and rows at
//! v = j/(H − 1), exactly as Mitsuba's `eval_spectrum`. The sampling cells are the W × (H − 1)
//! patches between four neighbouring texels; each cell is chosen with probability ∝ mean corner
//! luminance × its solid angle, and sampled uniformly in (φ, cos θ), so the solid-angle pdf is
//! constant per cell (no 1/sin θ singularity at the poles).

// `!(x > 0.0)` deliberately also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::LightSample;
use crate::io::RgbImage;
use crate::math::color::luminance;
use crate::math::distribution::Distribution1D;
use crate::math::fastmath;
use crate::math::simd::lane::sin_cos;
use crate::math::{Mat4, PI, Spectrum, Vec2, Vec3};
use crate::{Error, Result};
use std::path::Path;

/// An importance-sampled environment map (radiance = scale · image).
#[derive(Clone, Debug)]
pub struct EnvMapLight {
    width: usize,
    height: usize,
    /// Linear RGB, row-major, pre-multiplied by `scale`.
    data: Vec<Spectrum>,
    /// Rotation part of to_world and its inverse (directions only).
    to_world: glam::Mat3,
    to_local: glam::Mat3,
    /// Over rows (H − 1 bins).
    rows: Option<Distribution1D>,
    /// Per row, over columns (W bins); None where the row has no energy.
    cols: Vec<Option<Distribution1D>>,
    /// cos θ at each texel row j (θ_j = π j / (H − 1)).
    cos_row: Vec<f32>,
    /// Per sampling row j, P(row j) / solid angle of one of its cells (sr⁻¹): times a column's
    /// probability, the solid-angle pdf of that cell, the same product in sample and pdf.
    row_density: Vec<f32>,
}

impl EnvMapLight {
    /// Builds the light; `filename` is only used in error messages.
    pub fn new(image: &RgbImage, to_world: Mat4, scale: f32, filename: &Path) -> Result<Self> {
        let (w, h) = (image.width, image.height);
        if w < 2 || h < 3 {
            return Err(Error::format(
                filename,
                format!("environment map must be at least 2×3 pixels, got {w}×{h}"),
            ));
        }
        let m3 = glam::Mat3::from_mat4(to_world);
        let det = m3.determinant();
        if !det.is_finite() || det.abs() < 1e-12 {
            return Err(Error::format(
                filename,
                "environment map to_world is singular",
            ));
        }
        let data: Vec<Spectrum> = image
            .data
            .chunks_exact(3)
            .map(|c| Spectrum::new(c[0], c[1], c[2]) * scale)
            .collect();
        let lum: Vec<f64> = data
            .iter()
            .map(|&c| {
                let l = luminance(c) as f64;
                if l.is_finite() && l > 0.0 { l } else { 0.0 }
            })
            .collect();
        let cos_row: Vec<f32> = (0..h)
            .map(|j| (PI * j as f32 / (h - 1) as f32).cos())
            .collect();
        let mut cols = Vec::with_capacity(h - 1);
        let mut row_w = Vec::with_capacity(h - 1);
        for j in 0..h - 1 {
            let d_omega =
                (cos_row[j] as f64 - cos_row[j + 1] as f64).max(0.0) * 2.0 * std::f64::consts::PI
                    / w as f64;
            let cells = (0..w).map(|i| {
                let i1 = (i + 1) % w;
                let m =
                    lum[j * w + i] + lum[j * w + i1] + lum[(j + 1) * w + i] + lum[(j + 1) * w + i1];
                0.25 * m * d_omega
            });
            let dist = Distribution1D::new(cells);
            row_w.push(dist.as_ref().map_or(0.0, |d| d.total()));
            cols.push(dist);
        }
        let rows = Distribution1D::new(row_w);
        let row_density = (0..h - 1)
            .map(|j| {
                let omega = (cos_row[j] - cos_row[j + 1]) * 2.0 * PI / w as f32;
                rows.as_ref().map_or(0.0, |r| r.pmf(j) / omega)
            })
            .collect();
        Ok(EnvMapLight {
            width: w,
            height: h,
            data,
            to_world: m3,
            to_local: m3.inverse(),
            rows,
            cols,
            cos_row,
            row_density,
        })
    }

    /// Radiance arriving from world direction `d` (unit, pointing away from the scene).
    pub fn eval(&self, d: Vec3) -> Spectrum {
        let uv = self.lat_long(d);
        self.lookup(self.column(uv.x), uv.y)
    }

    /// Radiance toward world direction `d` and the solid-angle pdf of [`EnvMapLight::sample`]
    /// there, converting the direction to lat-long coordinates once (escaped rays need both).
    pub fn eval_pdf(&self, d: Vec3) -> (Spectrum, f32) {
        let uv = self.lat_long(d);
        let col = self.column(uv.x);
        (self.lookup(col, uv.y), self.pdf_at(col.0, uv.y))
    }

    /// Lat-long coordinates (u = azimuth / 2π, v = polar angle / π) of world direction `d`.
    ///
    /// Both angles are atan2 of the local direction's components, which does not depend on its
    /// length: no normalisation (a square root and a division) and no acos (a third) on the
    /// escaped-ray and light-sample paths. A zero or non-finite direction maps to (½, ½), where
    /// the normalised zero vector went before (atan2(0, −0) = π, acos(0) = π/2).
    #[inline]
    fn lat_long(&self, d: Vec3) -> Vec2 {
        let v = self.to_local * d;
        if !v.is_finite() || v == Vec3::ZERO {
            return Vec2::splat(0.5);
        }
        let r = (v.x * v.x + v.z * v.z).sqrt();
        Vec2::new(
            fastmath::atan2(v.x, -v.z) * (0.5 / PI),
            fastmath::atan2(r, v.y) * (1.0 / PI),
        )
    }

    /// The texel column left of lat-long `u` (periodic) and the fraction of the way to the next
    /// one: shared by the bilinear lookup and the pdf (whose cell is that column).
    #[inline]
    fn column(&self, u: f32) -> (usize, f32) {
        let w = self.width;
        let mut u = u - 0.5 / w as f32;
        u -= fastmath::floor_small(u);
        let x = u * w as f32;
        let ix = (x as usize).min(w - 1);
        (ix, x - ix as f32)
    }

    /// Mitsuba's bilinear lookup at texel column `col` (from [`EnvMapLight::column`]) and
    /// lat-long `v`.
    #[inline]
    fn lookup(&self, (ix, fx): (usize, f32), v: f32) -> Spectrum {
        let (w, h) = (self.width, self.height);
        let v = v - fastmath::floor_small(v);
        let y = v * (h - 1) as f32;
        let iy = (y as usize).min(h - 2);
        let fy = y - iy as f32;
        // The next column wraps around without an integer division.
        let ix1 = if ix + 1 == w { 0 } else { ix + 1 };
        let row0 = &self.data[iy * w..(iy + 2) * w];
        let (a, b) = (row0[ix], row0[ix1]);
        let (c, d) = (row0[w + ix], row0[w + ix1]);
        let top = a * (1.0 - fx) + b * fx;
        let bot = c * (1.0 - fx) + d * fx;
        top * (1.0 - fy) + bot * fy
    }

    /// Samples a world direction; returns (direction, radiance, solid-angle pdf).
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Spectrum, f32)> {
        let rows = self.rows.as_ref()?;
        let (j, _, uy) = rows.sample(u.y);
        let cols = self.cols[j].as_ref()?;
        let (i, pi, ux) = cols.sample(u.x);
        let (c0, c1) = (self.cos_row[j], self.cos_row[j + 1]);
        let cos_t = c0 + (c1 - c0) * uy;
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let u_lat = (i as f32 + ux) / self.width as f32 + 0.5 / self.width as f32;
        let (sp, cp) = sin_cos(2.0 * PI * u_lat);
        let local = Vec3::new(sin_t * sp, cos_t, -sin_t * cp);
        let d = (self.to_world * local).normalize_or_zero();
        let pdf = pi * self.row_density[j];
        if !(pdf > 0.0) || !pdf.is_finite() || d == Vec3::ZERO {
            return None;
        }
        Some((d, self.eval(d), pdf))
    }

    /// [`EnvMapLight::sample`] as a light sample (pdf in solid angle, no selection).
    #[inline]
    pub fn sample_li(&self, u: Vec2) -> Option<LightSample> {
        let (wi, val, pdf) = self.sample(u)?;
        Some(LightSample {
            wi,
            dist: f32::INFINITY,
            n_geo: Vec3::ZERO,
            weight: val / pdf,
            pdf,
            delta: false,
        })
    }

    /// Solid-angle pdf with which [`EnvMapLight::sample`] returns world direction `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        let uv = self.lat_long(d);
        self.pdf_at(self.column(uv.x).0, uv.y)
    }

    /// [`EnvMapLight::pdf`] at texel column `i` (from [`EnvMapLight::column`], which is also the
    /// sampling cell's column) and lat-long `v`.
    #[inline]
    fn pdf_at(&self, i: usize, v: f32) -> f32 {
        let j = ((v * (self.height - 1) as f32) as usize).min(self.height - 2);
        match &self.cols[j] {
            Some(cols) => cols.pmf(i) * self.row_density[j],
            None => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Pcg32;

    fn test_map() -> RgbImage {
        let (w, h) = (8, 5);
        let mut img = RgbImage::new(w, h);
        for j in 0..h {
            for i in 0..w {
                let v =
                    0.1 + (i * 7 + j * 3) as f32 % 5.0 + if (i, j) == (2, 1) { 40.0 } else { 0.0 };
                img.set(i, j, [v, 0.5 * v, 0.25]);
            }
        }
        img
    }

    #[test]
    fn mitsuba_mapping_up_is_row_zero_and_texel_centres_are_exact() {
        let img = test_map();
        let env = EnvMapLight::new(&img, Mat4::IDENTITY, 2.0, Path::new("t.exr")).unwrap();
        // +y (θ = 0) is row 0; with u at a texel centre the lookup is exact.
        let want = Spectrum::from(img.get(0, 0)) * 2.0;
        // Texel (i, j) sits at u = (i + ½)/W, v = j/(H−1).
        let u = 0.5 / 8.0;
        let phi = 2.0 * PI * u;
        let theta = PI * 1.0 / 4.0; // row 1
        let d = Vec3::new(
            theta.sin() * phi.sin(),
            theta.cos(),
            -theta.sin() * phi.cos(),
        );
        let got = env.eval(d);
        let want1 = Spectrum::from(img.get(0, 1)) * 2.0;
        assert!((got - want1).length() < 1e-4, "{got} vs {want1}");
        let top = env.eval(Vec3::new(0.0, 1.0, 0.0));
        // At the pole v = 0 the lookup interpolates along row 0 only.
        assert!((top.z - want.z).abs() < 1e-5);
    }

    /// A zero or non-finite direction looks up the map at (½, ½), as the normalised zero
    /// vector did before the atan2 mapping, instead of returning NaN.
    #[test]
    fn degenerate_directions_map_to_the_centre() {
        let img = test_map();
        let env = EnvMapLight::new(&img, Mat4::IDENTITY, 1.0, Path::new("t.exr")).unwrap();
        let centre = env.lookup(env.column(0.5), 0.5);
        for d in [Vec3::ZERO, Vec3::NAN, Vec3::new(f32::INFINITY, 0.0, 1.0)] {
            assert_eq!(env.lat_long(d), Vec2::splat(0.5));
            assert_eq!(env.eval(d), centre);
            assert!(env.pdf(d).is_finite());
        }
    }

    #[test]
    fn rotation_moves_the_map() {
        let img = test_map();
        let rot = Mat4::from_rotation_x(0.5 * PI);
        let a = EnvMapLight::new(&img, Mat4::IDENTITY, 1.0, Path::new("t.exr")).unwrap();
        let b = EnvMapLight::new(&img, rot, 1.0, Path::new("t.exr")).unwrap();
        let d = Vec3::new(0.3, 0.5, -0.2).normalize();
        let rd = rot.transform_vector3(d);
        assert!((a.eval(d) - b.eval(rd)).length() < 1e-4);
        assert!((a.pdf(d) - b.pdf(rd)).abs() < 1e-3 * a.pdf(d));
    }

    /// Chi-square test of the sampled directions against the pdf, on a (cos θ, φ) grid of
    /// equal-solid-angle bins whose expected counts come from integrating `pdf` numerically.
    #[test]
    fn sampling_matches_pdf_chi_square() {
        let img = test_map();
        let rot = Mat4::from_rotation_z(0.3) * Mat4::from_rotation_x(0.2);
        let env = EnvMapLight::new(&img, rot, 1.0, Path::new("t.exr")).unwrap();
        let (nt, np) = (10usize, 20usize);
        let n = 200_000;
        let mut hist = vec![0f64; nt * np];
        let mut rng = Pcg32::new(11, 12);
        let bin = |d: Vec3| {
            let t = (((1.0 - d.z) * 0.5 * nt as f32) as usize).min(nt - 1);
            let mut phi = d.y.atan2(d.x);
            if phi < 0.0 {
                phi += 2.0 * PI;
            }
            let p = ((phi / (2.0 * PI) * np as f32) as usize).min(np - 1);
            t * np + p
        };
        for _ in 0..n {
            let (d, val, pdf) = env.sample(rng.next_2d()).unwrap();
            assert!((d.length() - 1.0).abs() < 1e-4);
            assert!(
                (pdf - env.pdf(d)).abs() <= 1e-3 * pdf,
                "{pdf} vs {}",
                env.pdf(d)
            );
            assert!((val - env.eval(d)).length() < 1e-5);
            hist[bin(d)] += 1.0;
        }
        // Expected: integrate pdf over each bin with a fine stratified grid.
        let sub = 64;
        let mut expect = vec![0f64; nt * np];
        let mut total = 0.0;
        for t in 0..nt * sub {
            for p in 0..np * sub {
                let z = 1.0 - 2.0 * (t as f32 + 0.5) / (nt * sub) as f32;
                let phi = 2.0 * PI * (p as f32 + 0.5) / (np * sub) as f32;
                let r = (1.0 - z * z).sqrt();
                let d = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                let w =
                    env.pdf(d) as f64 * 4.0 * std::f64::consts::PI / (nt * np * sub * sub) as f64;
                expect[bin(d)] += w;
                total += w;
            }
        }
        assert!((total - 1.0).abs() < 0.01, "pdf integrates to {total}");
        let mut chi2 = 0.0;
        let mut dof = 0;
        let mut pooled = (0.0, 0.0);
        for k in 0..nt * np {
            let e = expect[k] * n as f64;
            if e < 5.0 {
                pooled.0 += hist[k];
                pooled.1 += e;
                continue;
            }
            chi2 += (hist[k] - e).powi(2) / e;
            dof += 1;
        }
        if pooled.1 >= 5.0 {
            chi2 += (pooled.0 - pooled.1).powi(2) / pooled.1;
            dof += 1;
        }
        // Critical value at α = 0.001 for ≈200 dof is ≈ 267; Wilson–Hilferty bound used.
        let k = (dof - 1) as f64;
        let z = 3.09;
        let crit = k * (1.0 - 2.0 / (9.0 * k) + z * (2.0 / (9.0 * k)).sqrt()).powi(3);
        assert!(chi2 < crit, "chi2 {chi2} > {crit} (dof {k})");
    }
}
