//! Ray acceleration: obvhs builds a binary BVH (PLOC + reinsertion + SAH leaf collapse) over
//! every triangle of every mesh; we flatten it into a 4-wide BVH with SoA f32 child bounds and
//! traverse that by hand: one 4-wide SIMD slab test per node (glam `Vec4`: SSE2 on x86-64),
//! front-to-back child order for closest hits, precomputed Möller–Trumbore triangles, and the
//! hit's barycentrics returned so shading does not intersect the triangle again.
//!
//! Why not obvhs's own CWBVH traversal: it decodes 8-bit quantised child boxes (u8 → f32 lane
//! by lane) at every node and sorts nothing; on incoherent rays it ran at ~1 Mray/s on 130k
//! triangles where this layout is several times faster (`cargo bench --bench traversal`).

use super::Mesh;
use super::sphere::Sphere;
use crate::math::{Vec2, Vec3};
use glam::Vec3A;
use glam::{BVec4A, Vec4};
use obvhs::BvhBuildParams;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::builder::build_bvh2_from_tris;
use obvhs::triangle::Triangle;
use std::mem::MaybeUninit;

/// A closest hit: distance along the (unit) ray direction, the triangle that was hit and where.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray in world units (direction is unit length).
    pub t: f32,
    /// Index of the mesh in the scene.
    pub mesh: u32,
    /// Triangle index inside the mesh.
    pub prim: u32,
    /// Barycentric weights (b1, b2) of the triangle's 2nd and 3rd vertices at the hit point.
    pub b: Vec2,
}

/// Most triangles in one leaf (obvhs's SAH collapse decides below that).
const MAX_LEAF_TRIS: u32 = 4;

/// Child slots per node.
const WIDTH: usize = 4;

/// 1 + 2γ₃ (pbrt's conservative slab test): the far slab distance is scaled up by this so that
/// rounding in (b − o)·(1/d) never rejects a box the ray passes through.
const FAR_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// One node of the 4-wide BVH: child bounds as SoA lanes, then child links. 128 bytes, two
/// cache lines. Empty slots have inverted infinite bounds and are never hit.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Node4 {
    /// [min x, max x, min y, max y, min z, max z] of the four children.
    bounds: [[f32; WIDTH]; 6],
    /// Internal child: index into `nodes`. Leaf child: first packet in `tris`.
    child: [u32; WIDTH],
    /// 0 for an internal child (or an empty slot), else the number of packets of the leaf.
    count: [u32; WIDTH],
}

impl Node4 {
    const EMPTY: Node4 = Node4 {
        bounds: [
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
        ],
        child: [u32::MAX; WIDTH],
        count: [0; WIDTH],
    };
}

/// Up to four triangles of a leaf, SoA, laid out for the Möller–Trumbore variant of
/// Áfra/madmann91 (one cross product per test): e1 = p0 − p1, e2 = p2 − p0, n = e1 × e2, each
/// as [x lanes, y lanes, z lanes]. Unused lanes are all zero: their determinant is 0, the
/// weights NaN, and they never hit. 192 bytes, three cache lines.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
struct Tri4 {
    p0: [[f32; 4]; 3],
    e1: [[f32; 4]; 3],
    e2: [[f32; 4]; 3],
    n: [[f32; 4]; 3],
}

/// Loads three SoA lanes as x, y, z vectors.
#[inline(always)]
fn lanes(a: &[[f32; 4]; 3]) -> [Vec4; 3] {
    [
        Vec4::from_array(a[0]),
        Vec4::from_array(a[1]),
        Vec4::from_array(a[2]),
    ]
}

