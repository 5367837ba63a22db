//! Measurement direction sets (UBO2003, UBO2014, arbitrary lists) in the local shading frame.

use super::delaunay;
use crate::math::Vec3;
use crate::math::frame::from_spherical;
use crate::{Error, Result};

/// An ordered list of measured directions on the upper hemisphere (index order = file order).
#[derive(Clone, Debug, PartialEq)]
pub struct DirectionSet {
    /// (θ, φ) in degrees, as named in the data files.
    pub angles_deg: Vec<(f32, f32)>,
    /// Unit vectors of `angles_deg` (z = normal, φ from s toward t).
    pub dirs: Vec<Vec3>,
}

impl DirectionSet {
    /// A set from (θ, φ) pairs in degrees.
    pub fn from_angles_deg(angles_deg: Vec<(f32, f32)>) -> Self {
        let dirs = angles_deg
            .iter()
            .map(|&(t, p)| from_spherical(t.to_radians(), p.to_radians()))
            .collect();
        DirectionSet { angles_deg, dirs }
    }

    /// Rings of constant θ with evenly spaced azimuths: (θ°, count, φ offset°) per ring.
    pub fn from_rings(rings: &[(f32, usize, f32)]) -> Self {
        let mut angles = Vec::new();
        for &(theta, n, offset) in rings {
            for k in 0..n {
                angles.push((theta, offset + 360.0 * k as f32 / n as f32));
            }
        }
        Self::from_angles_deg(angles)
    }

    /// The 81 directions of the Bonn UBO2003 database, in index order (docs/formats.md).
    pub fn ubo2003() -> Self {
        Self::from_rings(&[
            (0.0, 1, 0.0),
            (15.0, 6, 0.0),
            (30.0, 12, 0.0),
            (45.0, 18, 0.0),
            (60.0, 20, 0.0),
            (75.0, 24, 0.0),
        ])
    }

    /// The 151 directions of the Bonn UBO2014 database.
    pub fn ubo2014() -> Self {
        Self::from_rings(&[
            (0.0, 1, 0.0),
            (11.0, 6, 15.0),
            (23.5, 12, 0.0),
            (30.0, 12, 15.0),
            (37.5, 12, 0.0),
            (45.0, 18, 0.0),
            (52.5, 18, 7.5),
            (60.0, 24, 0.0),
            (67.5, 24, 7.5),
            (75.0, 24, 0.0),
        ])
    }

    /// Number of directions.
    pub fn len(&self) -> usize {
        self.dirs.len()
    }

    /// True if the set has no directions.
    pub fn is_empty(&self) -> bool {
        self.dirs.is_empty()
    }

    /// The barycentric interpolator over this set (docs/conventions.md, "Direction interpolation"): Delaunay triangulation of the
    /// directions projected to the unit disk plus a point-location grid. Built once at load.
    /// Errors if the set has fewer than 3 distinct directions, all on one plane through the
    /// normal, or a direction below the horizon.
    pub fn interpolator(&self) -> Result<DirectionInterp> {
        DirectionInterp::new(self)
    }
}

/// Candidates per cell that `locate16` tests lane-wise (about 98 % of UBO2003 directions and
/// 95 % of UBO2014's fall in cells with at most 4).
pub(super) const CANDS: usize = 4;
/// Marks a cell of `DirectionInterp::cands` with more than [`CANDS`] candidates.
pub(super) const NO_CANDS: u16 = u16::MAX;

/// Refinement factor per axis from the coarse candidate grid to the lookup grid.
const REFINE: u32 = 3;

/// Precomputed geometry of one triangle of the disk triangulation (one cache line).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct TriGeom {
    /// Vertex positions on the disk: a, b, c.
    p: [[f32; 2]; 3],
    /// Edge vectors c − b, a − c, b − a (opposite a, b, c).
    e: [[f32; 2]; 3],
    /// 1 / (2 · signed area).
    inv_area2: f32,
    /// Indices into the direction set.
    v: [u32; 3],
}

// `locate16` gathers the fields of a record by word offset: p at 0, e at 6, 1/(2A) at 12.
const _: () = assert!(std::mem::size_of::<TriGeom>() == 64);

