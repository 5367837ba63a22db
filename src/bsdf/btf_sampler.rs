//! The tabulated light-direction sampler of measured BTFs, shared by the raw data and every fitted
//! model (the same density whichever representation is rendered).
//!
//! At load, per measured view, a piecewise-constant density over the light triangulation on the
//! unit disk, proportional to the texel-averaged luminance of B / cos θ_l (so a Lambertian table
//! gives exactly cosine sampling). A sampler may hold several such sets of per-view tables (raw
//! data: one per texel cluster, `bsdf/btf_clusters.rs`), laid out one after the other; every
//! query names its set. For a query the tables of the 3 views of wi are blended with
//! their interpolation weights; the grazing band beyond the measured hull (where the direction
//! rule of docs/conventions.md holds B at its outer-ring values) gets its own uniform component
//! weighted by its estimated share of ∫ B dω; uniform hemisphere sampling is always mixed in
//! (one-sample MIS mixture). The defensive part is uniform rather than cosine because the
//! extrapolation holds B constant beyond the outermost measured ring (B does not fall like cos θ
//! there), so only a pdf that stays positive at the horizon bounds the weight:
//! f·cos/pdf ≤ 2 B / DEFENSIVE_FRACTION.

use crate::btf::directions::DirectionInterp;
use crate::math::distribution::Distribution1D;
use crate::math::simd::approx::sin_cos;
use crate::math::{INV_PI, INV_TWO_PI, Vec2, Vec3, warp};

/// Probability of the uniform-hemisphere component of the sampling mixture (the defensive part).
pub const DEFENSIVE_FRACTION: f32 = 0.2;
/// Lower bound on cos θ_l when turning B into a density over the disk (avoids blow-up at grazing
/// measured lights of arbitrary direction sets).
const MIN_COS: f32 = 0.05;

/// Most queries of one [`BtfLightSampler::sample_batch`] call (a packet batch).
pub const SAMPLE_LANES: usize = 16;

/// The component of the sampling mixture one sample is drawn from.
#[derive(Clone, Copy, Debug)]
enum Part {
    /// The defensive uniform-hemisphere part.
    Uniform,
    /// A black view's share: cosine-weighted hemisphere.
    Cosine,
    /// A triangle of table `table` (set · views + view), chosen by `u` in [0, 1].
    Table { table: u32, u: f32 },
    /// The grazing band beyond the measured hull, uniform in solid angle.
    Band,
}

/// Sets of per-view light tables over one light triangulation, and the mixture sampled from
/// them. The per-table fields are indexed by table = set · views + view.
pub struct BtfLightSampler {
    /// The light directions' triangulation on the unit disk (also the material's light lookup).
    lights: DirectionInterp,
    /// Measured views (tables per set).
    views: usize,
    /// Sets of tables (≥ 1).
    sets: usize,
    /// Per table: triangles chosen ∝ their share of ∫ B/cos θ_l dA; None for a black view
    /// (cosine sampling is used instead) or a view whose energy is all in the grazing band.
    tris: Vec<Option<Distribution1D>>,
    /// Per table: density over disk area of each light triangle, `[table][triangle]` (∫ dA = 1).
    density: Vec<f32>,
    /// Per table: false if the table is empty (black view); cosine sampling is used instead.
    table_ok: Vec<bool>,
    /// Per table: probability of the triangle table (vs the grazing band) in the tabulated part.
    table_prob: Vec<f32>,
    /// Grazing band beyond the measured hull: directions with cos θ < `band_cos`, sampled
    /// uniformly in solid angle (B is held constant there by the extrapolation rule); 0 = none.
    band_cos: f32,
}

impl BtfLightSampler {
    /// Builds one set of tables from `lum`, the texel-averaged luminance of B at every measured
    /// (view, light), `[view][light]`, linear and cosine-baked.
    pub fn new(lights: DirectionInterp, light_dirs: &[Vec3], lum: &[f32]) -> Self {
        Self::with_sets(lights, light_dirs, lum, 1)
    }