#[inline(always)]
fn dot4(a: &[Vec4; 3], b: &[Vec4; 3]) -> Vec4 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl Tri4 {
    /// Stores triangle (p0, p1, p2) in lane `k`.
    fn set(&mut self, k: usize, p0: Vec3, p1: Vec3, p2: Vec3) {
        let e1 = p0 - p1;
        let e2 = p2 - p0;
        let n = e1.cross(e2);
        for a in 0..3 {
            self.p0[a][k] = p0[a];
            self.e1[a][k] = e1[a];
            self.e2[a][k] = e2[a];
            self.n[a][k] = n[a];
        }
    }

    /// Which of the four lanes are hit at t in (0, tmax], with t, b1, b2 per lane.
    #[inline(always)]
    fn intersect(&self, o: &[Vec4; 3], d: &[Vec4; 3], tmax: f32) -> (BVec4A, Vec4, Vec4, Vec4) {
        let p0 = lanes(&self.p0);
        let c = [p0[0] - o[0], p0[1] - o[1], p0[2] - o[2]];
        // r = d × c
        let r = [
            d[1] * c[2] - d[2] * c[1],
            d[2] * c[0] - d[0] * c[2],
            d[0] * c[1] - d[1] * c[0],
        ];
        let n = lanes(&self.n);
        let inv_det = Vec4::ONE / dot4(&n, d);
        let u = dot4(&r, &lanes(&self.e2)) * inv_det;
        let v = dot4(&r, &lanes(&self.e1)) * inv_det;
        let t = dot4(&n, &c) * inv_det;
        let ok = u.cmpge(Vec4::ZERO)
            & v.cmpge(Vec4::ZERO)
            & (u + v).cmple(Vec4::ONE)
            & t.cmpgt(Vec4::ZERO)
            & t.cmple(Vec4::splat(tmax));
        (ok, t, u, v)
    }
}

/// The scalar form of [`Tri4`]: the reference the packet code is tested against.
#[cfg(test)]
#[derive(Clone, Copy, Debug)]
struct Tri {
    p0: Vec3A,
    e1: Vec3A,
    e2: Vec3A,
    n: Vec3A,
}

#[cfg(test)]
impl Tri {
    fn new(p0: Vec3, p1: Vec3, p2: Vec3) -> Tri {
        let (p0, p1, p2) = (Vec3A::from(p0), Vec3A::from(p1), Vec3A::from(p2));
        let e1 = p0 - p1;
        let e2 = p2 - p0;
        Tri {
            p0,
            e1,
            e2,
            n: e1.cross(e2),
        }
    }

    /// (t, b1, b2) if the ray hits the triangle at t in (0, tmax]. A zero determinant gives an
    /// infinite or NaN weight and fails the sign tests.
    #[inline(always)]
    fn intersect(&self, o: Vec3A, d: Vec3A, tmax: f32) -> Option<(f32, f32, f32)> {
        let c = self.p0 - o;
        let r = d.cross(c);
        let inv_det = 1.0 / self.n.dot(d);
        let u = r.dot(self.e2) * inv_det;
        let v = r.dot(self.e1) * inv_det;
        if u >= 0.0 && v >= 0.0 && u + v <= 1.0 {
            let t = self.n.dot(c) * inv_det;
            if t > 0.0 && t <= tmax {
                return Some((t, u, v));
            }
        }
        None
    }
}

/// A traversal stack entry: node index and the ray distance at which its box is entered.
#[derive(Clone, Copy)]
struct Entry {
    node: u32,
    t: f32,
}

/// Fixed-size traversal stack that spills to the heap only for pathologically deep trees, so
/// the common case never allocates and no tree depth can overflow it. The buffer is left
/// uninitialised (zeroing it cost a memset per ray).
struct Stack {
    buf: [MaybeUninit<Entry>; 32],
    len: usize,
    spill: Vec<Entry>,
}

impl Stack {
    #[inline(always)]
    fn new() -> Stack {
        Stack {
            buf: [const { MaybeUninit::uninit() }; 32],
            len: 0,
            spill: Vec::new(),
        }
    }

    #[inline(always)]
    fn push(&mut self, e: Entry) {
        if self.len < self.buf.len() {
            self.buf[self.len].write(e);
            self.len += 1;
        } else {
            self.spill.push(e);
        }
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<Entry> {
        if let Some(e) = self.spill.pop() {
            return Some(e);
        }
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: slots below `len` were written by `push` (len only grows there) and Entry is
        // Copy, so reading one leaves nothing to drop twice.
        Some(unsafe { self.buf[self.len].assume_init_read() })
    }
}

/// Per-ray constants of the slab test.
struct RayBox {
    o: [Vec4; 3],
    inv: [Vec4; 3],
    /// Index of the near plane in `Node4::bounds` per axis (0/1 + 2·axis), from the sign of 1/d.
    near: [usize; 3],
}

impl RayBox {
    #[inline(always)]
    fn new(o: Vec3, d: Vec3) -> RayBox {
        let inv = Vec3::ONE / d;
        let near = |a: usize, x: f32| 2 * a + x.is_sign_negative() as usize;
        RayBox {
            o: [Vec4::splat(o.x), Vec4::splat(o.y), Vec4::splat(o.z)],
            inv: [Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z)],
            near: [near(0, inv.x), near(1, inv.y), near(2, inv.z)],
        }
    }