impl TriGeom {
    /// Unclamped barycentric weights of `q`. Weight i vanishes exactly (in floating point) at the
    /// other two vertices, so a query at a measured direction gets weights exactly (1, 0, 0).
    #[inline(always)]
    fn weights(&self, q: [f32; 2]) -> [f32; 3] {
        let w = |e: [f32; 2], o: [f32; 2]| e[0] * (q[1] - o[1]) - e[1] * (q[0] - o[0]);
        // weight of a: (c − b) × (q − b); of b: (a − c) × (q − c); of c: (b − a) × (q − a).
        [
            w(self.e[0], self.p[1]) * self.inv_area2,
            w(self.e[1], self.p[2]) * self.inv_area2,
            w(self.e[2], self.p[0]) * self.inv_area2,
        ]
    }
}

/// Barycentric interpolation over a measured direction set: for a query direction, the 3 measured
/// directions and their weights (≥ 0, summing to 1) by the rule of docs/conventions.md — of all triangles of
/// the Delaunay triangulation on the disk (x, y) = sin θ (cos φ, sin φ), take the one whose
/// smallest barycentric weight is largest (the containing one inside the hull), clamp negative
/// weights to 0 and renormalise (which extrapolates beyond the outermost ring).
///
/// Beyond the hull the rule is discontinuous where the winning triangle changes: just outside the
/// 75° ring of UBO2003, at φ between two outer directions, it switches from blending the two outer
/// directions of the hull edge to the single nearer one, and in UBO2014 it can even pick an inner
/// 67.5° direction at θ ≈ 80°. Inside the hull it is continuous and reproduces linear functions.
///
/// Lookup is O(1): a uniform grid over [−1, 1]² lists per cell every triangle that can win the
/// rule somewhere in the cell (bounds of the concave min-weight function over the cell's corners),
/// so a query tests a handful of triangles and never allocates. The grid is fine (about 9 cells
/// per triangle edge length) so that most cells hold a single candidate, which is returned without
/// any test.
#[derive(Clone, Debug)]
pub struct DirectionInterp {
    pub(super) tris: Vec<TriGeom>,
    /// Cells per side of the grid over [−1, 1]².
    pub(super) grid: u32,
    /// Per cell, one small load for the common case: `(t << 1) | 1` if triangle t (< 2^15) is
    /// the cell's only candidate, else `0` (look in `cell_start`). u16 keeps the table L1-sized.
    /// One pad entry (0) after the grid² cells: `locate16` gathers 4 bytes per cell.
    pub(super) cells: Vec<u16>,
    /// Candidate lists: triangles of cell k are `cell_tris[cell_start[k]..cell_start[k + 1]]`.
    cell_start: Vec<u32>,
    cell_tris: Vec<u32>,
    /// Per cell, for `locate16`: its first [`CANDS`] candidates in search order, padded with the
    /// first (a repeat never changes the search's answer); `[NO_CANDS; CANDS]` if the cell has
    /// more candidates (or a triangle index ≥ 2^16), which `locate16` leaves to the scalar search.
    pub(super) cands: Vec<[u16; CANDS]>,
    /// Number of directions in the set.
    n_dirs: usize,
    /// `simd::isa()`'s level: `locate16` runs its AVX-512 kernel at `Avx512` (the CPU has
    /// AVX-512F), its AVX2 kernel at `Avx2`, else the scalar search per lane.
    pub(super) level: crate::math::simd::Level,
}

