//! A periodic triangulated height field with a two-level grid traversal (texel blocks with
//! min/max bounds over fine cells), exact and watertight: along the ray the signed height gap
//! f(t) = z(t) − H(x(t), y(t)) is piecewise linear, so the first sign change is found exactly and
//! the value at a cell boundary is carried into the next cell. Rays leaving the tile re-enter on
//! the opposite side (the sample is infinitely tiled, as a measured sample is locally).

use crate::math::Vec3;
use crate::{Error, Result};

/// Cell split: each cell (i, j) holds two triangles split along the diagonal (0,0)–(1,1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Tri {
    /// u ≥ v: vertices (0,0), (1,0), (1,1).
    Lower,
    /// v > u: vertices (0,0), (1,1), (0,1).
    Upper,
}

/// Where a ray hit the height field.
#[derive(Clone, Copy, Debug)]
pub struct HfHit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// Hit point on the surface, x/y wrapped into the tile, in texel units.
    pub p: Vec3,
    /// Geometric (facet) normal.
    pub ng: Vec3,
    /// Shading normal (interpolated vertex normals, or `ng` for faceted surfaces).
    pub ns: Vec3,
    /// Index of the fine cell (row-major, `j * nx + i`), for per-cell parameters.
    pub cell: usize,
}

/// A periodic height field of `nx × ny` vertices over a `width × height` texel tile.
#[derive(Clone, Debug)]
pub struct HeightField {
    nx: usize,
    ny: usize,
    /// Cell size in texel units.
    cx: f32,
    cy: f32,
    h: Vec<f32>,
    vn: Vec<Vec3>,
    smooth: bool,
    /// Cells per block side.
    bs: usize,
    nbx: usize,
    nby: usize,
    bmin: Vec<f32>,
    bmax: Vec<f32>,
    zmin: f32,
    zmax: f32,
    /// Traversal bound margin in z.
    zeps: f32,
}

impl HeightField {
    /// Builds the field from vertex heights (row-major `j * nx + i`, texel units) over a tile of
    /// `width × height` texels; `block` cells per block side must divide `nx` and `ny`.
    pub fn new(
        nx: usize,
        ny: usize,
        width: f32,
        height: f32,
        heights: Vec<f32>,
        block: usize,
        smooth: bool,
    ) -> Result<Self> {
        if nx < 2 || ny < 2 || heights.len() != nx * ny {
            return Err(Error::Invalid(format!(
                "height field needs ≥ 2×2 vertices and nx·ny heights (got {nx}×{ny}, {} heights)",
                heights.len()
            )));
        }
        if block == 0 || !nx.is_multiple_of(block) || !ny.is_multiple_of(block) {
            return Err(Error::Invalid(format!(
                "height-field block size {block} must divide the grid {nx}×{ny}"
            )));
        }
        if !(width > 0.0 && height > 0.0) || heights.iter().any(|h| !h.is_finite()) {
            return Err(Error::Invalid(
                "height field has a non-positive extent or non-finite heights".into(),
            ));
        }
        let cx = width / nx as f32;
        let cy = height / ny as f32;
        let at = |i: usize, j: usize| heights[(j % ny) * nx + (i % nx)];
        let mut vn = Vec::with_capacity(nx * ny);
        for j in 0..ny {
            for i in 0..nx {
                let gx = (at(i + 1, j) - at(i + nx - 1, j)) / (2.0 * cx);
                let gy = (at(i, j + 1) - at(i, j + ny - 1)) / (2.0 * cy);
                vn.push(Vec3::new(-gx, -gy, 1.0).normalize());
            }
        }
        let (nbx, nby) = (nx / block, ny / block);
        let mut bmin = vec![f32::INFINITY; nbx * nby];
        let mut bmax = vec![f32::NEG_INFINITY; nbx * nby];
        for bj in 0..nby {
            for bi in 0..nbx {
                let b = bj * nbx + bi;
                for j in bj * block..=(bj + 1) * block {
                    for i in bi * block..=(bi + 1) * block {
                        let v = at(i, j);
                        bmin[b] = bmin[b].min(v);
                        bmax[b] = bmax[b].max(v);
                    }
                }
            }
        }
        let zmin = heights.iter().copied().fold(f32::INFINITY, f32::min);
        let zmax = heights.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        let zeps = 1e-5 * (1.0 + zmax.abs().max(zmin.abs()) + width.max(height));
        Ok(HeightField {
            nx,
            ny,
            cx,
            cy,
            h: heights,
            vn,
            smooth,
            bs: block,
            nbx,
            nby,
            bmin,
            bmax,
            zmin,
            zmax,
            zeps,
        })
    }