    /// Entry distances of the four children and the mask of those entered within [0, tmax].
    /// NaN slab distances (origin on a slab plane of a zero direction component) are ignored:
    /// SSE max/min return the second operand when either is NaN, which is the running bound.
    #[inline(always)]
    fn test(&self, n: &Node4, tmax: f32) -> (Vec4, u32) {
        let mut tn = Vec4::ZERO;
        let mut tf = Vec4::splat(tmax);
        for a in 0..3 {
            let lo = Vec4::from_array(n.bounds[self.near[a]]);
            let hi = Vec4::from_array(n.bounds[self.near[a] ^ 1]);
            tn = ((lo - self.o[a]) * self.inv[a]).max(tn);
            tf = ((hi - self.o[a]) * self.inv[a]).min(tf);
        }
        let mask = tn.cmple(tf * FAR_SCALE).bitmask();
        (tn, mask)
    }
}

/// The scene's bounding volume hierarchy (4-wide, built from obvhs's binary BVH).
pub struct Accel {
    nodes: Vec<Node4>,
    /// Triangle packets in leaf order.
    tris: Vec<Tri4>,
    /// (mesh, triangle) of each packet lane (4 per packet; padding lanes are never hit).
    ids: Vec<[u32; 2]>,
    /// World-space bounds of all geometry (min, max); both zero for an empty scene.
    bounds: (Vec3, Vec3),
    /// Analytic spheres and their mesh index, tested one by one next to the BVH (scenes
    /// have a handful; each costs one quadratic).
    spheres: Vec<(Sphere, u32)>,
}

impl Accel {
    /// Builds the BVH over all triangles of `meshes` (obvhs `medium_build` preset, leaves of at
    /// most [`MAX_LEAF_TRIS`] triangles) and flattens it to the 4-wide layout.
    pub fn build(meshes: &[Mesh]) -> Accel {
        let mut src = Vec::new();
        let mut src_ids = Vec::new();
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        let mut spheres = Vec::new();
        for (mi, mesh) in meshes.iter().enumerate() {
            if let Some(s) = mesh.sphere {
                let (a, b) = s.bounds();
                lo = lo.min(a);
                hi = hi.max(b);
                spheres.push((s, mi as u32));
            }
            for (ti, idx) in mesh.indices.iter().enumerate() {
                let p = idx.map(|i| mesh.positions[i as usize]);
                // Non-finite or degenerate triangles cannot be hit; keep them out of the BVH.
                if !p.iter().all(|q| q.is_finite())
                    || (p[1] - p[0]).cross(p[2] - p[0]) == Vec3::ZERO
                {
                    continue;
                }
                for q in p {
                    lo = lo.min(q);
                    hi = hi.max(q);
                }
                src.push(Triangle {
                    v0: p[0].into(),
                    v1: p[1].into(),
                    v2: p[2].into(),
                });
                src_ids.push([mi as u32, ti as u32]);
            }
        }
        if src.is_empty() {
            return Accel {
                nodes: Vec::new(),
                tris: Vec::new(),
                ids: Vec::new(),
                bounds: if spheres.is_empty() {
                    (Vec3::ZERO, Vec3::ZERO)
                } else {
                    (lo, hi)
                },
                spheres,
            };
        }
        let params = BvhBuildParams {
            max_prims_per_leaf: MAX_LEAF_TRIS,
            ..BvhBuildParams::medium_build()
        };
        let bvh2 = build_bvh2_from_tris(&src, params, &mut std::time::Duration::default());
        let (nodes, order) = flatten(&bvh2);
        let mut tris = vec![Tri4::default(); order.len()];
        let mut ids = vec![[u32::MAX; 2]; 4 * order.len()];
        for (pk, lanes) in order.iter().enumerate() {
            for (k, &i) in lanes.iter().enumerate() {
                if i != u32::MAX {
                    let t = &src[i as usize];
                    tris[pk].set(k, t.v0.into(), t.v1.into(), t.v2.into());
                    ids[4 * pk + k] = src_ids[i as usize];
                }
            }
        }
        Accel {
            nodes,
            tris,
            ids,
            bounds: (lo, hi),
            spheres,
        }
    }

