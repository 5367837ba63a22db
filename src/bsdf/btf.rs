//! The raw measured BTF as a material (DESIGN §2): barycentric interpolation over 3 measured views
//! × 3 measured lights, nearest texel, eval = B/π (B is cosine-baked), one-sided.
//!
//! Sampling: at load, per measured view, a piecewise-constant density over the light triangulation
//! on the unit disk, proportional to the texel-averaged luminance of B / cos θ_l (so a Lambertian
//! table gives exactly cosine sampling); for a query the tables of the 3 views of wi are blended
//! with their interpolation weights, and a cosine lobe is always mixed in (one-sample MIS mixture)
//! so the weight f·cos/pdf ≤ max B / (COSINE_FRACTION · cos θ) stays bounded and directions beyond
//! the outermost measured ring are covered.
//!
//! Memory: the material reads the BTF only through `RawBtf::data()` (f16, `[view][light][row][col]
//! [rgb]`) and its dimensions; a 256² × 81 × 81 material is 2.6 GB, so it must be kept once per
//! file (the material holds an `Arc`) and can live in a memory-mapped cache file (`.btfc`) behind the
//! same accessor. Building the tables reads at most 64 × 64 texels per image.

use super::{BsdfFlags, BsdfSample};
use crate::btf::directions::DirectionInterp;
use crate::btf::{BtfSource, RawBtf};
use crate::geometry::SurfaceInteraction;
use crate::math::color::luminance;
use crate::math::{INV_PI, Spectrum, Vec2, Vec3, warp};
use crate::{Error, Result};
use rayon::prelude::*;
use std::path::Path;
use std::sync::Arc;

/// Probability of the cosine component of the sampling mixture (the defensive part).
pub const COSINE_FRACTION: f32 = 0.2;
/// Lower bound on cos θ_l when turning B into a density over the disk (avoids blow-up at grazing
/// measured lights of arbitrary direction sets).
const MIN_COS: f32 = 0.05;
/// Texels per axis averaged per image when building the sampling tables.
const TABLE_TEXELS: usize = 64;

/// A loaded BTF with its direction interpolators and sampling tables; shared (`Arc`) by every
/// [`BtfBsdf`] that uses the same file.
#[derive(Debug)]
pub struct BtfMaterial {
    btf: Arc<RawBtf>,
    views: DirectionInterp,
    lights: DirectionInterp,
    /// Per view: cumulative distribution over light triangles, `[view][triangle]`, last = 1.
    tri_cdf: Vec<f32>,
    /// Per view: density over disk area of each light triangle, `[view][triangle]` (∫ dA = 1).
    tri_density: Vec<f32>,
    /// Per view: false if the table is empty (black view); cosine sampling is used instead.
    table_ok: Vec<bool>,
}

impl BtfMaterial {
    /// Builds the interpolators and sampling tables of a BTF.
    pub fn new(btf: Arc<RawBtf>) -> Result<Self> {
        let views = btf
            .views()
            .interpolator()
            .map_err(|e| Error::Invalid(format!("BTF view directions: {e}")))?;
        let lights = btf
            .lights()
            .interpolator()
            .map_err(|e| Error::Invalid(format!("BTF light directions: {e}")))?;
        let (nv, nl, nt) = (btf.views().len(), btf.lights().len(), lights.num_triangles());
        let (w, h) = (btf.width(), btf.height());
        let (sx, sy) = (w.div_ceil(TABLE_TEXELS), h.div_ceil(TABLE_TEXELS));
        let data = btf.data();
        let light_cos: Vec<f32> = btf.lights().dirs.iter().map(|d| d.z).collect();
        // g(view, light) = texel-averaged luminance of B / cos θ_l (≥ 0).
        let g: Vec<f32> = (0..nv * nl)
            .into_par_iter()
            .map(|vl| {
                let mut sum = Spectrum::ZERO;
                let mut count = 0u32;
                for y in (0..h).step_by(sy) {
                    let row = 3 * ((vl * h + y) * w);
                    for x in (0..w).step_by(sx) {
                        let i = row + 3 * x;
                        sum += Spectrum::new(
                            data[i].to_f32(),
                            data[i + 1].to_f32(),
                            data[i + 2].to_f32(),
                        );
                        count += 1;
                    }
                }
                let lum = luminance(sum / count as f32);
                let v = lum / light_cos[vl % nl].max(MIN_COS);
                if v.is_finite() { v.max(0.0) } else { 0.0 }
            })
            .collect();
        let mut tri_cdf = vec![0f32; nv * nt];
        let mut tri_density = vec![0f32; nv * nt];
        let mut table_ok = vec![false; nv];
        for v in 0..nv {
            let gv = &g[v * nl..(v + 1) * nl];
            let mut total = 0f64;
            for t in 0..nt {
                let tri = lights.triangle(t);
                let mean = tri.iter().map(|&i| gv[i as usize] as f64).sum::<f64>() / 3.0;
                tri_density[v * nt + t] = mean as f32;
                total += mean * lights.triangle_area(t) as f64;
                tri_cdf[v * nt + t] = total as f32;
            }
            if total > 0.0 && total.is_finite() {
                table_ok[v] = true;
                for t in 0..nt {
                    tri_cdf[v * nt + t] = (tri_cdf[v * nt + t] as f64 / total) as f32;
                    tri_density[v * nt + t] = (tri_density[v * nt + t] as f64 / total) as f32;
                }
                tri_cdf[v * nt + nt - 1] = 1.0;
            }
        }
        Ok(BtfMaterial {
            btf,
            views,
            lights,
            tri_cdf,
            tri_density,
            table_ok,
        })
    }