    /// Builds `sets` sets of tables (at least 1) from `lum`, `[set][view][light]`: each set's
    /// tables exactly as [`BtfLightSampler::new`] builds them from its part of `lum`.
    pub fn with_sets(
        lights: DirectionInterp,
        light_dirs: &[Vec3],
        lum: &[f32],
        sets: usize,
    ) -> Self {
        let sets = sets.max(1);
        let nl = light_dirs.len();
        let ntab = lum.len().checked_div(nl).unwrap_or(0);
        let nv = ntab / sets;
        let ntab = nv * sets;
        let nt = lights.num_triangles();
        let clean = |l: f32| if l.is_finite() { l.max(0.0) } else { 0.0 };
        let (band_cos, hull) = grazing_band(&lights);
        let band_solid_angle = 2.0 * std::f64::consts::PI * band_cos as f64;
        let mut tris = Vec::with_capacity(ntab);
        let mut density = vec![0f32; ntab * nt];
        let mut table_ok = vec![false; ntab];
        let mut table_prob = vec![1f32; ntab];
        for v in 0..ntab {
            let lv = &lum[v * nl..(v + 1) * nl];
            // g = B / cos θ_l: the density over the disk that makes the solid-angle pdf ∝ B.
            let g = |i: u32| {
                clean(lv[i as usize]) as f64 / light_dirs[i as usize].z.max(MIN_COS) as f64
            };
            let means: Vec<f64> = (0..nt)
                .map(|t| lights.triangle(t).iter().map(|&i| g(i)).sum::<f64>() / 3.0)
                .collect();
            let total: f64 = (0..nt)
                .map(|t| means[t] * lights.triangle_area(t) as f64)
                .sum();
            // ∫ B dω over the band ≈ mean B of the hull directions × the band's solid angle.
            let band = if hull.is_empty() {
                0.0
            } else {
                hull.iter()
                    .map(|&i| clean(lv[i as usize]) as f64)
                    .sum::<f64>()
                    / hull.len() as f64
                    * band_solid_angle
            };
            if total + band > 0.0 && (total + band).is_finite() {
                table_ok[v] = true;
                table_prob[v] = (total / (total + band)) as f32;
            }
            let dist = if total > 0.0 && total.is_finite() {
                for t in 0..nt {
                    density[v * nt + t] = (means[t] / total) as f32;
                }
                Distribution1D::new((0..nt).map(|t| means[t] * lights.triangle_area(t) as f64))
            } else {
                None
            };
            tris.push(dist);
        }
        BtfLightSampler {
            lights,
            views: nv,
            sets,
            tris,
            density,
            table_ok,
            table_prob,
            band_cos,
        }
    }

    /// The light-direction interpolator the tables are built on.
    pub fn light_interp(&self) -> &DirectionInterp {
        &self.lights
    }

    /// cos θ of the inner edge of the grazing band (0: no band).
    pub fn band_cos(&self) -> f32 {
        self.band_cos
    }

    /// Number of table sets (queries name one in `0..sets()`).
    pub fn sets(&self) -> usize {
        self.sets
    }

    /// Bytes one set of tables takes for `views` measured views over `triangles` light
    /// triangles: per view a [`Distribution1D`] (its cdf, lower edges, probabilities and
    /// 16-byte guide entries: 28 bytes per triangle, and its header), the triangle densities
    /// (4 bytes per triangle), the table probability and flag.
    pub fn bytes_per_set(views: usize, triangles: usize) -> usize {
        let per_view = triangles * (3 * 4 + 16 + 4)
            + std::mem::size_of::<Option<Distribution1D>>()
            + std::mem::size_of::<f32>()
            + std::mem::size_of::<bool>();
        views * per_view
    }

    /// Bytes the tables of every set take ([`BtfLightSampler::bytes_per_set`] × sets).
    pub fn table_bytes(&self) -> usize {
        self.sets * Self::bytes_per_set(self.views, self.lights.num_triangles())
    }

    /// Samples a light direction from the mixture (uniform defensive part + the blended tabulated
    /// part of table set `set`'s views `vi` with weights `vw`); its density is
    /// [`BtfLightSampler::pdf`]. Also returns the light triangle when the direction was drawn
    /// inside one (so the caller's eval and pdf need not search for it again).
    #[inline]
    pub fn sample(
        &self,
        set: u32,
        vi: [u32; 3],
        vw: [f32; 3],
        sample1: f32,
        sample2: Vec2,
    ) -> (Vec3, Option<usize>) {
        let part = self.choose(set, vi, vw, sample1);
        self.place(part, self.triangle_of(part), sample2)
    }

    /// [`BtfLightSampler::sample`] of up to [`SAMPLE_LANES`] queries (query q: table set
    /// `set[q]`, views `vi[q]` with weights `vw[q]`, numbers `sample1[q]`, `sample2[q]`) into
    /// `out[q]`, each the same bits. Stage by stage over the queries: the components first, then every triangle-table
    /// search, then the directions, so the table loads of different queries (a chain of
    /// dependent cache misses each) overlap instead of running one query after the other.
    #[inline]
    pub fn sample_batch(
        &self,
        set: &[u32],
        vi: &[[u32; 3]],
        vw: &[[f32; 3]],
        sample1: &[f32],
        sample2: &[Vec2],
        out: &mut [(Vec3, Option<usize>)],
    ) {
        let n = out.len();
        assert!(n <= SAMPLE_LANES);
        assert!(set.len() == n && vi.len() == n && vw.len() == n);
        assert!(sample1.len() == n && sample2.len() == n);
        let mut part = [Part::Uniform; SAMPLE_LANES];
        for q in 0..n {
            part[q] = self.choose(set[q], vi[q], vw[q], sample1[q]);
        }
        let mut tri = [0usize; SAMPLE_LANES];
        for q in 0..n {
            tri[q] = self.triangle_of(part[q]);
        }
        for q in 0..n {
            out[q] = self.place(part[q], tri[q], sample2[q]);
        }
    }