    /// Number of triangles in the hierarchy.
    pub fn triangle_count(&self) -> usize {
        self.ids.iter().filter(|i| i[0] != u32::MAX).count()
    }

    /// Axis-aligned bounds (min, max) of all geometry in world units.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    /// Closest hit along `o + t d` for t in (0, tmax]; `d` must be unit length.
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, tmax: f32) -> Option<Hit> {
        // Spheres first: a sphere hit shrinks the interval the BVH has to search.
        let mut tmax = tmax;
        let mut best = None;
        for (s, mesh) in &self.spheres {
            if let Some(t) = s.intersect(o, d, tmax) {
                tmax = t;
                best = Some(Hit {
                    t,
                    mesh: *mesh,
                    prim: 0,
                    b: Vec2::ZERO,
                });
            }
        }
        match self.traverse::<false>(o, d, tmax) {
            Some((i, t, u, v)) => {
                let [mesh, prim] = self.ids[i as usize];
                Some(Hit {
                    t,
                    mesh,
                    prim,
                    b: Vec2::new(u, v),
                })
            }
            None => best,
        }
    }

    /// True if anything blocks `o + t d` for t in (0, tmax] (shadow rays).
    #[inline]
    pub fn occluded(&self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        self.spheres
            .iter()
            .any(|(s, _)| s.intersect(o, d, tmax).is_some())
            || self.traverse::<true>(o, d, tmax).is_some()
    }

    /// Front-to-back traversal. Closest hit (`ANY` = false): (triangle slot, t, b1, b2) of the
    /// nearest hit; any hit (`ANY` = true): the first hit found. Leaf children are intersected
    /// as soon as their box is entered (shrinking tmax); inner children are visited nearest
    /// first and the others stacked with their entry distance, dropped on pop once a closer
    /// hit is known.
    #[inline(always)]
    fn traverse<const ANY: bool>(
        &self,
        o: Vec3,
        d: Vec3,
        tmax: f32,
    ) -> Option<(u32, f32, f32, f32)> {
        if self.nodes.is_empty() {
            return None;
        }
        let rb = RayBox::new(o, d);
        let da = [Vec4::splat(d.x), Vec4::splat(d.y), Vec4::splat(d.z)];
        let mut tmax = tmax;
        let mut best: Option<(u32, f32, f32)> = None;
        let mut stack = Stack::new();
        let mut node = 0u32;
        loop {
            let n = &self.nodes[node as usize];
            let (tn, mut mask) = rb.test(n, tmax);
            let tn = tn.to_array();
            let mut inner = [Entry { node: 0, t: 0.0 }; WIDTH];
            let mut k = 0;
            while mask != 0 {
                let i = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let count = n.count[i];
                if count == 0 {
                    inner[k] = Entry {
                        node: n.child[i],
                        t: tn[i],
                    };
                    k += 1;
                } else {
                    let first = n.child[i] as usize;
                    for (j, tri) in self.tris[first..first + count as usize].iter().enumerate() {
                        let (hit, t, u, v) = tri.intersect(&rb.o, &da, tmax);
                        if !hit.any() {
                            continue;
                        }
                        // Nearest lane that hit.
                        let t = Vec4::select(hit, t, Vec4::INFINITY);
                        let tm = t.min_element();
                        let lane = t.cmpeq(Vec4::splat(tm)).bitmask().trailing_zeros() as usize;
                        let slot = (4 * (first + j) + lane) as u32;
                        if ANY {
                            return Some((slot, tm, u[lane], v[lane]));
                        }
                        tmax = tm;
                        best = Some((slot, u[lane], v[lane]));
                    }
                }
            }
            // Sort the entered inner children farthest first (insertion sort, at most four),
            // dropping those entered beyond a hit found in a sibling leaf.
            let mut m = 0;
            for a in 0..k {
                let e = inner[a];
                if e.t > tmax {
                    continue;
                }
                let mut j = m;
                while j > 0 && inner[j - 1].t < e.t {
                    inner[j] = inner[j - 1];
                    j -= 1;
                }
                inner[j] = e;
                m += 1;
            }
            if m > 0 {
                for e in &inner[..m - 1] {
                    stack.push(*e);
                }
                node = inner[m - 1].node;
                continue;
            }
            loop {
                match stack.pop() {
                    Some(e) if e.t <= tmax => {
                        node = e.node;
                        break;
                    }
                    Some(_) => {}
                    None => {
                        let (i, u, v) = best?;
                        return Some((i, tmax, u, v));
                    }
                }
            }
        }
    }
}

