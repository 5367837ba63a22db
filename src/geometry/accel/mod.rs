//! Ray acceleration: obvhs builds a binary BVH (PLOC + reinsertion) over every triangle of
//! every mesh, straight from the mesh vertices and in parts for big scenes ([`build`]); the
//! SAH-optimal grouping of it into wide nodes and leaves of packet tests is chosen
//! ([`collapse`]) and flattened into an 8-wide BVH with SoA f32 child bounds ([`node`],
//! [`flatten`]; leaves of one node share 8-lane packets) and traverse that by hand ([`traverse`]): one 8-lane slab test per
//! node, front-to-back child order for closest hits, 8-triangle Möller–Trumbore leaf packets
//! ([`tri`]), and the hit's barycentrics returned so shading does not intersect the triangle
//! again. The traversal is compiled twice, for AVX2 ([`crate::math::simd::f8`]: one ymm register per 8-lane
//! step, also used on AVX-512 CPUs) and for the baseline (two SSE halves), and picked at runtime
//! by `simd::isa()`, so a baseline (SSE2) binary still runs 8-wide code on AVX2 machines. Both
//! builds return the same bits (no fused multiply-adds). Rows of sixteen coherent camera rays
//! go through one packet traversal instead ([`packet`], [`Accel::intersect16`]), which gives
//! every lane the one-ray hit.
//!
//! Why not obvhs's own CWBVH traversal: it decodes 8-bit quantised child boxes (u8 → f32 lane
//! by lane) at every node and sorts nothing; on incoherent rays it ran at ~1 Mray/s on 130k
//! triangles where this layout is several times faster (`cargo bench --bench traversal`).

mod build;
mod collapse;
mod flatten;
mod instances;
mod node;
mod packet;
mod stack;
mod traverse;
mod tri;

#[cfg(test)]
mod tests;

use super::Mesh;
use super::sphere::Sphere;
use crate::math::simd::f16::{F16, V3x};
use crate::math::simd::{self, Isa};
use crate::math::{Vec2, Vec3};
use node::Node8;
use tri::{LANES, TriPack};

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
    /// The instance mesh whose group was hit ([`NO_INSTANCE`] for the scene's own geometry);
    /// `mesh` and `prim` then name the group's object-space triangle.
    pub inst: u32,
}

/// [`Hit::inst`] of a hit on geometry that no instance placed.
pub const NO_INSTANCE: u32 = u32::MAX;

/// The scene's bounding volume hierarchy (8-wide, built from obvhs's binary BVH).
pub struct Accel {
    nodes: Vec<Node8>,
    /// Triangle packets in leaf order.
    tris: Vec<TriPack>,
    /// Global triangle id (see `mesh_first`) of each packet lane; u32::MAX in padding lanes,
    /// which are never hit.
    ids: Vec<[u32; LANES]>,
    /// Global id of each mesh's first triangle (the meshes' triangles numbered in order).
    mesh_first: Vec<u32>,
    /// World-space bounds of all geometry (min, max); both zero for an empty scene.
    bounds: (Vec3, Vec3),
    /// Analytic spheres and their mesh index, tested one by one next to the BVH (scenes
    /// have a handful; each costs one quadratic).
    spheres: Vec<(Sphere, u32)>,
    /// The instruction set the traversal runs in (`simd::isa()` at build time).
    isa: Isa,
    /// Shapegroups and the instances that place them; None in a scene without instances,
    /// which then runs the one-level traversal alone.
    instances: Option<Box<instances::InstanceLevel>>,
}

impl Accel {
    /// Builds the BVH over all triangles of `meshes` (obvhs's PLOC with `medium_build`'s
    /// settings, reinsertion sized by the triangle count, leaves of at most 24 triangles;
    /// big scenes in parts, see [`build`]) and flattens it to the 8-wide layout. The meshes
    /// must hold fewer than u32::MAX triangles in all (`RenderScene::new` checks).
    pub fn build(meshes: &[Mesh]) -> Accel {
        Self::build_in_parts(meshes, build::PART_TRIS)
    }