    /// Lowest vertex height.
    pub fn zmin(&self) -> f32 {
        self.zmin
    }

    /// Highest vertex height.
    pub fn zmax(&self) -> f32 {
        self.zmax
    }

    /// Vertices per row and per column.
    pub fn grid(&self) -> (usize, usize) {
        (self.nx, self.ny)
    }

    #[inline]
    fn cell_heights(&self, i: usize, j: usize) -> [f32; 4] {
        let i1 = if i + 1 == self.nx { 0 } else { i + 1 };
        let j1 = if j + 1 == self.ny { 0 } else { j + 1 };
        let r0 = j * self.nx;
        let r1 = j1 * self.nx;
        [
            self.h[r0 + i],
            self.h[r0 + i1],
            self.h[r1 + i],
            self.h[r1 + i1],
        ]
    }

    /// Height of triangle `tri` of a cell with corner heights `[h00, h10, h01, h11]` at local (u, v).
    #[inline]
    fn tri_height(c: &[f32; 4], tri: Tri, u: f32, v: f32) -> f32 {
        match tri {
            Tri::Lower => c[0] + (c[1] - c[0]) * u + (c[3] - c[1]) * v,
            Tri::Upper => c[0] + (c[3] - c[2]) * u + (c[2] - c[0]) * v,
        }
    }

    /// First intersection of the ray o + t·d (t > 0) with the tiled surface.
    pub fn intersect(&self, o: Vec3, d: Vec3) -> Option<HfHit> {
        let (t, i, j, u, v, tri) = self.trace(o, d)?;
        let c = self.cell_heights(i, j);
        let (du, dv) = match tri {
            Tri::Lower => (c[1] - c[0], c[3] - c[1]),
            Tri::Upper => (c[3] - c[2], c[2] - c[0]),
        };
        let ng = Vec3::new(-du / self.cx, -dv / self.cy, 1.0).normalize();
        let ns = if self.smooth {
            let i1 = if i + 1 == self.nx { 0 } else { i + 1 };
            let j1 = if j + 1 == self.ny { 0 } else { j + 1 };
            let n00 = self.vn[j * self.nx + i];
            let n11 = self.vn[j1 * self.nx + i1];
            let n = match tri {
                Tri::Lower => n00 * (1.0 - u) + self.vn[j * self.nx + i1] * (u - v) + n11 * v,
                Tri::Upper => n00 * (1.0 - v) + self.vn[j1 * self.nx + i] * (v - u) + n11 * u,
            };
            n.normalize()
        } else {
            ng
        };
        let w = self.cx * self.nx as f32;
        let hgt = self.cy * self.ny as f32;
        let x = ((i as f32 + u) * self.cx).rem_euclid(w);
        let y = ((j as f32 + v) * self.cy).rem_euclid(hgt);
        let z = Self::tri_height(&c, tri, u, v);
        Some(HfHit {
            t,
            p: Vec3::new(x, y, z),
            ng,
            ns,
            cell: j * self.nx + i,
        })
    }

    /// True if the ray o + t·d (t > 0) hits the surface (shadow rays).
    pub fn occluded(&self, o: Vec3, d: Vec3) -> bool {
        self.trace(o, d).is_some()
    }