    /// Loads a BTF file (any format `btf::load_raw` reads) and builds the material.
    pub fn load(path: &Path) -> Result<Self> {
        let btf = crate::btf::load_raw(path)?;
        Self::new(Arc::new(btf)).map_err(|e| Error::format(path, e.to_string()))
    }

    /// The underlying measured data.
    pub fn btf(&self) -> &RawBtf {
        &self.btf
    }

    /// B(view dir, light dir, texel) interpolated over 3 × 3 measured directions (cosine-baked).
    #[inline]
    pub fn eval_b(&self, wi: Vec3, wo: Vec3, x: usize, y: usize) -> Spectrum {
        let (vi, vw) = self.views.lookup(wi);
        let (li, lw) = self.lights.lookup(wo);
        let (w, h, nl) = (self.btf.width(), self.btf.height(), self.btf.lights().len());
        let data = self.btf.data();
        let texel = y * w + x;
        let mut acc = [0f32; 3];
        for a in 0..3 {
            if vw[a] == 0.0 {
                continue;
            }
            let view_base = vi[a] as usize * nl;
            for b in 0..3 {
                let wgt = vw[a] * lw[b];
                if wgt == 0.0 {
                    continue;
                }
                let i = 3 * ((view_base + li[b] as usize) * (w * h) + texel);
                let px = &data[i..i + 3];
                acc[0] += wgt * px[0].to_f32();
                acc[1] += wgt * px[1].to_f32();
                acc[2] += wgt * px[2].to_f32();
            }
        }
        Spectrum::from(acc)
    }

    /// Density over the unit disk of the blended light tables at disk point `q` (0 off the hull).
    #[inline]
    fn table_density(&self, vi: [u32; 3], vw: [f32; 3], q: [f32; 2]) -> f32 {
        let (t, bw) = self.lights.locate(q);
        let inside = bw[0].min(bw[1]).min(bw[2]) >= -1e-6;
        let nt = self.lights.num_triangles();
        let mut d = 0.0;
        for k in 0..3 {
            if vw[k] == 0.0 {
                continue;
            }
            let v = vi[k] as usize;
            d += vw[k]
                * if !self.table_ok[v] {
                    INV_PI // black view: its share is cosine sampled
                } else if inside {
                    self.tri_density[v * nt + t]
                } else {
                    0.0
                };
        }
        d
    }
}

/// A BTF material instance: shared data + its uv tiling.
#[derive(Clone, Debug)]
pub struct BtfBsdf {
    material: Arc<BtfMaterial>,
    /// Texture-space repetitions per unit of uv.
    uv_scale: f32,
}