impl DirectionInterp {
    fn new(set: &DirectionSet) -> Result<Self> {
        if let Some(i) = set.dirs.iter().position(|d| d.z.is_nan() || d.z < -1e-6) {
            return Err(Error::Invalid(format!(
                "direction {i} (θ = {}°) is below the horizon",
                set.angles_deg[i].0
            )));
        }
        let pts32: Vec<[f32; 2]> = set.dirs.iter().map(|d| [d.x, d.y]).collect();
        let pts64: Vec<[f64; 2]> = pts32.iter().map(|p| [p[0] as f64, p[1] as f64]).collect();
        let tri_idx = delaunay::triangulate(&pts64)
            .map_err(|m| Error::Invalid(format!("direction set: {m}")))?;
        let tris: Vec<TriGeom> = tri_idx
            .iter()
            .map(|&v| {
                let p = v.map(|i| pts32[i as usize]);
                let sub = |a: [f32; 2], b: [f32; 2]| [a[0] - b[0], a[1] - b[1]];
                let area2 = delaunay::orient(
                    pts64[v[0] as usize],
                    pts64[v[1] as usize],
                    pts64[v[2] as usize],
                );
                TriGeom {
                    p,
                    e: [sub(p[2], p[1]), sub(p[0], p[2]), sub(p[1], p[0])],
                    inv_area2: (1.0 / area2) as f32,
                    v,
                }
            })
            .collect();
        // A coarse grid tested against every triangle, refined REFINE× per axis testing only the
        // parent cell's candidates (a triangle that can win somewhere in a sub-cell can win
        // somewhere in its parent): cells small enough that most hold a single candidate.
        let coarse = ((3.0 * (tris.len() as f64).sqrt()).round() as u32).clamp(8, 64);
        let all: Vec<u32> = (0..tris.len() as u32).collect();
        let (cs, ct) = build_grid(&tris, coarse, |_, _| &all);
        let grid = coarse * REFINE;
        let (cell_start, cell_tris) = build_grid(&tris, grid, |cx, cy| {
            let k = ((cy / REFINE) * coarse + cx / REFINE) as usize;
            &ct[cs[k] as usize..cs[k + 1] as usize]
        });
        let cells = cell_start
            .windows(2)
            .map(|r| match cell_tris[r[0] as usize..r[1] as usize] {
                [t] if t < 1 << 15 => ((t << 1) | 1) as u16,
                _ => 0,
            })
            .chain([0])
            .collect();
        let cands = cell_start
            .windows(2)
            .map(|r| match &cell_tris[r[0] as usize..r[1] as usize] {
                c if !c.is_empty()
                    && c.len() <= CANDS
                    && c.iter().all(|&t| t < NO_CANDS as u32) =>
                {
                    std::array::from_fn(|j| c.get(j).copied().unwrap_or(c[0]) as u16)
                }
                _ => [NO_CANDS; CANDS],
            })
            .collect();
        Ok(DirectionInterp {
            tris,
            grid,
            cells,
            cell_start,
            cell_tris,
            cands,
            n_dirs: set.len(),
            level: crate::math::simd::isa().level(),
        })
    }

    /// Number of directions of the underlying set.
    pub fn len(&self) -> usize {
        self.n_dirs
    }

    /// True if the set is empty (never, for a built interpolator).
    pub fn is_empty(&self) -> bool {
        self.n_dirs == 0
    }

    /// Number of triangles of the triangulation.
    pub fn num_triangles(&self) -> usize {
        self.tris.len()
    }

    /// Direction indices of triangle `t`, counter-clockwise on the disk.
    pub fn triangle(&self, t: usize) -> [u32; 3] {
        self.tris[t].v
    }

    /// Vertex positions of triangle `t` on the unit disk (x, y) = sin θ (cos φ, sin φ).
    pub fn triangle_disk(&self, t: usize) -> [[f32; 2]; 3] {
        self.tris[t].p
    }

    /// Area of triangle `t` on the unit disk (the disk has area π).
    pub fn triangle_area(&self, t: usize) -> f32 {
        0.5 / self.tris[t].inv_area2
    }

    /// Unclamped barycentric weights of the disk point `q` in triangle `t` (what
    /// [`DirectionInterp::locate`] returns when it picks `t`): for a point already known to lie
    /// in `t`, e.g. one sampled inside it, without the grid search.
    #[inline]
    pub fn triangle_weights(&self, t: usize, q: [f32; 2]) -> [f32; 3] {
        self.tris[t].weights(q)
    }

    /// The lookup-grid cell of the disk point `q` (points outside [−1, 1]² and NaN: the
    /// nearest edge cell, resp. cell 0 of that axis).
    #[inline(always)]
    pub(super) fn cell_of(&self, q: [f32; 2]) -> usize {
        let g = self.grid as f32;
        let cx = (((q[0] + 1.0) * 0.5 * g) as i32).clamp(0, self.grid as i32 - 1) as u32;
        let cy = (((q[1] + 1.0) * 0.5 * g) as i32).clamp(0, self.grid as i32 - 1) as u32;
        (cy * self.grid + cx) as usize
    }

    /// The triangle chosen by the docs/conventions.md rule for the disk point `q`, with its unclamped
    /// barycentric weights (all ≥ 0 iff `q` is inside the hull, up to rounding).
    #[inline]
    pub fn locate(&self, q: [f32; 2]) -> (usize, [f32; 3]) {
        let cell = self.cell_of(q);
        let single = self.cells[cell] as usize;
        if single & 1 == 1 {
            // The only triangle that wins anywhere in this cell (most cells of the fine grid).
            let t = single >> 1;
            return (t, self.tris[t].weights(q));
        }
        let (s, e) = (
            self.cell_start[cell] as usize,
            self.cell_start[cell + 1] as usize,
        );
        let mut best_t = self.cell_tris[s] as usize;
        let mut best_w = self.tris[best_t].weights(q);
        let mut best_min = best_w[0].min(best_w[1]).min(best_w[2]);
        if best_min >= 0.0 {
            return (best_t, best_w);
        }
        for &t in &self.cell_tris[s + 1..e] {
            let w = self.tris[t as usize].weights(q);
            let m = w[0].min(w[1]).min(w[2]);
            if m > best_min {
                best_t = t as usize;
                best_w = w;
                best_min = m;
                if m >= 0.0 {
                    break; // inside this triangle: no other can do better
                }
            }
        }
        (best_t, best_w)
    }