    /// Core traversal; returns (t, wrapped cell i, j, local u, v, triangle).
    fn trace(&self, o: Vec3, d: Vec3) -> Option<(f32, usize, usize, f32, f32, Tri)> {
        let zlo = self.zmin - self.zeps;
        let zhi = self.zmax + self.zeps;
        // Ray interval inside the slab [zlo, zhi].
        let (t0, t_end) = if d.z > 0.0 {
            ((zlo - o.z) / d.z, (zhi - o.z) / d.z)
        } else if d.z < 0.0 {
            ((zhi - o.z) / d.z, (zlo - o.z) / d.z)
        } else if o.z >= zlo && o.z <= zhi {
            (f32::NEG_INFINITY, f32::INFINITY)
        } else {
            return None;
        };
        let t0 = t0.max(0.0);
        if t_end <= t0 {
            return None;
        }
        // Cell units.
        let ox = o.x / self.cx;
        let oy = o.y / self.cy;
        let dx = d.x / self.cx;
        let dy = d.y / self.cy;
        let bs = self.bs as f32;
        let x0 = ox + dx * t0;
        let y0 = oy + dy * t0;
        let mut bi = (x0 / bs).floor() as i64;
        let mut bj = (y0 / bs).floor() as i64;
        let (step_x, tdel_x, mut tmax_x) = axis_setup(ox, dx, bi, bs);
        let (step_y, tdel_y, mut tmax_y) = axis_setup(oy, dy, bj, bs);
        let mut t = t0;
        let mut carry: Option<f32> = None;
        // A ray nearly parallel to the mean plane inside the slab could wander forever over a
        // periodic surface; after this many blocks it is declared unoccluded.
        let max_steps = 16 * (self.nbx + self.nby) + 64;
        for _ in 0..max_steps {
            let t_exit = tmax_x.min(tmax_y).min(t_end);
            let wbi = bi.rem_euclid(self.nbx as i64) as usize;
            let wbj = bj.rem_euclid(self.nby as i64) as usize;
            let b = wbj * self.nbx + wbi;
            let za = o.z + d.z * t;
            let zb = if t_exit.is_finite() {
                o.z + d.z * t_exit
            } else {
                za
            };
            if za.min(zb) <= self.bmax[b] && za.max(zb) >= self.bmin[b] {
                let ctx = RayCells {
                    o,
                    d,
                    ox,
                    oy,
                    dx,
                    dy,
                };
                if let Some(hit) = self.trace_block(&ctx, bi, bj, wbi, wbj, t, t_exit, &mut carry) {
                    return Some(hit);
                }
            } else {
                carry = None;
            }
            if t_exit >= t_end {
                return None;
            }
            if tmax_x < tmax_y {
                bi += step_x;
                t = tmax_x;
                tmax_x += tdel_x;
            } else {
                bj += step_y;
                t = tmax_y;
                tmax_y += tdel_y;
            }
        }
        None
    }