    /// [`Accel::build`] with parts of at most `part_tris` triangles.
    fn build_in_parts(meshes: &[Mesh], part_tris: usize) -> Accel {
        // Shapegroup members are stored once, in their group's own hierarchy.
        let ids = build::TriIds::new_filtered(meshes, |m| m.group.is_none());
        let instances = instances::InstanceLevel::build(meshes, part_tris).map(Box::new);
        let (built, tri_bounds) = build::build(&ids, part_tris);
        let mut spheres = Vec::new();
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for (mi, mesh) in meshes.iter().enumerate() {
            if let (Some(s), None) = (mesh.sphere, mesh.group) {
                let (a, b) = s.bounds();
                lo = lo.min(a);
                hi = hi.max(b);
                spheres.push((s, mi as u32));
            }
        }
        if let Some((a, b)) = tri_bounds {
            lo = lo.min(a);
            hi = hi.max(b);
        }
        let inst_bounds = instances.as_ref().and_then(|i| i.bounds);
        if let Some((a, b)) = inst_bounds {
            lo = lo.min(a);
            hi = hi.max(b);
        }
        let bounds = if spheres.is_empty() && tri_bounds.is_none() && inst_bounds.is_none() {
            (Vec3::ZERO, Vec3::ZERO)
        } else {
            (lo, hi)
        };
        Accel {
            nodes: built.nodes,
            tris: built.tris,
            ids: built.ids,
            mesh_first: ids.first,
            bounds,
            spheres,
            isa: simd::isa(),
            instances,
        }
    }