    /// Interpolation indices and weights (≥ 0, sum 1) for a unit direction in the local frame
    /// (z = normal); only x and y are used, so any upper-hemisphere direction is valid.
    #[inline]
    pub fn lookup(&self, dir: Vec3) -> ([u32; 3], [f32; 3]) {
        let (t, w) = self.locate([dir.x, dir.y]);
        self.interpolation(t, w)
    }

    /// Interpolation indices and weights from a [`DirectionInterp::locate`] result: negative
    /// weights clamped to 0, renormalised (what [`DirectionInterp::lookup`] returns).
    #[inline]
    pub fn interpolation(&self, t: usize, w: [f32; 3]) -> ([u32; 3], [f32; 3]) {
        let w = w.map(|x| x.max(0.0));
        let inv = 1.0 / (w[0] + w[1] + w[2]);
        (self.tris[t].v, w.map(|x| x * inv))
    }
}

/// Candidate triangles per grid cell: every triangle whose upper bound of the smallest weight over
/// the cell reaches the best lower bound of any triangle over the cell. Exact reasoning: each weight
/// is affine, so min-weight is concave; its minimum over a box is at a corner (lower bound), and
/// the minimum over weights of each weight's corner maximum bounds it from above.
/// `candidates(cx, cy)` lists the triangles that may be kept for cell (cx, cy).
fn build_grid<'a>(
    tris: &[TriGeom],
    grid: u32,
    candidates: impl Fn(u32, u32) -> &'a [u32],
) -> (Vec<u32>, Vec<u32>) {
    let mut cell_start = Vec::with_capacity((grid * grid + 1) as usize);
    let mut cell_tris = Vec::new();
    let mut lo = vec![0f32; tris.len()];
    let mut hi = vec![0f32; tris.len()];
    let step = 2.0 / grid as f64;
    cell_start.push(0u32);
    for cy in 0..grid {
        for cx in 0..grid {
            let (x0, y0) = (-1.0 + cx as f64 * step, -1.0 + cy as f64 * step);
            let corners = [
                [x0, y0],
                [x0 + step, y0],
                [x0, y0 + step],
                [x0 + step, y0 + step],
            ];
            let mut best_lo = f32::NEG_INFINITY;
            let cand = candidates(cx, cy);
            for &t in cand {
                let (t, tri) = (t as usize, &tris[t as usize]);
                let mut wmax = [f32::NEG_INFINITY; 3];
                let mut mlo = f32::INFINITY;
                for c in corners {
                    let w = tri.weights([c[0] as f32, c[1] as f32]);
                    for k in 0..3 {
                        wmax[k] = wmax[k].max(w[k]);
                    }
                    mlo = mlo.min(w[0].min(w[1]).min(w[2]));
                }
                lo[t] = mlo;
                hi[t] = wmax[0].min(wmax[1]).min(wmax[2]);
                best_lo = best_lo.max(mlo);
            }
            // Margin for rounding in the f32 weights.
            let cut = best_lo - 1e-4 * (1.0 + best_lo.abs());
            let first = cell_tris.len();
            cell_tris.extend(cand.iter().copied().filter(|&t| hi[t as usize] >= cut));
            // Most promising first (largest lower bound), so the early exit triggers at once.
            cell_tris[first..].sort_by(|&a, &b| lo[b as usize].total_cmp(&lo[a as usize]));
            cell_start.push(cell_tris.len() as u32);
        }
    }
    (cell_start, cell_tris)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standard_sets_have_the_documented_sizes_and_order() {
        let s = DirectionSet::ubo2003();
        assert_eq!(s.len(), 81);
        assert_eq!(s.angles_deg[0], (0.0, 0.0));
        assert_eq!(s.angles_deg[2], (15.0, 60.0));
        assert_eq!(s.angles_deg[80], (75.0, 345.0));
        assert_eq!(DirectionSet::ubo2014().len(), 151);
        assert_eq!(DirectionSet::ubo2014().angles_deg[1], (11.0, 15.0));
    }
}