    /// The mixture component `sample1` picks for table set `set`'s views `vi` with weights `vw`
    /// (a set past the last is the last).
    #[inline(always)]
    fn choose(&self, set: u32, vi: [u32; 3], vw: [f32; 3], sample1: f32) -> Part {
        if sample1 < DEFENSIVE_FRACTION {
            return Part::Uniform;
        }
        // Choose one of the 3 views by its weight, then a triangle of its table.
        let mut u = (sample1 - DEFENSIVE_FRACTION) / (1.0 - DEFENSIVE_FRACTION);
        let last = (0..3).rev().find(|&k| vw[k] > 0.0).unwrap_or(0);
        let mut k = 0;
        while k < last && (vw[k] == 0.0 || u >= vw[k]) {
            u -= vw[k];
            k += 1;
        }
        let u = (u / vw[k].max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
        let v = self.table(set, vi[k]);
        if !self.table_ok[v] {
            return Part::Cosine;
        }
        match &self.tris[v] {
            Some(_) if u < self.table_prob[v] => Part::Table {
                table: v as u32,
                u: u / self.table_prob[v],
            },
            _ => Part::Band,
        }
    }

    /// The table of view `view` in set `set` (a set past the last is the last).
    #[inline(always)]
    fn table(&self, set: u32, view: u32) -> usize {
        (set as usize).min(self.sets - 1) * self.views + view as usize
    }

    /// The light triangle of a [`Part::Table`] sample (0 for the other parts).
    #[inline(always)]
    fn triangle_of(&self, part: Part) -> usize {
        match part {
            Part::Table { table, u } => match &self.tris[table as usize] {
                Some(tris) => tris.sample_bin(u),
                None => 0,
            },
            _ => 0,
        }
    }

    /// The direction of a sample of component `part` (drawn in light triangle `t` for
    /// [`Part::Table`]) for the numbers `sample2`.
    #[inline(always)]
    fn place(&self, part: Part, t: usize, sample2: Vec2) -> (Vec3, Option<usize>) {
        match part {
            Part::Uniform => (warp::square_to_uniform_hemisphere(sample2), None),
            Part::Cosine => (warp::square_to_cosine_hemisphere(sample2), None),
            Part::Table { .. } => {
                let b = warp::square_to_uniform_triangle(sample2);
                let p = self.lights.triangle_disk(t);
                let (b0, b1, b2) = (1.0 - b.x - b.y, b.x, b.y);
                let x = b0 * p[0][0] + b1 * p[1][0] + b2 * p[2][0];
                let y = b0 * p[0][1] + b1 * p[1][1] + b2 * p[2][1];
                (
                    Vec3::new(x, y, (1.0 - x * x - y * y).max(0.0).sqrt()),
                    Some(t),
                )
            }
            Part::Band => {
                // Grazing band, uniform in solid angle.
                let z = self.band_cos * sample2.x;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let (sp, cp) = sin_cos(2.0 * std::f32::consts::PI * sample2.y);
                (Vec3::new(r * cp, r * sp, z), None)
            }
        }
    }

    /// Solid-angle density of [`BtfLightSampler::sample`] (table set `set`) at the
    /// upper-hemisphere `wo`.
    #[inline]
    pub fn pdf(&self, set: u32, vi: [u32; 3], vw: [f32; 3], wo: Vec3) -> f32 {
        self.pdf_located(set, vi, vw, wo, self.lights.locate([wo.x, wo.y]))
    }

    /// [`BtfLightSampler::pdf`] with `wo` already located in the light triangulation
    /// (`located` = [`DirectionInterp::locate`] of (wo.x, wo.y)): shares that search with eval.
    #[inline]
    pub fn pdf_located(
        &self,
        set: u32,
        vi: [u32; 3],
        vw: [f32; 3],
        wo: Vec3,
        located: (usize, [f32; 3]),
    ) -> f32 {
        DEFENSIVE_FRACTION * INV_TWO_PI
            + (1.0 - DEFENSIVE_FRACTION) * self.tabulated_pdf(set, vi, vw, wo, located)
    }

    /// Solid-angle density of the tabulated part of the mixture (blended over the 3 views).
    #[inline]
    fn tabulated_pdf(
        &self,
        set: u32,
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
            let v = self.table(set, vi[k]);
            d += vw[k]
                * if !self.table_ok[v] {
                    wo.z * INV_PI // black view: its share is cosine sampled
                } else {
                    let p = self.table_prob[v];
                    let tri = if inside {
                        wo.z * self.density[v * nt + t]
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

/// A summary only.
impl std::fmt::Debug for BtfLightSampler {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BtfLightSampler")
            .field("views", &self.views)
            .field("sets", &self.sets)
            .field("light_triangles", &self.lights.num_triangles())
            .field("band_cos", &self.band_cos)
            .finish_non_exhaustive()
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