    /// Fine traversal of the cells of block (bi, bj) (unwrapped; wrapped wbi, wbj) for t in
    /// [ta, tb]. `carry` holds f at ta if the previous block was traversed finely.
    #[allow(clippy::too_many_arguments)]
    fn trace_block(
        &self,
        r: &RayCells,
        bi: i64,
        bj: i64,
        wbi: usize,
        wbj: usize,
        ta: f32,
        tb: f32,
        carry: &mut Option<f32>,
    ) -> Option<(f32, usize, usize, f32, f32, Tri)> {
        let bs = self.bs as i64;
        let ci0 = bi * bs;
        let cj0 = bj * bs;
        let xa = r.ox + r.dx * ta;
        let ya = r.oy + r.dy * ta;
        let mut li = ((xa.floor() as i64) - ci0).clamp(0, bs - 1);
        let mut lj = ((ya.floor() as i64) - cj0).clamp(0, bs - 1);
        let (sx, tdx, mut tmx) = axis_setup(r.ox, r.dx, ci0 + li, 1.0);
        let (sy, tdy, mut tmy) = axis_setup(r.oy, r.dy, cj0 + lj, 1.0);
        let mut t = ta;
        let mut f_s = match *carry {
            Some(f) => f,
            None => {
                let (i, j) = (wbi * self.bs + li as usize, wbj * self.bs + lj as usize);
                let c = self.cell_heights(i, j);
                let u = xa - (ci0 + li) as f32;
                let v = ya - (cj0 + lj) as f32;
                let tri = if u >= v { Tri::Lower } else { Tri::Upper };
                let f = r.o.z + r.d.z * ta - Self::tri_height(&c, tri, u, v);
                if f <= 0.0 {
                    return Some((ta, i, j, u, v, tri));
                }
                f
            }
        };
        loop {
            let t_next = tmx.min(tmy).min(tb);
            let (ci, cj) = (ci0 + li, cj0 + lj);
            let (i, j) = (wbi * self.bs + li as usize, wbj * self.bs + lj as usize);
            let c = self.cell_heights(i, j);
            let ua = r.ox + r.dx * t - ci as f32;
            let va = r.oy + r.dy * t - cj as f32;
            let (ub, vb) = if t_next.is_finite() {
                (
                    r.ox + r.dx * t_next - ci as f32,
                    r.oy + r.dy * t_next - cj as f32,
                )
            } else {
                (ua, va)
            };
            let ga = ua - va;
            let gb = ub - vb;
            // Pieces of constant triangle along the segment.
            let mut pieces: [(f32, f32, Tri); 2] = [(0.0, 0.0, Tri::Lower); 2];
            let mut np = 0;
            if ga * gb < 0.0 && t_next.is_finite() {
                let td = t + (t_next - t) * ga / (ga - gb);
                pieces[0] = (t, td, if ga > 0.0 { Tri::Lower } else { Tri::Upper });
                pieces[1] = (td, t_next, if gb > 0.0 { Tri::Lower } else { Tri::Upper });
                np = 2;
            } else {
                pieces[0] = (
                    t,
                    t_next,
                    if ga + gb >= 0.0 {
                        Tri::Lower
                    } else {
                        Tri::Upper
                    },
                );
                np += 1;
            }
            for &(ps, pe, tri) in &pieces[..np] {
                let te = if pe.is_finite() { pe } else { ps };
                let ue = r.ox + r.dx * te - ci as f32;
                let ve = r.oy + r.dy * te - cj as f32;
                let f_e = if pe.is_finite() {
                    r.o.z + r.d.z * te - Self::tri_height(&c, tri, ue, ve)
                } else {
                    // Vertical ray: it meets the surface at this (u, v).
                    let hz = Self::tri_height(&c, tri, ue, ve);
                    if r.d.z < 0.0 {
                        let th = (hz - r.o.z) / r.d.z;
                        return Some((th.max(ps), i, j, ue, ve, tri));
                    }
                    1.0
                };
                if f_e <= 0.0 {
                    let th = ps + (te - ps) * (f_s / (f_s - f_e));
                    let uh = (r.ox + r.dx * th - ci as f32).clamp(0.0, 1.0);
                    let vh = (r.oy + r.dy * th - cj as f32).clamp(0.0, 1.0);
                    return Some((th, i, j, uh, vh, tri));
                }
                f_s = f_e;
            }
            if t_next >= tb {
                *carry = Some(f_s);
                return None;
            }
            t = t_next;
            if tmx < tmy {
                li += sx;
                tmx += tdx;
            } else {
                lj += sy;
                tmy += tdy;
            }
            if li < 0 || li >= bs || lj < 0 || lj >= bs {
                // Left the block through rounding before tb: continue in the next block.
                *carry = Some(f_s);
                return None;
            }
        }
    }
}

/// The ray in cell units (x, y scaled by 1/cell size; z and t unchanged).
struct RayCells {
    o: Vec3,
    d: Vec3,
    ox: f32,
    oy: f32,
    dx: f32,
    dy: f32,
}