#[cfg(test)]
mod interp_tests {
    use super::*;
    use proptest::prelude::*;

    /// Brute force of the docs/conventions.md rule over all triangles: (best smallest weight, clamped weights).
    fn brute(ip: &DirectionInterp, q: [f32; 2]) -> (f32, [u32; 3], [f32; 3]) {
        let mut best = (f32::NEG_INFINITY, [0u32; 3], [0f32; 3]);
        for tri in &ip.tris {
            let w = tri.weights(q);
            let m = w[0].min(w[1]).min(w[2]);
            if m > best.0 {
                best = (m, tri.v, w);
            }
        }
        let w = best.2.map(|x| x.max(0.0));
        let s = w[0] + w[1] + w[2];
        (best.0, best.1, w.map(|x| x / s))
    }

    fn interp(f: &[f32], (idx, w): ([u32; 3], [f32; 3])) -> f32 {
        (0..3).map(|k| w[k] * f[idx[k] as usize]).sum()
    }

    /// A smooth test function of the direction.
    fn smooth(d: Vec3) -> f32 {
        (3.0 * d.x).sin() + (2.0 * d.y).cos() * d.z + 0.5 * d.x * d.y
    }

    fn dir(theta_deg: f32, phi_deg: f32) -> Vec3 {
        from_spherical(theta_deg.to_radians(), phi_deg.to_radians())
    }

