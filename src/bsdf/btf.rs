//! The raw measured BTF as a material (docs/conventions.md): barycentric interpolation over 3 measured views
//! × 3 measured lights, nearest texel, eval = B/π (B is cosine-baked), one-sided.
//!
//! Sampling: the tabulated light sampler of measured BTFs ([`BtfLightSampler`]) with one set of
//! tables per texel cluster ([`super::btf_clusters`]: texels whose light distributions have the
//! same shape), each built from the averaged values of its cluster's texels; a hit samples from
//! its texel's cluster. Where the budget allows no more, one set from the whole material's
//! average.
//!
//! Memory: the material reads the BTF only through `RawBtf::data()` (f16, `[view][light][row][col]
//! [rgb]`) and its dimensions; a 256² × 81 × 81 material is 2.6 GB, so it must be kept once per
//! file (the material holds an `Arc`) and can live in a memory-mapped cache file (`.btfc`) behind the
//! same accessor. Building the tables reads at most 64 × 64 texels per image (and the clustering
//! the images of 16 views of every texel).

use super::Bsdf;
use super::btf_clusters::{MAX_CLUSTERS, TABLE_BUDGET_BYTES, cluster_texels, clusters_within};
use super::btf_sampler::BtfLightSampler;
#[cfg(test)]
use super::btf_sampler::DEFENSIVE_FRACTION;
use super::plugin::BsdfProperties;
use super::{BsdfFlags, BsdfSample, Bxdf};
use crate::btf::directions::DirectionInterp;
use crate::btf::{BtfSource, RawBtf};
use crate::geometry::SurfaceInteraction;
#[cfg(test)]
use crate::math::warp;
use crate::math::{INV_PI, Spectrum, Vec2, Vec3};
use crate::model::BtfModel;
use crate::{Error, Result};
use std::path::Path;
use std::sync::Arc;

/// A loaded BTF with its direction interpolators and sampling tables; shared (`Arc`) by every
/// [`BtfBsdf`] that uses the same file.
pub struct BtfMaterial {
    btf: Arc<RawBtf>,
    views: DirectionInterp,
    /// Light-direction sampling tables, one set per texel cluster (and the light interpolator
    /// they are built on).
    sampler: BtfLightSampler,
    /// Per texel (row-major) its cluster, the sampler's table set; empty when there is one set.
    clusters: Vec<u8>,
}

impl BtfMaterial {
    /// Builds the interpolators and sampling tables of a BTF: up to [`MAX_CLUSTERS`] texel
    /// clusters within [`TABLE_BUDGET_BYTES`].
    pub fn new(btf: Arc<RawBtf>) -> Result<Self> {
        Self::with_clusters(btf, MAX_CLUSTERS, TABLE_BUDGET_BYTES)
    }