/// Flattens obvhs's binary BVH into 4-wide nodes: each wide node takes a binary node and
/// repeatedly opens its largest-area inner child until it has four children (the usual BVH2 →
/// BVH4 collapse). Returns the nodes (root first) and the leaf-ordered triangle packets as
/// source triangle indices (u32::MAX in unused lanes). Iterative, so deep trees cannot overflow
/// the call stack.
fn flatten(bvh2: &Bvh2) -> (Vec<Node4>, Vec<[u32; 4]>) {
    let b = &bvh2.nodes;
    let mut nodes = Vec::with_capacity(b.len() / 2 + 1);
    let mut order: Vec<[u32; 4]> = Vec::with_capacity(bvh2.primitive_indices.len() / 2);
    // (binary node to turn into a wide node, wide parent and slot to link it from)
    let mut work: Vec<(u32, Option<(usize, usize)>)> = vec![(0, None)];
    while let Some((bi, parent)) = work.pop() {
        let me = nodes.len();
        nodes.push(Node4::EMPTY);
        if let Some((p, slot)) = parent {
            let pn: &mut Node4 = &mut nodes[p];
            pn.child[slot] = me as u32;
        }
        let mut kids: Vec<u32> = vec![bi];
        loop {
            if kids.len() >= WIDTH {
                break;
            }
            let open = kids
                .iter()
                .enumerate()
                .filter(|(_, k)| b[**k as usize].prim_count == 0)
                .max_by(|x, y| {
                    let ax = b[*x.1 as usize].aabb.half_area();
                    let ay = b[*y.1 as usize].aabb.half_area();
                    ax.total_cmp(&ay)
                })
                .map(|(i, _)| i);
            let Some(i) = open else { break };
            let first = b[kids[i] as usize].first_index;
            kids.swap_remove(i);
            kids.push(first);
            kids.push(first + 1);
        }
        for (slot, &k) in kids.iter().enumerate() {
            let bn = &b[k as usize];
            let (mn, mx) = (bn.aabb.min, bn.aabb.max);
            let n = &mut nodes[me];
            for a in 0..3 {
                n.bounds[2 * a][slot] = mn[a];
                n.bounds[2 * a + 1][slot] = mx[a];
            }
            if bn.prim_count == 0 {
                work.push((k, Some((me, slot))));
            } else {
                let f = bn.first_index as usize;
                let prims = &bvh2.primitive_indices[f..f + bn.prim_count as usize];
                n.child[slot] = order.len() as u32;
                n.count[slot] = prims.len().div_ceil(4) as u32;
                for chunk in prims.chunks(4) {
                    let mut pk = [u32::MAX; 4];
                    pk[..chunk.len()].copy_from_slice(chunk);
                    order.push(pk);
                }
            }
        }
    }
    (nodes, order)
}

/// Scale of the origin offset relative to the magnitude of the coordinates (≈ 2⁻¹⁶; the hit
/// point is reconstructed from barycentrics with an error of a few ulps of |p|).
const OFFSET_SCALE: f32 = 1.0 / 65536.0;

