//! Lat-long environment map with Mitsuba 3's `envmap` mapping and bilinear lookup, importance
//! sampled by alias tables over the cells of the bilinear interpolant.
//!
//! Mapping (local frame, +y up): direction d ↔ uv = (atan2(d.x, −d.z)/2π, acos(d.y)/π), both
//! evaluated as atan2 by [`crate::math::simd::approx`] (no normalisation needed); the image
//! is looked up bilinearly with texel centres at u = (i + ½)/W (periodic in u) and rows at
//! v = j/(H − 1), exactly as Mitsuba's `eval_spectrum`. The sampling cells are the W × (H − 1)
//! patches between four neighbouring texels; each cell is chosen with probability ∝ mean corner
//! luminance × its solid angle — a row by one alias table, then a column by that row's — and
//! sampled uniformly in (φ, cos θ), so the solid-angle pdf is constant per cell (no 1/sin θ
//! singularity at the poles) and is one table read. Alias tables take one read per draw where a
//! CDF search takes a data-dependent loop, so the packet kernel samples 16 lanes with gathers
//! ([`EnvMapLight::sample_x`], [`EnvMapLight::eval_pdf_x`]: the scalar code's `_x` twins).

// `!(x > 0.0)` deliberately also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::{LightSample, LightSampleX};
use crate::io::RgbImage;
use crate::math::alias::AliasTable;
use crate::math::color::luminance;
use crate::math::simd::WIDTH;
use crate::math::simd::approx::{self, atan2_x, floor_small_x, sin_cos};
use crate::math::simd::f16::{F16, M16, V2x, V3x, lanes};
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
    /// Over sampling rows (H − 1 bins, by their total weight); None if the map is black.
    rows: Option<AliasTable>,
    /// Per sampling row, over its W cells.
    cols: AliasTable,
    /// cos θ at each texel row j (θ_j = π j / (H − 1)).
    cos_row: Vec<f32>,
    /// Per cell (row-major, W per sampling row): the solid-angle pdf of sampling a direction in
    /// it (sr⁻¹), read by `sample` and `pdf` alike.
    cell_pdf: Vec<f32>,
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
        // Solid angle of one cell of sampling row j.
        let omega = |j: usize| {
            (cos_row[j] as f64 - cos_row[j + 1] as f64).max(0.0) * 2.0 * std::f64::consts::PI
                / w as f64
        };
        let mut cell_w = vec![0f64; (h - 1) * w];
        for j in 0..h - 1 {
            for i in 0..w {
                let i1 = (i + 1) % w;
                let m =
                    lum[j * w + i] + lum[j * w + i1] + lum[(j + 1) * w + i] + lum[(j + 1) * w + i1];
                cell_w[j * w + i] = 0.25 * m * omega(j);
            }
        }
        let too_big = || Error::format(filename, "environment map too large to sample");
        let cols = AliasTable::rows(&cell_w, w).ok_or_else(too_big)?;
        let row_w: Vec<f64> = (0..h - 1).map(|j| cols.total(j)).collect();
        let rows = AliasTable::new(&row_w);
        let total: f64 = row_w.iter().sum();
        let cell_pdf = cell_w
            .iter()
            .enumerate()
            .map(|(k, &cw)| {
                let o = omega(k / w);
                if total > 0.0 && o > 0.0 {
                    (cw / total / o) as f32
                } else {
                    0.0
                }
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
            cell_pdf,
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

    /// [`EnvMapLight::eval_pdf`] for 16 directions (the same bits per lane).
    #[inline(always)]
    pub fn eval_pdf_x(&self, d: V3x) -> (V3x, F16) {
        let (u, v) = self.lat_long_x(d);
        let col = self.column_x(u);
        (self.lookup_x(col, v), self.pdf_at_x(col.0, v))
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
            approx::atan2(v.x, -v.z) * (0.5 / PI),
            approx::atan2(r, v.y) * (1.0 / PI),
        )
    }

    /// [`EnvMapLight::lat_long`] per lane: (u, v).
    #[inline(always)]
    fn lat_long_x(&self, d: V3x) -> (F16, F16) {
        let v = d.transform(&self.to_local);
        let bad = v.is_finite().not().or(v.is_zero());
        let r = (v.x * v.x + v.z * v.z).sqrt();
        let u = atan2_x(v.x, -v.z) * (0.5 / PI);
        let t = atan2_x(r, v.y) * (1.0 / PI);
        let half = F16::splat(0.5);
        (F16::select(bad, half, u), F16::select(bad, half, t))
    }

    /// The texel column left of lat-long `u` (periodic) and the fraction of the way to the next
    /// one: shared by the bilinear lookup and the pdf (whose cell is that column).
    #[inline]
    fn column(&self, u: f32) -> (usize, f32) {
        let w = self.width;
        let mut u = u - 0.5 / w as f32;
        u -= approx::floor_small(u);
        let x = u * w as f32;
        let ix = (x as usize).min(w - 1);
        (ix, x - ix as f32)
    }

    /// [`EnvMapLight::column`] per lane.
    #[inline(always)]
    fn column_x(&self, u: F16) -> ([u32; WIDTH], F16) {
        let w = self.width;
        let u = u - 0.5 / w as f32;
        let u = u - floor_small_x(u);
        let x = u * w as f32;
        let ix: [u32; WIDTH] = lanes(|l| (x.0[l] as u32).min(w as u32 - 1));
        (ix, x - F16(lanes(|l| ix[l] as f32)))
    }

    /// Mitsuba's bilinear lookup at texel column `col` (from [`EnvMapLight::column`]) and
    /// lat-long `v`.
    #[inline]
    fn lookup(&self, (ix, fx): (usize, f32), v: f32) -> Spectrum {
        let (w, h) = (self.width, self.height);
        let v = v - approx::floor_small(v);
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

    /// [`EnvMapLight::lookup`] per lane: four texel gathers per lane, the blends in SoA.
    #[inline(always)]
    fn lookup_x(&self, (ix, fx): ([u32; WIDTH], F16), v: F16) -> V3x {
        let (w, h) = (self.width, self.height);
        let v = v - floor_small_x(v);
        let y = v * (h - 1) as f32;
        let iy: [u32; WIDTH] = lanes(|l| (y.0[l] as u32).min(h as u32 - 2));
        let fy = y - F16(lanes(|l| iy[l] as f32));
        // Each lane's four texels: (ix, iy), (ix + 1, iy), (ix, iy + 1), (ix + 1, iy + 1).
        let last = self.data.len() - 1;
        let mut at = [[0usize; WIDTH]; 4];
        for l in 0..WIDTH {
            let (x0, y0) = (ix[l] as usize, iy[l] as usize);
            let x1 = if x0 + 1 == w { 0 } else { x0 + 1 };
            let (r0, r1) = (y0 * w, (y0 + 1) * w);
            at[0][l] = (r0 + x0).min(last);
            at[1][l] = (r0 + x1).min(last);
            at[2][l] = (r1 + x0).min(last);
            at[3][l] = (r1 + x1).min(last);
        }
        let (a, b) = (self.texels_x(&at[0]), self.texels_x(&at[1]));
        let (c, d) = (self.texels_x(&at[2]), self.texels_x(&at[3]));
        let gx = 1.0 - fx;
        let top = a.scale(gx).add(b.scale(fx));
        let bot = c.scale(gx).add(d.scale(fx));
        top.scale(1.0 - fy).add(bot.scale(fy))
    }

    /// The texels at flat indices `at` (each in range), one per lane.
    #[inline(always)]
    fn texels_x(&self, at: &[usize; WIDTH]) -> V3x {
        let (mut x, mut y, mut z) = ([0f32; WIDTH], [0f32; WIDTH], [0f32; WIDTH]);
        for l in 0..WIDTH {
            let t = self.data[at[l]];
            (x[l], y[l], z[l]) = (t.x, t.y, t.z);
        }
        V3x::new(F16(x), F16(y), F16(z))
    }

    /// Samples a world direction; returns (direction, radiance, solid-angle pdf).
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Spectrum, f32)> {
        let rows = self.rows.as_ref()?;
        let w = self.width;
        let (j, uy) = rows.sample(0, u.y);
        let (i, ux) = self.cols.sample(j, u.x);
        let pdf = self.cell_pdf[j * w + i];
        let (c0, c1) = (self.cos_row[j], self.cos_row[j + 1]);
        let cos_t = c0 + (c1 - c0) * uy;
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let u_lat = (i as f32 + ux) / w as f32 + 0.5 / w as f32;
        let (sp, cp) = sin_cos(2.0 * PI * u_lat);
        let local = Vec3::new(sin_t * sp, cos_t, -sin_t * cp);
        let d = (self.to_world * local).normalize_or_zero();
        if !(pdf > 0.0) || !pdf.is_finite() || d == Vec3::ZERO {
            return None;
        }
        // The radiance at the sampled lat-long point itself: the cell's column and fraction,
        // and the polar angle of (sin θ, cos θ).
        let v = approx::atan2(sin_t, cos_t) * (1.0 / PI);
        Some((d, self.lookup((i, ux), v), pdf))
    }

    /// [`EnvMapLight::sample`] for 16 lanes: (direction, radiance, pdf, lanes where the scalar
    /// code returns a sample), the same bits per lane.
    #[inline(always)]
    pub fn sample_x(&self, u: V2x) -> (V3x, V3x, F16, M16) {
        let Some(rows) = self.rows.as_ref() else {
            return (V3x::ZERO, V3x::ZERO, F16::splat(0.0), M16::splat(false));
        };
        let w = self.width;
        let (j, uy) = rows.sample_x([0; WIDTH], u.y);
        let (i, ux) = self.cols.sample_x(j, u.x);
        let last = self.cell_pdf.len() - 1;
        let pdf = F16(lanes(|l| {
            self.cell_pdf[(j[l] as usize * w + i[l] as usize).min(last)]
        }));
        let top = self.cos_row.len() - 1;
        let c0 = F16(lanes(|l| self.cos_row[(j[l] as usize).min(top)]));
        let c1 = F16(lanes(|l| self.cos_row[(j[l] as usize + 1).min(top)]));
        let cos_t = c0 + (c1 - c0) * uy;
        let sin_t = (1.0 - cos_t * cos_t).max(F16::splat(0.0)).sqrt();
        let fi = F16(lanes(|l| i[l] as f32));
        let u_lat = (fi + ux) / w as f32 + 0.5 / w as f32;
        let (sp, cp) = approx::sin_cos_x(2.0 * PI * u_lat);
        let local = V3x::new(sin_t * sp, cos_t, -sin_t * cp);
        let d = local.transform(&self.to_world).normalize_or_zero();
        let ok = pdf
            .gt(F16::splat(0.0))
            .and(pdf.is_finite())
            .and(d.is_zero().not());
        let v = atan2_x(sin_t, cos_t) * (1.0 / PI);
        (d, self.lookup_x((i, ux), v), pdf, ok)
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

    /// [`EnvMapLight::sample_li`] for 16 lanes: the samples and the lanes that have one.
    #[inline(always)]
    pub fn sample_li_x(&self, u: V2x) -> (LightSampleX, M16) {
        let (wi, val, pdf, ok) = self.sample_x(u);
        let s = LightSampleX {
            wi,
            dist: F16::splat(f32::INFINITY),
            n_geo: V3x::ZERO,
            weight: val.div(pdf),
            pdf,
            delta: M16::splat(false),
        };
        (s, ok)
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
        self.cell_pdf[j * self.width + i]
    }

    /// [`EnvMapLight::pdf_at`] per lane.
    #[inline(always)]
    fn pdf_at_x(&self, i: [u32; WIDTH], v: F16) -> F16 {
        let (w, h) = (self.width, self.height);
        let y = v * (h - 1) as f32;
        let last = self.cell_pdf.len() - 1;
        F16(lanes(|l| {
            let j = (y.0[l] as usize).min(h - 2);
            self.cell_pdf[(j * w + i[l] as usize).min(last)]
        }))
    }
}

#[cfg(test)]
mod tests;