impl BtfBsdf {
    /// An instance of `material` tiled `uv_scale` times per unit uv (finite, non-zero).
    pub fn new(material: Arc<BtfMaterial>, uv_scale: f32) -> Result<Self> {
        if !uv_scale.is_finite() || uv_scale == 0.0 {
            return Err(Error::Invalid(format!(
                "btf uv_scale must be finite and non-zero, got {uv_scale}"
            )));
        }
        Ok(BtfBsdf { material, uv_scale })
    }

    /// The shared material.
    pub fn material(&self) -> &Arc<BtfMaterial> {
        &self.material
    }

    /// Texel (column, row) of uv: ⌊frac(u·uv_scale)·W⌋, ⌊frac(v·uv_scale)·H⌋ (DESIGN §2).
    #[inline]
    pub fn texel(&self, uv: Vec2) -> (usize, usize) {
        let btf = &self.material.btf;
        let idx = |c: f32, n: usize| {
            let s = c * self.uv_scale;
            let f = s - s.floor();
            ((f * n as f32) as usize).min(n - 1)
        };
        (idx(uv.x, btf.width()), idx(uv.y, btf.height()))
    }

    /// Lobes: measured reflection, glossy in general, varying over the surface.
    pub fn flags(&self) -> BsdfFlags {
        BsdfFlags::GLOSSY_REFLECTION | BsdfFlags::SPATIALLY_VARYING
    }

    /// f · cos θ_o = B/π with wi = view (toward the camera), wo = light; 0 below either horizon.
    #[inline]
    pub fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        if si.wi.z <= 0.0 || wo.z <= 0.0 {
            return Spectrum::ZERO;
        }
        let (x, y) = self.texel(si.uv);
        self.material.eval_b(si.wi, wo, x, y) * INV_PI
    }

    /// Solid-angle pdf of [`BtfBsdf::sample`].
    #[inline]
    pub fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        if si.wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let (vi, vw) = self.material.views.lookup(si.wi);
        self.pdf_with_views(vi, vw, wo)
    }

    #[inline]
    fn pdf_with_views(&self, vi: [u32; 3], vw: [f32; 3], wo: Vec3) -> f32 {
        let table = self.material.table_density(vi, vw, [wo.x, wo.y]);
        // Disk-area density × cos θ = solid-angle density.
        wo.z * (COSINE_FRACTION * INV_PI + (1.0 - COSINE_FRACTION) * table)
    }

    /// Samples a light direction from the mixture; weight = eval / pdf.
    pub fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        if si.wi.z <= 0.0 {
            return None;
        }
        let m = &*self.material;
        let (vi, vw) = m.views.lookup(si.wi);
        let wo = if sample1 < COSINE_FRACTION {
            warp::square_to_cosine_hemisphere(sample2)
        } else {
            // Choose one of the 3 views by its weight, then a triangle of its table.
            let mut u = (sample1 - COSINE_FRACTION) / (1.0 - COSINE_FRACTION);
            let last = (0..3).rev().find(|&k| vw[k] > 0.0).unwrap_or(0);
            let mut k = 0;
            while k < last && (vw[k] == 0.0 || u >= vw[k]) {
                u -= vw[k];
                k += 1;
            }
            let u = (u / vw[k].max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
            let v = vi[k] as usize;
            if !m.table_ok[v] {
                warp::square_to_cosine_hemisphere(sample2)
            } else {
                let nt = m.lights.num_triangles();
                let cdf = &m.tri_cdf[v * nt..(v + 1) * nt];
                let t = cdf.partition_point(|&c| c <= u).min(nt - 1);
                let b = warp::square_to_uniform_triangle(sample2);
                let p = m.lights.triangle_disk(t);
                let (b0, b1, b2) = (1.0 - b.x - b.y, b.x, b.y);
                let x = b0 * p[0][0] + b1 * p[1][0] + b2 * p[2][0];
                let y = b0 * p[0][1] + b1 * p[1][1] + b2 * p[2][1];
                Vec3::new(x, y, (1.0 - x * x - y * y).max(0.0).sqrt())
            }
        };
        if wo.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf_with_views(vi, vw, wo);
        if !(pdf > 0.0) {
            return None;
        }
        let weight = self.eval(si, wo) / pdf;
        let s = BsdfSample {
            wo,
            pdf,
            eta: 1.0,
            sampled: BsdfFlags::GLOSSY_REFLECTION,
        };
        Some((s, weight))
    }
}