    /// [`BtfMaterial::new`] with at most `max_clusters` sets of sampling tables, fewer where
    /// they and the texel index would take more than `budget_bytes` (1: the material-wide
    /// table, whatever the budget).
    pub fn with_clusters(
        btf: Arc<RawBtf>,
        max_clusters: usize,
        budget_bytes: usize,
    ) -> Result<Self> {
        let views = btf
            .views()
            .interpolator()
            .map_err(|e| Error::Invalid(format!("BTF view directions: {e}")))?;
        let lights = btf
            .lights()
            .interpolator()
            .map_err(|e| Error::Invalid(format!("BTF light directions: {e}")))?;
        let per_set = BtfLightSampler::bytes_per_set(btf.views().len(), lights.num_triangles());
        let texels = btf.width() * btf.height();
        let k = clusters_within(budget_bytes, per_set, texels, max_clusters);
        let c = cluster_texels(&btf, k);
        let sampler = BtfLightSampler::with_sets(lights, &btf.lights().dirs, &c.lum, c.k);
        Ok(BtfMaterial {
            btf,
            views,
            sampler,
            clusters: c.index,
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
        let (li, lw) = self.sampler.light_interp().lookup(wo);
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

    /// The light-direction sampler (shared code with the fitted models).
    pub fn sampler(&self) -> &BtfLightSampler {
        &self.sampler
    }

    /// The cluster of texel (column `x`, row `y`): the sampler's table set its hits sample from.
    #[inline]
    pub fn cluster(&self, x: usize, y: usize) -> u32 {
        self.clusters
            .get(y * self.btf.width() + x)
            .map_or(0, |&c| c as u32)
    }

    /// Bytes the sampling tables and the texel index take.
    pub fn sampling_bytes(&self) -> usize {
        self.sampler.table_bytes() + self.clusters.len()
    }

    /// The view-direction interpolator.
    pub fn view_interp(&self) -> &DirectionInterp {
        &self.views
    }
}

/// A summary only: the measured data can be gigabytes.
impl std::fmt::Debug for BtfMaterial {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BtfMaterial")
            .field("views", &self.btf.views().len())
            .field("lights", &self.btf.lights().len())
            .field("width", &self.btf.width())
            .field("height", &self.btf.height())
            .field("sampler", &self.sampler)
            .field("sampling_bytes", &self.sampling_bytes())
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

/// Mitsuba's `btf` plugin (btfpt's own): the measured material `filename` (a file or a
/// `synth:` source), `uv_scale` (texture repeats per unit uv), `model` (raw, lm, plm, plmc, …):
/// a raw [`BtfBsdf`] or a fitted [`super::PlmcBsdf`], as the scene format loads it.
pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Bsdf> {
    let file = p.string_req("filename")?;
    let uv_scale = p.float("uv_scale", 1.0)?;
    let model = p
        .string_opt("model")?
        .map(|m| BtfModel::parse(&m).map_err(|e| p.err(&e.to_string())))
        .transpose()?;
    // Every property checked before a possibly large file is read.
    p.finish()?;
    if uv_scale <= 0.0 {
        return Err(p.err("\"uv_scale\" must be positive"));
    }
    p.measured(&file, uv_scale, model)
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

    /// Texel (column, row) of uv: ⌊frac(u·uv_scale)·W⌋, ⌊frac(v·uv_scale)·H⌋ (docs/conventions.md).
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

    /// The sampling density at texel (`x`, `y`) for the views `vi` with weights `vw`.
    #[inline]
    fn pdf_with_views(&self, (x, y): (usize, usize), vi: [u32; 3], vw: [f32; 3], wo: Vec3) -> f32 {
        let m = &*self.material;
        m.sampler.pdf(m.cluster(x, y), vi, vw, wo)
    }
}

impl Bxdf for BtfBsdf {
    /// Lobes: measured reflection, glossy in general, varying over the surface.
    fn flags(&self) -> BsdfFlags {
        BsdfFlags::GLOSSY_REFLECTION | BsdfFlags::SPATIALLY_VARYING
    }

    /// f · cos θ_o = B/π with wi = view (toward the camera), wo = light; 0 below either horizon.
    #[inline]
    fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        if si.wi.z <= 0.0 || wo.z <= 0.0 {
            return Spectrum::ZERO;
        }
        let (x, y) = self.texel(si.uv);
        self.material.eval_b(si.wi, wo, x, y) * INV_PI
    }

    /// Solid-angle pdf of [`BtfBsdf::sample`].
    #[inline]
    fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        if si.wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let (vi, vw) = self.material.views.lookup(si.wi);
        self.pdf_with_views(self.texel(si.uv), vi, vw, wo)
    }

    /// `(eval, pdf)` sharing the view lookup (what emitter sampling with MIS needs).
    #[inline]
    fn eval_pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> (Spectrum, f32) {
        if si.wi.z <= 0.0 || wo.z <= 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let m = &*self.material;
        let (vi, vw) = m.views.lookup(si.wi);
        let (x, y) = self.texel(si.uv);
        let f = m.eval_b_with_views(vi, vw, wo, x, y) * INV_PI;
        (f, self.pdf_with_views((x, y), vi, vw, wo))
    }

    /// Samples a light direction from the mixture; weight = eval / pdf.
    fn sample(
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
        let (x, y) = self.texel(si.uv);
        let (wo, _) = m.sampler.sample(m.cluster(x, y), vi, vw, sample1, sample2);
        if wo.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf_with_views((x, y), vi, vw, wo);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
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
pub(crate) mod tests {
    use super::*;
    use crate::btf::{DirectionSet, StoredEncoding};
    use crate::math::{Pcg32, frame::from_spherical};
    use std::sync::OnceLock;

    /// A UBO2003-direction BTF of w × h texels with B = `f(view, light, x, y)` (linear).
    pub(crate) fn table(
        w: usize,
        h: usize,
        f: impl Fn(Vec3, Vec3, usize, usize) -> [f32; 3],
    ) -> RawBtf {
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
    pub(crate) fn weight_stats(
        sample: impl Fn(f32, Vec2) -> Option<f32>,
        n: usize,
        seed: u64,
    ) -> (f64, f64) {
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
