//! The raw measured BTF as a material (DESIGN §2): barycentric interpolation over 3 measured views
//! × 3 measured lights, nearest texel, eval = B/π (B is cosine-baked), one-sided.
//!
//! Sampling: at load, per measured view, a piecewise-constant density over the light triangulation
//! on the unit disk, proportional to the texel-averaged luminance of B / cos θ_l (so a Lambertian
//! table gives exactly cosine sampling); for a query the tables of the 3 views of wi are blended
//! with their interpolation weights; the grazing band beyond the measured hull (where the DESIGN
//! rule holds B at its outer-ring values) gets its own uniform component weighted by its estimated
//! share of ∫ B dω; uniform hemisphere sampling is always mixed in (one-sample
//! MIS mixture). The defensive part is uniform rather than cosine because the DESIGN extrapolation
//! holds B constant beyond the outermost measured ring (B does not fall like cos θ there), so
//! only a pdf that stays positive at the horizon bounds the weight: f·cos/pdf ≤ 2 B / DEFENSIVE_FRACTION.
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
use crate::math::{INV_PI, INV_TWO_PI, Spectrum, Vec2, Vec3, warp};
use crate::{Error, Result};
use rayon::prelude::*;
use std::path::Path;
use std::sync::Arc;

/// Probability of the uniform-hemisphere component of the sampling mixture (the defensive part).
pub const DEFENSIVE_FRACTION: f32 = 0.2;
/// Lower bound on cos θ_l when turning B into a density over the disk (avoids blow-up at grazing
/// measured lights of arbitrary direction sets).
const MIN_COS: f32 = 0.05;
/// Texels per axis averaged per image when building the sampling tables.
const TABLE_TEXELS: usize = 64;