    /// Bytes held by the hierarchy (nodes, packets, lane ids) while rendering.
    pub fn resident_bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.tris.as_slice())
            + std::mem::size_of_val(self.ids.as_slice())
            + std::mem::size_of_val(self.mesh_first.as_slice())
            + self.instances.as_ref().map_or(0, |i| i.resident_bytes())
    }

    /// Number of triangles in the hierarchy.
    pub fn triangle_count(&self) -> usize {
        self.ids
            .iter()
            .flatten()
            .filter(|&&g| g != u32::MAX)
            .count()
            + self.instances.as_ref().map_or(0, |i| i.triangle_count())
    }

    /// Axis-aligned bounds (min, max) of all geometry in world units.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    /// Closest hit along `o + t d` for t in (0, tmax]; `d` must be unit length.
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, tmax: f32) -> Option<Hit> {
        self.intersect_isa(self.isa, o, d, tmax)
    }

    /// True if anything blocks `o + t d` for t in (0, tmax] (shadow rays).
    #[inline]
    pub fn occluded(&self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        self.occluded_isa(self.isa, o, d, tmax)
    }

    /// [`Accel::intersect`] with the traversal built for `isa` (one `simd::isa()` allows).
    #[inline]
    fn intersect_isa(&self, isa: Isa, o: Vec3, d: Vec3, tmax: f32) -> Option<Hit> {
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
                    inst: NO_INSTANCE,
                });
            }
        }
        if !self.nodes.is_empty() {
            let h = traverse::run::<false>(isa, &self.nodes, &self.tris, o, d, tmax);
            if h.is_hit() {
                tmax = h.t;
                best = Some(self.hit_of(h));
            }
        }
        match &self.instances {
            None => best,
            Some(level) => level.intersect(isa, o, d, tmax).or(best),
        }
    }

    /// Closest hits of up to sixteen coherent rays (`o`, `d` per axis, lane l; unit directions)
    /// in (0, tmax[l]] for the lanes set in `active`, into `out`, by one packet traversal (a row
    /// of camera rays): each lane gets exactly what [`Accel::intersect`] returns for its ray.
    /// Returns false, leaving `out` alone, where a packet does not pay and the rays must be
    /// traced one at a time: their direction signs differ, fewer than four lanes are active,
    /// or not [`Accel::packets_pay`].
    pub fn intersect16(
        &self,
        o: &[[f32; 16]; 3],
        d: &[[f32; 16]; 3],
        tmax: &[f32; 16],
        active: u32,
        out: &mut [Option<Hit>; 16],
    ) -> bool {
        self.intersect16_isa(self.isa, o, d, tmax, active, out)
    }

    /// True if [`Accel::intersect16`] can trace a packet in this scene: the tree has nodes
    /// below its root to share, and no analytic spheres or instances (which the one-ray
    /// traversal handles).
    #[inline]
    pub fn packets_pay(&self) -> bool {
        self.nodes.len() > 1 && self.spheres.is_empty() && self.instances.is_none()
    }

    /// [`Accel::intersect16`] with the traversal built for `isa` (one `simd::isa()` allows).
    fn intersect16_isa(
        &self,
        isa: Isa,
        o: &[[f32; 16]; 3],
        d: &[[f32; 16]; 3],
        tmax: &[f32; 16],
        active: u32,
        out: &mut [Option<Hit>; 16],
    ) -> bool {
        if !self.packets_pay() || active.count_ones() < 4 {
            return false;
        }
        let Some(hits) = packet::run16(isa, &self.nodes, &self.tris, o, d, tmax, active) else {
            return false;
        };
        let mut m = active;
        while m != 0 {
            let l = m.trailing_zeros() as usize;
            m &= m - 1;
            out[l] = hits[l].is_hit().then(|| self.hit_of(hits[l]));
        }
        true
    }

    /// The scene hit of a traversal result.
    #[inline(always)]
    fn hit_of(&self, h: traverse::SlotHit) -> Hit {
        let g = self.ids[h.slot as usize / LANES][h.slot as usize % LANES];
        let (mesh, prim) = build::TriIds::locate(&self.mesh_first, g);
        Hit {
            t: h.t,
            mesh,
            prim,
            b: Vec2::new(h.u, h.v),
            inst: NO_INSTANCE,
        }
    }

    /// [`Accel::occluded`] with the traversal built for `isa` (one `simd::isa()` allows).
    #[inline]
    fn occluded_isa(&self, isa: Isa, o: Vec3, d: Vec3, tmax: f32) -> bool {
        self.spheres
            .iter()
            .any(|(s, _)| s.intersect(o, d, tmax).is_some())
            || (!self.nodes.is_empty()
                && traverse::run::<true>(isa, &self.nodes, &self.tris, o, d, tmax).is_hit())
            || self
                .instances
                .as_ref()
                .is_some_and(|level| level.occluded(isa, o, d, tmax))
    }
}

/// [`offset_origin`] per lane.
#[inline(always)]
pub fn offset_origin_x(p: V3x, n: V3x, d: V3x) -> V3x {
    let mag = 1.0 + p.abs_max_element();
    let off = n.scale(mag * OFFSET_SCALE);
    V3x::select(n.dot(d).ge(F16::splat(0.0)), p.add(off), p.sub(off))
}

/// Scale of the origin offset relative to the magnitude of the coordinates (≈ 2⁻¹⁶; the hit
/// point is reconstructed from barycentrics with an error of a few ulps of |p|).
const OFFSET_SCALE: f32 = 1.0 / 65536.0;

/// Moves a surface point off its surface along the geometric normal `n`, to the side `d` points
/// to, by an amount that grows with the coordinates' magnitude, so that a ray spawned there does
/// not re-hit the surface it starts on.
/// (Scalar `Vec3` arithmetic, so the packet kernels' lane loops vectorise it to the same bits.)
#[inline(always)]
pub fn offset_origin(p: Vec3, n: Vec3, d: Vec3) -> Vec3 {
    let mag = 1.0 + p.abs().max_element();
    let off = n * (mag * OFFSET_SCALE);
    if n.dot(d) >= 0.0 { p + off } else { p - off }
}
