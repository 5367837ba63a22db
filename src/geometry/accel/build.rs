//! Building the 8-wide BVH from the scene's meshes without copying them: leaf boxes straight from
//! the mesh vertices (in parallel), obvhs's PLOC on those boxes and reinsertion sized by
//! [`reinsertion_ratio`], the SAH-optimal grouping into wide nodes and packet leaves
//! ([`WidePlan`]), then [`flatten`] into wide nodes and packets.
//!
//! A scene of more than [`PART_TRIS`] triangles is built in parts: its triangles sorted along a
//! 30-bit Morton curve of their centroids, cut into equal runs, each run built and flattened on
//! its own (obvhs's transient buffers, ~150 bytes per triangle, then exist for one part at a
//! time), and the parts' roots joined by a few wide nodes on top. Every step depends only on the
//! geometry, never on the thread count, so the tree (and the image) is the same on any machine.

use super::collapse::WidePlan;
use super::flatten::flatten;
use super::node::{Node8, WIDTH};
use super::tri::{LANES, TriPack};
use crate::geometry::Mesh;
use crate::math::Vec3;
use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::ploc::{PlocBuilder, SortPrecision};
use rayon::prelude::*;

/// Largest number of triangles built as one obvhs BVH; bigger scenes are built in parts of at
/// most this many (bounds the build's transient memory to ~150 bytes × this).
pub(super) const PART_TRIS: usize = 1 << 19;

/// obvhs `medium_build`'s PLOC search distance (14 neighbours each side).
const PLOC_SEARCH: usize = 14;

/// Below this many triangles per part, reinsertion runs at obvhs `medium_build`'s ratio.
const FULL_QUALITY_TRIS: usize = 1 << 18;

/// The reinsertion batch ratio for a part of `n` triangles: obvhs `medium_build`'s 0.05 up to
/// [`FULL_QUALITY_TRIS`], then falling as 1/√n, so reinsertion's share of the build (it costs
/// about ratio × n × the depth of the search) stays a bounded fraction of PLOC's n log n while
/// still moving the largest nodes, which decide most of the traversal cost.
pub(super) fn reinsertion_ratio(n: usize) -> f32 {
    let medium = 0.05;
    if n <= FULL_QUALITY_TRIS {
        medium
    } else {
        medium * (FULL_QUALITY_TRIS as f32 / n as f32).sqrt()
    }
}

/// The built hierarchy: wide nodes (root first), triangle packets and the global triangle id of
/// every packet lane (u32::MAX for an empty lane).
pub(super) struct Built {
    pub nodes: Vec<Node8>,
    pub tris: Vec<TriPack>,
    pub ids: Vec<[u32; LANES]>,
}

/// Maps global triangle ids (all meshes' triangles numbered in order) to meshes.
pub(super) struct TriIds<'a> {
    meshes: &'a [Mesh],
    /// Global id of each mesh's first triangle.
    pub first: Vec<u32>,
    /// Total number of triangles.
    pub total: usize,
}