    /// UBO2003 and UBO2014 with their interpolators, built once for all tests.
    fn standard() -> &'static [(DirectionSet, DirectionInterp)] {
        static SETS: std::sync::OnceLock<Vec<(DirectionSet, DirectionInterp)>> =
            std::sync::OnceLock::new();
        SETS.get_or_init(|| {
            [DirectionSet::ubo2003(), DirectionSet::ubo2014()]
                .into_iter()
                .map(|s| {
                    let ip = s.interpolator().unwrap();
                    (s, ip)
                })
                .collect()
        })
    }

    /// Random sets of 3..40 directions with θ ≤ 85°.
    fn arbitrary_set() -> impl Strategy<Value = DirectionSet> {
        proptest::collection::vec((0.0f32..85.0, 0.0f32..360.0), 3..40)
            .prop_map(DirectionSet::from_angles_deg)
    }

    #[test]
    fn standard_sets_triangulate_canonically() {
        for (s, ip) in standard() {
            let pts: Vec<[f64; 2]> = s.dirs.iter().map(|d| [d.x as f64, d.y as f64]).collect();
            let tris: Vec<[u32; 3]> = (0..ip.num_triangles()).map(|t| ip.triangle(t)).collect();
            super::delaunay::tests_support::check(&pts, &tris);
            // Euler: a triangulation of n points with h on the hull has 2n − h − 2 triangles.
            let h = s
                .angles_deg
                .iter()
                .filter(|a| a.0 == s.angles_deg.last().unwrap().0)
                .count();
            assert_eq!(ip.num_triangles(), 2 * s.len() - h - 2);
            let total: f32 = (0..ip.num_triangles()).map(|t| ip.triangle_area(t)).sum();
            assert!(total > 0.0 && total < std::f32::consts::PI);
        }
    }

    #[test]
    fn exact_at_measured_directions() {
        for (s, ip) in standard() {
            for (i, &d) in s.dirs.iter().enumerate() {
                let (idx, w) = ip.lookup(d);
                let k = idx.iter().position(|&j| j as usize == i).unwrap();
                assert_eq!(w[k], 1.0, "direction {i}: {idx:?} {w:?}");
            }
        }
    }

    #[test]
    fn invalid_sets_are_errors() {
        let below = DirectionSet::from_angles_deg(vec![(0.0, 0.0), (30.0, 0.0), (120.0, 90.0)]);
        assert!(below.interpolator().is_err());
        let dup = DirectionSet::from_angles_deg(vec![(0.0, 0.0), (0.0, 90.0), (30.0, 90.0)]);
        assert!(dup.interpolator().is_err());
        let plane = DirectionSet::from_angles_deg(vec![(10.0, 0.0), (30.0, 0.0), (50.0, 180.0)]);
        assert!(plane.interpolator().is_err());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn lookup_matches_brute_force_rule(theta in 0.0f32..90.0, phi in 0.0f32..360.0) {
            for (s, ip) in standard() {
                let f: Vec<f32> = s.dirs.iter().map(|&d| smooth(d)).collect();
                let d = dir(theta, phi);
                let (idx, w) = ip.lookup(d);
                prop_assert!(w.iter().all(|&x| x >= 0.0));
                prop_assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
                let (_, bidx, bw) = brute(ip, [d.x, d.y]);
                prop_assert!((interp(&f, (idx, w)) - interp(&f, (bidx, bw))).abs() < 1e-5);
            }
        }

        #[test]
        fn linear_precision_and_continuity_inside_hull(
            // The 24-gon hull of the 75° rings reaches down to θ = asin(sin 75° cos 7.5°) = 73.25°.
            theta in 0.0f32..73.0, phi in 0.0f32..360.0, dt in -1.0f32..1.0, dp in -1.0f32..1.0
        ) {
            for (s, ip) in standard() {
                // Linear functions of the disk position are reproduced exactly inside the hull.
                let lin = |d: Vec3| 0.3 + 2.0 * d.x - 1.5 * d.y;
                let fl: Vec<f32> = s.dirs.iter().map(|&d| lin(d)).collect();
                let d = dir(theta, phi);
                prop_assert!((interp(&fl, ip.lookup(d)) - lin(d)).abs() < 1e-5);
                // Nearby queries (1e-3 rad apart) give nearby values of a smooth function.
                let f: Vec<f32> = s.dirs.iter().map(|&d| smooth(d)).collect();
                let e = dir(theta + dt * 0.0573, phi + dp * 0.0573);
                let gap = (interp(&f, ip.lookup(d)) - interp(&f, ip.lookup(e))).abs();
                prop_assert!(gap <= 10.0 * (d - e).length() + 1e-5, "gap {gap}");
            }
        }

        #[test]
        fn arbitrary_sets(set in arbitrary_set(), theta in 0.0f32..90.0, phi in 0.0f32..360.0) {
            let ip = match set.interpolator() {
                Ok(ip) => ip,
                // Random sets are degenerate (near-duplicate) only by rare accident.
                Err(e) => { prop_assert!(e.to_string().contains("coincide"), "{e}"); return Ok(()); }
            };
            let pts: Vec<[f64; 2]> = set.dirs.iter().map(|d| [d.x as f64, d.y as f64]).collect();
            let tris: Vec<[u32; 3]> = (0..ip.num_triangles()).map(|t| ip.triangle(t)).collect();
            super::delaunay::tests_support::check(&pts, &tris);
            let f: Vec<f32> = set.dirs.iter().map(|&d| smooth(d)).collect();
            let d = dir(theta, phi);
            let (idx, w) = ip.lookup(d);
            prop_assert!(w.iter().all(|&x| x >= 0.0));
            prop_assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
            let (_, bidx, bw) = brute(&ip, [d.x, d.y]);
            prop_assert!((interp(&f, (idx, w)) - interp(&f, (bidx, bw))).abs() < 1e-5);
            for (i, &m) in set.dirs.iter().enumerate() {
                let (idx, w) = ip.lookup(m);
                let k = idx.iter().position(|&j| j as usize == i);
                prop_assert!(k.is_some_and(|k| w[k] == 1.0), "direction {i}: {idx:?} {w:?}");
            }
        }
    }

    #[test]
    fn grid_candidate_lists_are_short() {
        // Performance guard: the pruned candidate lists of cells inside the disk stay small.
        for (_, ip) in standard() {
            let g = ip.grid as usize;
            let (mut total, mut cells, mut longest) = (0usize, 0usize, 0usize);
            for cy in 0..g {
                for cx in 0..g {
                    let x = -1.0 + (cx as f32 + 0.5) * 2.0 / g as f32;
                    let y = -1.0 + (cy as f32 + 0.5) * 2.0 / g as f32;
                    if x * x + y * y <= 1.0 {
                        let k = cy * g + cx;
                        let n = (ip.cell_start[k + 1] - ip.cell_start[k]) as usize;
                        total += n;
                        cells += 1;
                        longest = longest.max(n);
                    }
                }
            }
            let mean = total as f32 / cells as f32;
            // Most disk cells hold one candidate: the lookup's test-free fast path.
            let single = (0..g * g)
                .filter(|&k| ip.cell_start[k + 1] - ip.cell_start[k] == 1)
                .count();
            assert!(single as f32 > 0.6 * cells as f32, "{single} of {cells}");
            assert!(
                mean < 5.0 && longest <= 16,
                "mean {mean}, longest {longest}"
            );
        }
    }
}