/// A loaded BTF with its direction interpolators and sampling tables; shared (`Arc`) by every
/// [`BtfBsdf`] that uses the same file.
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
    /// Per view: probability of the triangle table (vs the grazing band) in the tabulated part.
    table_prob: Vec<f32>,
    /// Grazing band beyond the measured hull: directions with cos θ < `band_cos`, sampled
    /// uniformly in solid angle (B is held constant there by the extrapolation rule); 0 = none.
    band_cos: f32,
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
        let (nv, nl, nt) = (
            btf.views().len(),
            btf.lights().len(),
            lights.num_triangles(),
        );
        let (w, h) = (btf.width(), btf.height());
        let (sx, sy) = (w.div_ceil(TABLE_TEXELS), h.div_ceil(TABLE_TEXELS));
        let data = btf.data();
        let light_cos: Vec<f32> = btf.lights().dirs.iter().map(|d| d.z).collect();
        // Texel-averaged luminance of B per (view, light).
        let lum: Vec<f32> = (0..nv * nl)
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
                let l = luminance(sum / count as f32);
                if l.is_finite() { l.max(0.0) } else { 0.0 }
            })
            .collect();
        // g = B / cos θ_l: the density over the disk that makes the solid-angle pdf ∝ B.
        let g: Vec<f32> = (0..nv * nl)
            .map(|vl| lum[vl] / light_cos[vl % nl].max(MIN_COS))
            .collect();
        let (band_cos, hull) = grazing_band(&lights);
        let band_solid_angle = 2.0 * std::f64::consts::PI * band_cos as f64;
        let mut tri_cdf = vec![0f32; nv * nt];
        let mut tri_density = vec![0f32; nv * nt];
        let mut table_ok = vec![false; nv];
        let mut table_prob = vec![1f32; nv];
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
            // ∫ B dω over the band ≈ mean B of the hull directions × the band's solid angle.
            let band = if hull.is_empty() {
                0.0
            } else {
                let lv = &lum[v * nl..(v + 1) * nl];
                hull.iter().map(|&i| lv[i as usize] as f64).sum::<f64>() / hull.len() as f64
                    * band_solid_angle
            };
            if total + band > 0.0 && (total + band).is_finite() {
                table_ok[v] = true;
                table_prob[v] = (total / (total + band)) as f32;
            }
            if total > 0.0 && total.is_finite() {
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
            table_prob,
            band_cos,
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
        self.eval_b_with_views(vi, vw, wo, x, y)
    }

    #[inline]
    fn eval_b_with_views(
        &self,
        vi: [u32; 3],
        vw: [f32; 3],
        wo: Vec3,
        x: usize,
        y: usize,
    ) -> Spectrum {
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

    /// Samples a light direction from the mixture (uniform defensive part + the blended tabulated
    /// part of the views `vi` with weights `vw`); its density is [`BtfMaterial::light_pdf`].
    /// Shared by the raw material and the fitted models (whose tables are built the same way).
    #[inline]
    pub fn sample_light(&self, vi: [u32; 3], vw: [f32; 3], sample1: f32, sample2: Vec2) -> Vec3 {
        let m = self;
        if sample1 < DEFENSIVE_FRACTION {
            warp::square_to_uniform_hemisphere(sample2)
        } else {
            // Choose one of the 3 views by its weight, then a triangle of its table.
            let mut u = (sample1 - DEFENSIVE_FRACTION) / (1.0 - DEFENSIVE_FRACTION);
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
            } else if u >= m.table_prob[v] {
                // Grazing band, uniform in solid angle.
                let z = m.band_cos * sample2.x;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let (sp, cp) = (2.0 * std::f32::consts::PI * sample2.y).sin_cos();
                Vec3::new(r * cp, r * sp, z)
            } else {
                let u = u / m.table_prob[v];
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
        }
    }

    /// Solid-angle density of [`BtfMaterial::sample_light`] at the upper-hemisphere `wo`.
    #[inline]
    pub fn light_pdf(&self, vi: [u32; 3], vw: [f32; 3], wo: Vec3) -> f32 {
        DEFENSIVE_FRACTION * INV_TWO_PI
            + (1.0 - DEFENSIVE_FRACTION) * self.tabulated_pdf(vi, vw, wo)
    }

    /// The view-direction interpolator (shared with a fitted model on the same direction sets).
    pub fn view_interp(&self) -> &DirectionInterp {
        &self.views
    }

    /// The light-direction interpolator (shared with a fitted model on the same direction sets).
    pub fn light_interp(&self) -> &DirectionInterp {
        &self.lights
    }

    /// [`BtfMaterial::light_pdf`] with `wo` already located in the light triangulation
    /// (`located` = [`DirectionInterp::locate`] of (wo.x, wo.y)): shares that search with eval.
    #[inline]
    pub fn light_pdf_located(
        &self,
        vi: [u32; 3],
        vw: [f32; 3],
        wo: Vec3,
        located: (usize, [f32; 3]),
    ) -> f32 {
        DEFENSIVE_FRACTION * INV_TWO_PI
            + (1.0 - DEFENSIVE_FRACTION) * self.tabulated_pdf_located(vi, vw, wo, located)
    }

    /// Solid-angle density of the tabulated part of the mixture (blended over the 3 views) at
    /// the upper-hemisphere direction `wo`.
    #[inline]
    fn tabulated_pdf(&self, vi: [u32; 3], vw: [f32; 3], wo: Vec3) -> f32 {
        self.tabulated_pdf_located(vi, vw, wo, self.lights.locate([wo.x, wo.y]))
    }

    #[inline]
    fn tabulated_pdf_located(
        &self,
        vi: [u32; 3],
        vw: [f32; 3],
        wo: Vec3,
        (t, bw): (usize, [f32; 3]),
    ) -> f32 {
        let inside = bw[0].min(bw[1]).min(bw[2]) >= -1e-6;
        let in_band = wo.z < self.band_cos;
        let band_pdf = 1.0 / (2.0 * std::f32::consts::PI * self.band_cos.max(f32::MIN_POSITIVE));
        let nt = self.lights.num_triangles();
        let mut d = 0.0;
        for k in 0..3 {
            if vw[k] == 0.0 {
                continue;
            }
            let v = vi[k] as usize;
            d += vw[k]
                * if !self.table_ok[v] {
                    wo.z * INV_PI // black view: its share is cosine sampled
                } else {
                    let p = self.table_prob[v];
                    let tri = if inside {
                        wo.z * self.tri_density[v * nt + t]
                    } else {
                        0.0
                    };
                    let band = if in_band { band_pdf } else { 0.0 };
                    p * tri + (1.0 - p) * band
                };
        }
        d
    }
}