impl<'a> TriIds<'a> {
    /// Numbers the triangles of `meshes`. Panics if there are u32::MAX or more (callers check
    /// first: `RenderScene::new` reports that as an error).
    /// Only the meshes `include` accepts count triangles (the others count none).
    pub fn new_filtered(meshes: &'a [Mesh], include: impl Fn(&Mesh) -> bool) -> TriIds<'a> {
        let mut first = Vec::with_capacity(meshes.len());
        let mut total = 0usize;
        for m in meshes {
            first.push(total as u32);
            if include(m) {
                total += m.indices.len();
            }
        }
        assert!(
            total < u32::MAX as usize,
            "{total} triangles: the BVH numbers triangles in 32 bits"
        );
        TriIds {
            meshes,
            first,
            total,
        }
    }

    /// Number of triangles counted for mesh `mi`.
    #[inline]
    fn count(&self, mi: usize) -> usize {
        self.first.get(mi + 1).map_or(self.total, |&f| f as usize) - self.first[mi] as usize
    }

    /// (mesh, triangle in the mesh) of global id `g`.
    #[inline]
    pub fn locate(first: &[u32], g: u32) -> (u32, u32) {
        let m = first.partition_point(|&f| f <= g) - 1;
        (m as u32, g - first[m])
    }

    /// The corners of global triangle `g`.
    #[inline]
    fn corners(&self, g: u32) -> [Vec3; 3] {
        let (m, t) = Self::locate(&self.first, g);
        let mesh = &self.meshes[m as usize];
        mesh.indices[t as usize].map(|i| mesh.positions[i as usize])
    }
}

/// Non-finite or degenerate triangles cannot be hit: they stay out of the BVH.
#[inline]
fn usable(p: &[Vec3; 3]) -> bool {
    p.iter().all(|q| q.is_finite()) && (p[1] - p[0]).cross(p[2] - p[0]) != Vec3::ZERO
}

/// The box of a triangle.
#[inline]
fn tri_aabb(p: &[Vec3; 3]) -> Aabb {
    let (a, b, c) = (Vec3A::from(p[0]), Vec3A::from(p[1]), Vec3A::from(p[2]));
    Aabb {
        min: a.min(b).min(c),
        max: a.max(b).max(c),
    }
}

/// Union of two boxes (for parallel reductions).
fn union(a: Aabb, b: Aabb) -> Aabb {
    Aabb {
        min: a.min.min(b.min),
        max: a.max.max(b.max),
    }
}

/// Builds the hierarchy over the usable triangles of `ids`' meshes, in parts of at most
/// `part_tris` triangles; also returns the bounds of those triangles (min, max), or None if
/// there are none.
pub(super) fn build(ids: &TriIds, part_tris: usize) -> (Built, Option<(Vec3, Vec3)>) {
    // Per triangle: its global id, or u32::MAX if unusable; and the bounds of the usable ones.
    let mut valid: Vec<u32> = vec![u32::MAX; ids.total];
    let mut bounds = Aabb::empty();
    for (mi, mesh) in ids.meshes.iter().enumerate() {
        let f = ids.first[mi] as usize;
        let b = valid[f..f + ids.count(mi)]
            .par_iter_mut()
            .zip(mesh.indices.par_iter())
            .enumerate()
            .map(|(t, (v, idx))| {
                let p = idx.map(|i| mesh.positions[i as usize]);
                if usable(&p) {
                    *v = (f + t) as u32;
                    tri_aabb(&p)
                } else {
                    Aabb::empty()
                }
            })
            .reduce(Aabb::empty, union);
        bounds = union(bounds, b);
    }
    valid.retain(|&g| g != u32::MAX);
    let mut out = Built {
        nodes: Vec::new(),
        tris: Vec::new(),
        ids: Vec::new(),
    };
    if valid.is_empty() {
        return (out, None);
    }
    let bounds_v = (Vec3::from(bounds.min), Vec3::from(bounds.max));
    // Wide nodes hold about 15 triangles on average: reserve so the 64-byte aligned nodes are
    // rarely copied by growth.
    out.nodes.reserve(valid.len() / 12 + 16);
    if valid.len() <= part_tris {
        build_part(ids, &valid, &mut out);
        out.tris = packets(ids, &out.ids);
        return (out, Some(bounds_v));
    }
    // Sort along a Morton curve (10 bits per axis) of the centroids; the id in the low bits
    // makes every key distinct, so the order does not depend on the sort algorithm.
    let lo = bounds.min;
    let scale =
        Vec3A::splat(1023.0) / (bounds.max - bounds.min).max(Vec3A::splat(f32::MIN_POSITIVE));
    let mut keys: Vec<u64> = valid
        .par_iter()
        .map(|&g| {
            let p = ids.corners(g);
            let c = (Vec3A::from(p[0]) + Vec3A::from(p[1]) + Vec3A::from(p[2])) * (1.0 / 3.0);
            let q = ((c - lo) * scale).clamp(Vec3A::ZERO, Vec3A::splat(1023.0));
            let code = spread10(q.x as u32) | spread10(q.y as u32) << 1 | spread10(q.z as u32) << 2;
            (code as u64) << 32 | g as u64
        })
        .collect();
    drop(valid);
    keys.par_sort_unstable();
    let parts = keys.len().div_ceil(part_tris);
    let per = keys.len().div_ceil(parts);
    // Node 0 is the root, filled once the parts' roots are known.
    out.nodes.push(Node8::EMPTY);
    let mut roots: Vec<(u32, Aabb)> = Vec::with_capacity(parts);
    for chunk in keys.chunks(per) {
        let gids: Vec<u32> = chunk.iter().map(|&k| k as u32).collect();
        roots.push(build_part(ids, &gids, &mut out));
    }
    drop(keys);
    // Join the part roots (in Morton order, so neighbours are close) eight at a time.
    while roots.len() > WIDTH {
        let mut up = Vec::with_capacity(roots.len().div_ceil(WIDTH));
        for group in roots.chunks(WIDTH) {
            let me = out.nodes.len() as u32;
            out.nodes.push(wide_node(group));
            let b = group.iter().fold(Aabb::empty(), |a, (_, b)| union(a, *b));
            up.push((me, b));
        }
        roots = up;
    }
    out.nodes[0] = wide_node(&roots);
    out.ids.shrink_to_fit();
    out.tris = packets(ids, &out.ids);
    (out, Some(bounds_v))
}

/// A wide node whose children are the inner nodes `kids` (index, box).
fn wide_node(kids: &[(u32, Aabb)]) -> Node8 {
    let mut n = Node8::EMPTY;
    for (slot, (child, b)) in kids.iter().enumerate() {
        for a in 0..3 {
            n.bounds[2 * a][slot] = b.min[a];
            n.bounds[2 * a + 1][slot] = b.max[a];
        }
        n.child[slot] = *child;
    }
    n
}

/// Spreads the low 10 bits of `x` to every third bit (Morton interleave).
fn spread10(x: u32) -> u32 {
    let mut x = x & 0x3ff;
    x = (x | x << 16) & 0x30000ff;
    x = (x | x << 8) & 0x300f00f;
    x = (x | x << 4) & 0x30c30c3;
    x = (x | x << 2) & 0x9249249;
    x
}

/// Builds obvhs's BVH over the triangles `gids` (global ids) and flattens it into `out`'s
/// nodes and packet ids; returns the index of its root wide node and its box.
fn build_part(ids: &TriIds, gids: &[u32], out: &mut Built) -> (u32, Aabb) {
    let bvh2 = binary_bvh(ids, gids);
    let root_box = *bvh2.nodes[0].aabb();
    let plan = WidePlan::new(&bvh2);
    let root = flatten(&bvh2, &plan, gids, &mut out.nodes, &mut out.ids);
    (root, root_box)
}

/// obvhs's binary BVH over the triangles `gids` (global ids; its primitive k is `gids[k]`), one
/// triangle per leaf: PLOC, then reinsertion sized by [`reinsertion_ratio`]. Leaves are grouped
/// later, by [`WidePlan`], for the wide layout's packet costs.
pub(super) fn binary_bvh(ids: &TriIds, gids: &[u32]) -> Bvh2 {
    let n = gids.len();
    let leaves: Vec<Bvh2Node> = gids
        .par_iter()
        .enumerate()
        .map(|(k, &g)| Bvh2Node::new(tri_aabb(&ids.corners(g)), 1, k as u32))
        .collect();
    let total = leaves
        .par_iter()
        .map(|l| *l.aabb())
        .reduce(Aabb::empty, union);
    let mut bvh2 = Bvh2 {
        primitive_indices: (0..n as u32).collect(),
        ..Default::default()
    };
    {
        let mut ploc = PlocBuilder::new();
        ploc.current_nodes = leaves;
        // obvhs `medium_build`: search distance 14, 1 for the first three levels, 64-bit codes.
        ploc.build_ploc_from_leaves::<PLOC_SEARCH, false>(&mut bvh2, total, SortPrecision::U64, 3);
    }
    ReinsertionOptimizer::default().run(&mut bvh2, reinsertion_ratio(n), None);
    bvh2.parents = Vec::new();
    bvh2
}

/// The triangle packets of `ids` (global triangle ids per lane), built in parallel into one
/// allocation of the exact size (a growing `Vec` of 64-byte aligned packets would be copied
/// on every growth, two copies resident at once).
fn packets(tri_ids: &TriIds, ids: &[[u32; LANES]]) -> Vec<TriPack> {
    ids.par_iter()
        .map(|lanes| {
            let mut pk = TriPack::default();
            for (k, &g) in lanes.iter().enumerate() {
                if g != u32::MAX {
                    let p = tri_ids.corners(g);
                    pk.set(k, p[0], p[1], p[2]);
                }
            }
            pk
        })
        .collect()
}