/// Moves a surface point off its surface along the geometric normal `n`, to the side `d` points
/// to, by an amount that grows with the coordinates' magnitude, so that a ray spawned there does
/// not re-hit the surface it starts on.
#[inline]
pub fn offset_origin(p: Vec3, n: Vec3, d: Vec3) -> Vec3 {
    let mag = 1.0 + Vec3A::from(p).abs().max_element();
    let off = n * (mag * OFFSET_SCALE);
    if n.dot(d) >= 0.0 { p + off } else { p - off }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(z: f32) -> Mesh {
        Mesh {
            name: "quad".into(),
            positions: vec![
                Vec3::new(-1.0, -1.0, z),
                Vec3::new(1.0, -1.0, z),
                Vec3::new(1.0, 1.0, z),
                Vec3::new(-1.0, 1.0, z),
            ],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            ..Default::default()
        }
    }

    #[test]
    fn closest_hit_maps_back_to_mesh_and_triangle() {
        let meshes = vec![quad(0.0), quad(2.0)];
        let accel = Accel::build(&meshes);
        assert_eq!(accel.triangle_count(), 4);
        let h = accel
            .intersect(Vec3::new(0.5, -0.2, 5.0), -Vec3::Z, f32::INFINITY) // (−0, −0, −1)
            .unwrap();
        assert_eq!(h.mesh, 1);
        assert_eq!(h.prim, 0);
        assert!((h.t - 3.0).abs() < 1e-5);
        let h = accel
            .intersect(Vec3::new(-0.5, 0.2, -5.0), Vec3::Z, f32::INFINITY)
            .unwrap();
        assert_eq!((h.mesh, h.prim), (0, 1));
        assert!(
            accel
                .intersect(Vec3::new(3.0, 0.0, 5.0), -Vec3::Z, 100.0)
                .is_none()
        );
        assert!(
            accel
                .intersect(Vec3::new(0.5, 0.0, 5.0), -Vec3::Z, 2.5)
                .is_none()
        );
        assert!(accel.occluded(Vec3::new(0.5, 0.0, 5.0), -Vec3::Z, 3.5));
        assert!(!accel.occluded(Vec3::new(0.5, 0.0, 5.0), -Vec3::Z, 2.9));
        let (lo, hi) = accel.bounds();
        assert_eq!(lo, Vec3::new(-1.0, -1.0, 0.0));
        assert_eq!(hi, Vec3::new(1.0, 1.0, 2.0));
    }

    /// Brute force over every triangle with the same intersection routine.
    fn brute(meshes: &[Mesh], o: Vec3, d: Vec3, tmax: f32) -> Option<(f32, u32, u32, Vec2)> {
        let mut best: Option<(f32, u32, u32, Vec2)> = None;
        for (mi, m) in meshes.iter().enumerate() {
            for (ti, idx) in m.indices.iter().enumerate() {
                let p = idx.map(|i| m.positions[i as usize]);
                let lim = best.map_or(tmax, |b| b.0);
                if let Some((t, u, v)) =
                    Tri::new(p[0], p[1], p[2]).intersect(o.into(), d.into(), lim)
                {
                    best = Some((t, mi as u32, ti as u32, Vec2::new(u, v)));
                }
            }
        }
        best
    }

    #[test]
    fn wide_bvh_matches_brute_force() {
        use crate::geometry::generate::sphere_displaced;
        use crate::math::warp::square_to_uniform_sphere;
        // A bumpy sphere (~2k triangles, deep enough for several wide levels) plus an
        // axis-aligned box of quads, so zero direction components and ±0.0 meet slab planes.
        let mut meshes = vec![sphere_displaced(
            Vec3::ZERO,
            1.0,
            24,
            48,
            false,
            true,
            |d| 0.1 * (7.0 * d.x).sin() * (5.0 * d.y).cos(),
        )];
        for (z, s) in [(1.5f32, 1.0f32), (-1.5, 2.0)] {
            let mut q = quad(z);
            q.positions
                .iter_mut()
                .for_each(|p| *p *= Vec3::new(s, s, 1.0));
            meshes.push(q);
        }
        let accel = Accel::build(&meshes);
        assert!(accel.nodes.len() > 20);
        let mut rng = crate::math::Pcg32::new(7, 9);
        let mut hits = 0;
        for k in 0..4000 {
            let o = square_to_uniform_sphere(rng.next_2d()) * (0.5 + 3.0 * rng.next_f32());
            let mut d = (square_to_uniform_sphere(rng.next_2d()) * 0.8 - o).normalize();
            if k % 4 == 0 {
                // Axis-aligned directions with signed zeros.
                let a = (k / 4) % 3;
                let s = if (k / 12) % 2 == 0 { 1.0 } else { -1.0 };
                d = Vec3::ZERO;
                d[a] = s;
                if k % 8 == 0 {
                    d = -d; // the zero components become −0.0
                }
            }
            let tmax = if k % 3 == 0 { 2.0 } else { f32::INFINITY };
            let want = brute(&meshes, o, d, tmax);
            let got = accel.intersect(o, d, tmax);
            assert_eq!(accel.occluded(o, d, tmax), want.is_some(), "ray {k}");
            match (want, got) {
                (None, None) => {}
                (Some((t, m, p, b)), Some(h)) => {
                    hits += 1;
                    assert!(
                        (h.t - t).abs() <= 1e-5 * t.max(1.0),
                        "ray {k}: {h:?} vs {t}"
                    );
                    if (h.mesh, h.prim) != (m, p) {
                        // Only a tie (shared edge/vertex at the same t) may pick another triangle.
                        assert!((h.t - t).abs() <= 1e-6 * t.max(1.0), "ray {k}");
                    } else {
                        assert!((h.b - b).length() < 1e-5, "ray {k}");
                    }
                }
                (w, g) => panic!("ray {k}: brute {w:?} vs bvh {g:?}"),
            }
        }
        assert!(
            hits > 1500,
            "only {hits} hits: the test rays miss too often"
        );
    }

    #[test]
    fn hit_barycentrics_match_shading() {
        let meshes = vec![Mesh {
            positions: vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(2.0, 0.0, 0.1),
                Vec3::new(0.0, 2.0, -0.1),
            ],
            indices: vec![[0, 1, 2]],
            ..Default::default()
        }];
        let accel = Accel::build(&meshes);
        let o = Vec3::new(0.3, 0.5, 2.0);
        let d = Vec3::new(0.1, 0.2, -1.0).normalize();
        let h = accel.intersect(o, d, f32::INFINITY).unwrap();
        let p = &meshes[0].positions;
        let b = crate::geometry::shading::barycentrics(p[0], p[1], p[2], o, d);
        assert!((h.b - b).length() < 1e-6, "{:?} vs {b:?}", h.b);
        let x = p[0] * (1.0 - b.x - b.y) + p[1] * b.x + p[2] * b.y;
        assert!((o + d * h.t - x).length() < 1e-5);
    }

    #[test]
    fn stack_is_lifo_across_the_heap_spill() {
        let mut st = Stack::new();
        for i in 0..100u32 {
            st.push(Entry {
                node: i,
                t: i as f32,
            });
        }
        for i in (0..100u32).rev() {
            assert_eq!(st.pop().map(|e| e.node), Some(i));
        }
        assert!(st.pop().is_none());
    }

    #[test]
    fn empty_scene_never_hits() {
        let accel = Accel::build(&[]);
        assert!(
            accel
                .intersect(Vec3::ZERO, Vec3::Z, f32::INFINITY)
                .is_none()
        );
        assert!(!accel.occluded(Vec3::ZERO, Vec3::Z, f32::INFINITY));
    }

    #[test]
    fn offset_origin_escapes_the_surface() {
        let meshes = vec![quad(0.0)];
        let accel = Accel::build(&meshes);
        let mut rng = crate::math::Pcg32::new(3, 4);
        for _ in 0..2000 {
            let p = Vec3::new(rng.next_f32() * 1.8 - 0.9, rng.next_f32() * 1.8 - 0.9, 0.0);
            let d = crate::math::warp::square_to_uniform_sphere(rng.next_2d());
            if d.z.abs() < 1e-3 {
                continue;
            }
            let o = offset_origin(p, Vec3::Z, d);
            assert!(accel.intersect(o, d, f32::INFINITY).is_none());
        }
    }
}