/// The grazing band not covered by the light triangulation: (cos θ of the largest circle around
/// the normal inside the hull, indices of the hull directions). (0, []) when the hull does not
/// contain the normal with some margin (then only the defensive part covers the rim).
fn grazing_band(lights: &DirectionInterp) -> (f32, Vec<u32>) {
    let mut edges = std::collections::HashSet::new();
    for t in 0..lights.num_triangles() {
        let v = lights.triangle(t);
        for e in 0..3 {
            edges.insert((v[e], v[(e + 1) % 3], t, e));
        }
    }
    let directed: std::collections::HashSet<(u32, u32)> =
        edges.iter().map(|&(a, b, _, _)| (a, b)).collect();
    let mut hull = Vec::new();
    let mut r_min = f32::INFINITY;
    for &(a, b, t, e) in &edges {
        if directed.contains(&(b, a)) {
            continue;
        }
        hull.push(a);
        let p = lights.triangle_disk(t);
        let (pa, pb) = (p[e], p[(e + 1) % 3]);
        // Signed distance of the origin to the edge line, > 0 inside (edges are counter-clockwise).
        let d = [pb[0] - pa[0], pb[1] - pa[1]];
        let len = (d[0] * d[0] + d[1] * d[1]).sqrt();
        let dist = (d[0] * (0.0 - pa[1]) - d[1] * (0.0 - pa[0])) / len;
        r_min = r_min.min(dist);
    }
    if r_min.is_nan() || r_min <= 0.5 {
        return (0.0, Vec::new());
    }
    hull.sort_unstable();
    ((1.0 - r_min.min(1.0) * r_min.min(1.0)).sqrt(), hull)
}

/// A summary only: the measured data can be gigabytes.
impl std::fmt::Debug for BtfMaterial {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BtfMaterial")
            .field("views", &self.btf.views().len())
            .field("lights", &self.btf.lights().len())
            .field("width", &self.btf.width())
            .field("height", &self.btf.height())
            .field("light_triangles", &self.lights.num_triangles())
            .field("band_cos", &self.band_cos)
            .finish_non_exhaustive()
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

    /// Texture-space repetitions per unit of uv (the scene's `uv_scale`).
    pub fn uv_scale(&self) -> f32 {
        self.uv_scale
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

    /// `(eval, pdf)` sharing the view lookup (what emitter sampling with MIS needs).
    #[inline]
    pub fn eval_pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> (Spectrum, f32) {
        if si.wi.z <= 0.0 || wo.z <= 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let m = &*self.material;
        let (vi, vw) = m.views.lookup(si.wi);
        let (x, y) = self.texel(si.uv);
        let f = m.eval_b_with_views(vi, vw, wo, x, y) * INV_PI;
        (f, self.pdf_with_views(vi, vw, wo))
    }

    #[inline]
    fn pdf_with_views(&self, vi: [u32; 3], vw: [f32; 3], wo: Vec3) -> f32 {
        self.material.light_pdf(vi, vw, wo)
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
        let wo = m.sample_light(vi, vw, sample1, sample2);
        if wo.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf_with_views(vi, vw, wo);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        let (x, y) = self.texel(si.uv);
        let weight = m.eval_b_with_views(vi, vw, wo, x, y) * (INV_PI / pdf);
        let s = BsdfSample {
            wo,
            pdf,
            eta: 1.0,
            sampled: BsdfFlags::GLOSSY_REFLECTION,
        };
        Some((s, weight))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::btf::{DirectionSet, StoredEncoding};
    use crate::math::{Pcg32, frame::from_spherical};
    use std::sync::OnceLock;

    /// A BTF tabulated from `f(view, light, column, row)` on the UBO2003 directions.
    fn table(w: usize, h: usize, f: impl Fn(Vec3, Vec3, usize, usize) -> [f32; 3]) -> RawBtf {
        let set = DirectionSet::ubo2003();
        let mut data = Vec::with_capacity(81 * 81 * w * h * 3);
        for &v in &set.dirs {
            for &l in &set.dirs {
                for y in 0..h {
                    for x in 0..w {
                        data.extend_from_slice(&f(v, l, x, y));
                    }
                }
            }
        }
        RawBtf::from_f32(set.clone(), set, w, h, StoredEncoding::Linear, &data).unwrap()
    }

    /// A glossy, spatially varying table: B = cos θ_l (0.1 + 3 max(0, r·l)^8) · texel tint.
    fn glossy_fn(v: Vec3, l: Vec3, x: usize, y: usize) -> [f32; 3] {
        let r = Vec3::new(-v.x, -v.y, v.z);
        let lobe = 0.1 + 3.0 * r.dot(l).max(0.0).powi(30);
        let tint = 1.0 + 0.1 * (x + 2 * y) as f32;
        let b = l.z * lobe * tint;
        [b, 0.8 * b, 0.6 * b]
    }

    fn glossy() -> &'static BtfBsdf {
        static M: OnceLock<BtfBsdf> = OnceLock::new();
        M.get_or_init(|| {
            let m = BtfMaterial::new(Arc::new(table(4, 4, glossy_fn))).unwrap();
            BtfBsdf::new(Arc::new(m), 1.0).unwrap()
        })
    }

    fn lambert() -> &'static BtfBsdf {
        static M: OnceLock<BtfBsdf> = OnceLock::new();
        M.get_or_init(|| {
            let m = BtfMaterial::new(Arc::new(table(2, 2, |_, l, _, _| [l.z; 3]))).unwrap();
            BtfBsdf::new(Arc::new(m), 1.0).unwrap()
        })
    }