/// DDA setup along one axis for cells of size `size` (in cell units): (step, t per cell, t of the
/// first boundary) from the current cell index `c`.
#[inline]
fn axis_setup(o: f32, d: f32, c: i64, size: f32) -> (i64, f32, f32) {
    if d > 0.0 {
        (1, size / d, ((c + 1) as f32 * size - o) / d)
    } else if d < 0.0 {
        (-1, -size / d, (c as f32 * size - o) / d)
    } else {
        (0, f32::INFINITY, f32::INFINITY)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Pcg32;

    fn bumpy(n: usize, w: f32) -> HeightField {
        let mut h = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let (x, y) = (i as f32 / n as f32, j as f32 / n as f32);
                h.push(
                    0.7 * (std::f32::consts::TAU * x).sin()
                        * (2.0 * std::f32::consts::TAU * y).cos()
                        + 0.2 * (3.0 * std::f32::consts::TAU * (x + y)).sin(),
                );
            }
        }
        HeightField::new(n, n, w, w, h, 4, true).unwrap()
    }

    /// Brute force: march the ray finely and find the first t where z < H (bilinear-free exact
    /// triangle height at the marched point).
    fn brute(hf: &HeightField, o: Vec3, d: Vec3) -> Option<f32> {
        let w = hf.cx * hf.nx as f32;
        let height_at = |x: f32, y: f32| {
            let gx = x.rem_euclid(w) / hf.cx;
            let gy = y.rem_euclid(w) / hf.cy;
            let (i, j) = (gx.floor() as usize % hf.nx, gy.floor() as usize % hf.ny);
            let (u, v) = (gx - gx.floor(), gy - gy.floor());
            let c = hf.cell_heights(i, j);
            HeightField::tri_height(&c, if u >= v { Tri::Lower } else { Tri::Upper }, u, v)
        };
        let mut t = 0.0;
        let dt = 1e-3;
        while t < 200.0 {
            let p = o + d * t;
            if p.z < height_at(p.x, p.y) {
                return Some(t);
            }
            if d.z > 0.0 && p.z > hf.zmax {
                return None;
            }
            t += dt;
        }
        None
    }

    #[test]
    fn traversal_matches_brute_force_marching() {
        let hf = bumpy(32, 8.0);
        let mut rng = Pcg32::new(5, 1);
        let mut hits = 0;
        for k in 0..300 {
            let o = Vec3::new(
                rng.next_f32() * 8.0,
                rng.next_f32() * 8.0,
                if k % 2 == 0 {
                    1.5
                } else {
                    0.9 + rng.next_f32() * 0.3
                },
            );
            let dir = crate::math::warp::square_to_uniform_sphere(rng.next_2d());
            let got = hf.intersect(o, dir).map(|h| h.t);
            let want = brute(&hf, o, dir);
            match (got, want) {
                (Some(a), Some(b)) => {
                    assert!((a - b).abs() < 3e-3, "ray {k}: {a} vs {b}");
                    hits += 1;
                }
                (None, None) => {}
                // A brute-force march with step 1e-3 can miss sub-step grazes; allow only those.
                (a, b) => panic!("ray {k} o={o} d={dir}: traversal {a:?}, brute {b:?}"),
            }
        }
        assert!(hits > 50);
    }

    #[test]
    fn hit_points_lie_on_the_surface_and_vertical_rays_hit() {
        let hf = bumpy(16, 4.0);
        let mut rng = Pcg32::new(9, 2);
        for _ in 0..200 {
            let o = Vec3::new(rng.next_f32() * 4.0, rng.next_f32() * 4.0, 3.0);
            let h = hf.intersect(o, -Vec3::Z).expect("vertical ray must hit");
            assert!((h.p.x - o.x).abs() < 1e-4 && (h.p.y - o.y).abs() < 1e-4);
            assert!((o.z - h.t - h.p.z).abs() < 1e-4);
            assert!(h.ng.z > 0.0 && h.ns.z > 0.0);
        }
    }

    #[test]
    fn rejects_bad_grids() {
        assert!(HeightField::new(4, 4, 1.0, 1.0, vec![0.0; 15], 2, false).is_err());
        assert!(HeightField::new(6, 6, 1.0, 1.0, vec![0.0; 36], 4, false).is_err());
        assert!(HeightField::new(4, 4, 1.0, 1.0, vec![f32::NAN; 16], 2, false).is_err());
    }
}