    fn si(wi: Vec3) -> SurfaceInteraction {
        SurfaceInteraction::for_tests(wi, Vec2::new(0.3, 0.6))
    }

    fn dir(theta_deg: f32, phi_deg: f32) -> Vec3 {
        from_spherical(theta_deg.to_radians(), phi_deg.to_radians())
    }

    #[test]
    fn eval_is_the_table_over_pi_at_measured_directions_and_texels() {
        let b = glossy();
        let btf = b.material().btf();
        let set = DirectionSet::ubo2003();
        for (vi, li, x, y) in [(0, 0, 0, 0), (5, 40, 1, 2), (80, 17, 3, 3), (33, 80, 2, 1)] {
            let mut s = si(set.dirs[vi]);
            s.uv = Vec2::new((x as f32 + 0.5) / 4.0, (y as f32 + 0.5) / 4.0);
            let want = Spectrum::from(btf.texel(vi, li, x, y)) * INV_PI;
            assert_eq!(b.eval(&s, set.dirs[li]), want, "view {vi} light {li}");
        }
        // Texel addressing: frac(u·uv_scale), negative u wraps, u = 1 wraps to column 0.
        assert_eq!(b.texel(Vec2::new(-0.125, 0.99)), (3, 3));
        assert_eq!(b.texel(Vec2::new(1.0, 0.25)), (0, 1));
        let tiled = BtfBsdf::new(b.material().clone(), 2.0).unwrap();
        assert_eq!(tiled.texel(Vec2::new(0.3, 0.55)), (2, 0));
        assert!(BtfBsdf::new(b.material().clone(), f32::NAN).is_err());
        let dbg = format!("{b:?}");
        assert!(dbg.contains("views: 81") && dbg.len() < 400, "{dbg}");
    }

    #[test]
    fn one_sided() {
        let b = glossy();
        let up = dir(30.0, 10.0);
        let down = Vec3::new(up.x, up.y, -up.z);
        assert_eq!(b.eval(&si(up), down), Spectrum::ZERO);
        assert_eq!(b.eval(&si(down), up), Spectrum::ZERO);
        assert_eq!(b.pdf(&si(down), up), 0.0);
        assert_eq!(b.pdf(&si(up), down), 0.0);
        assert!(b.sample(&si(down), 0.5, Vec2::splat(0.5)).is_none());
        assert!(b.eval(&si(up), up).max_element() > 0.0);
    }

    #[test]
    fn sample_weight_and_pdf_are_consistent_with_eval() {
        let b = glossy();
        let mut rng = Pcg32::new(3, 4);
        for _ in 0..2000 {
            let wi = warp::square_to_uniform_hemisphere(rng.next_2d());
            let s = si(wi);
            let Some((smp, weight)) = b.sample(&s, rng.next_f32(), rng.next_2d()) else {
                continue;
            };
            let pdf = b.pdf(&s, smp.wo);
            assert_eq!(b.eval_pdf(&s, smp.wo), (b.eval(&s, smp.wo), pdf));
            assert!((smp.pdf - pdf).abs() <= 1e-4 * pdf, "{} vs {pdf}", smp.pdf);
            let want = b.eval(&s, smp.wo) / pdf;
            assert!((weight - want).length() <= 1e-4 * want.length() + 1e-7);
            // Defensive mixture: weight ≤ 2 B / fraction, B ≤ 3.1 · 1.3 for this table.
            assert!(weight.max_element() <= 2.0 * 3.1 * 1.3 / DEFENSIVE_FRACTION);
        }
    }

    fn test_views() -> Vec<Vec3> {
        vec![
            dir(0.0, 0.0),
            dir(45.0, 20.0),  // a measured view
            dir(37.0, 101.0), // between views
            dir(68.0, 250.0), // between the outer rings
            dir(82.0, 33.0),  // beyond the outermost ring
        ]
    }

    #[test]
    fn chi2_sampling_matches_pdf() {
        use crate::bsdf::chi2::Chi2Test;
        let views = test_views();
        let t = Chi2Test {
            cos_theta_res: 20,
            phi_res: 40,
            sample_count: 200_000,
            test_count: 2 * views.len(),
            ..Default::default()
        };
        for (m, name) in [(glossy(), "glossy"), (lambert(), "lambert")] {
            for &wi in &views {
                let s = si(wi);
                let mut lobe = Pcg32::new(17, 3);
                let out = t.run(
                    |u1, u2| {
                        let s1 = lobe.next_f32();
                        m.sample(&s, s1, Vec2::new(u1, u2)).map(|x| x.0.wo)
                    },
                    |w| m.pdf(&s, w),
                );
                assert!(out.passed, "{name} wi = {wi}: {}", out.message);
                assert!(
                    (out.pdf_integral - 1.0).abs() < 5e-3,
                    "{name} {wi}: {}",
                    out.pdf_integral
                );
            }
        }
    }

    /// ∫ eval dω over the hemisphere by a fine midpoint rule in (cos θ, φ).
    fn albedo_quadrature(b: &BtfBsdf, s: &SurfaceInteraction) -> Spectrum {
        let (nt, np) = (200, 400);
        let mut acc = Spectrum::ZERO;
        for i in 0..nt {
            let c = (i as f32 + 0.5) / nt as f32;
            for j in 0..np {
                let p = (j as f32 + 0.5) / np as f32 * 2.0 * std::f32::consts::PI;
                let st = (1.0 - c * c).sqrt();
                acc += b.eval(s, Vec3::new(st * p.cos(), st * p.sin(), c));
            }
        }
        acc * (2.0 * std::f32::consts::PI / (nt * np) as f32)
    }

    /// Mean and standard error of the sample weights (first channel) with `n` samples.
    fn weight_stats(sample: impl Fn(f32, Vec2) -> Option<f32>, n: usize, seed: u64) -> (f64, f64) {
        let mut rng = Pcg32::new(seed, 5);
        let (mut s1, mut s2) = (0f64, 0f64);
        for _ in 0..n {
            let w = sample(rng.next_f32(), rng.next_2d()).unwrap_or(0.0) as f64;
            s1 += w;
            s2 += w * w;
        }
        let mean = s1 / n as f64;
        let var = (s2 / n as f64 - mean * mean).max(0.0);
        (mean, (var / n as f64).sqrt())
    }

    #[test]
    fn white_lambertian_table_furnace() {
        // B = cos θ_l at the 81 directions: the directional albedo is 1 up to the interpolation
        // error (cos θ interpolated linearly on the disk: below 1 inside the hull, held at
        // cos 75° beyond the outer ring: above 1) — a few percent.
        let b = lambert();
        for wi in test_views() {
            let s = si(wi);
            let quad = albedo_quadrature(b, &s).x as f64;
            let (mean, se) = weight_stats(|u1, u2| b.sample(&s, u1, u2).map(|x| x.1.x), 20_000, 1);
            assert!(
                (mean - quad).abs() < 4.0 * se + 2e-3,
                "IS {mean} ± {se} vs quadrature {quad}"
            );
            assert!((quad - 1.0).abs() < 0.06, "albedo {quad}");
            // Weight spread: uniform sampling would give std ≈ 0.6, cosine sampling an unbounded
            // variance (B is held at cos 75° towards the horizon while the cosine pdf → 0).
            let std = se * (20_000f64).sqrt();
            assert!(std < 0.2, "weight std {std}");
        }
    }

    #[test]
    fn tabulated_sampling_beats_cosine_on_a_glossy_table() {
        let b = glossy();
        for wi in [dir(30.0, 40.0), dir(60.0, 200.0)] {
            let s = si(wi);
            let quad = albedo_quadrature(b, &s).x as f64;
            let n = 20_000;
            let (m_is, se_is) = weight_stats(|u1, u2| b.sample(&s, u1, u2).map(|x| x.1.x), n, 2);
            let (m_cos, se_cos) = weight_stats(
                |_, u2| {
                    let wo = warp::square_to_cosine_hemisphere(u2);
                    let pdf = warp::square_to_cosine_hemisphere_pdf(wo);
                    (pdf > 0.0).then(|| b.eval(&s, wo).x / pdf)
                },
                n,
                3,
            );
            assert!(
                (m_is - quad).abs() < 4.0 * se_is + 2e-3,
                "IS {m_is} ± {se_is} vs {quad}"
            );
            assert!(
                (m_cos - quad).abs() < 4.0 * se_cos + 2e-3,
                "cos {m_cos} ± {se_cos} vs {quad}"
            );
            // Variance ratio of the estimators (same n).
            assert!(
                se_cos > 1.5 * se_is,
                "cosine se {se_cos} vs tabulated {se_is}"
            );
        }
    }
}
