//! The instance level of the BVH (Mitsuba's `shapegroup` + `instance`): one bottom-level
//! hierarchy per shapegroup, built once over its object-space meshes with the same builder and
//! 8-wide traversal as the scene's, and a top-level binary BVH (obvhs PLOC) over the instances'
//! world boxes. A ray that enters an instance's box is moved to the group's object space
//! (`to_object`, direction not renormalised, so t is the same parameter in both spaces) and
//! traverses the group's hierarchy; so a group's triangles are stored once however many
//! instances place it.

use super::Hit;
use super::build::{self, TriIds};
use super::node::{FAR_SCALE, Node8};
use super::traverse;
use super::tri::{LANES, TriPack};
use crate::geometry::Mesh;
use crate::math::simd::Isa;
use crate::math::{Mat4, Vec2, Vec3};
use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::ploc::{PlocBuilder, SortPrecision};

/// One shapegroup's hierarchy (object space).
struct Blas {
    nodes: Vec<Node8>,
    tris: Vec<TriPack>,
    ids: Vec<[u32; LANES]>,
    /// Global id of each scene mesh's first triangle, counting only this group's meshes.
    mesh_first: Vec<u32>,
    /// Object-space bounds, None for a group without triangles.
    bounds: Option<(Vec3, Vec3)>,
}

/// An instance as the traversal needs it.
struct Inst {
    /// World → group space.
    to_object: Mat4,
    /// Index of its group's hierarchy.
    blas: u32,
    /// The scene mesh that is this instance (what a hit reports as `inst`).
    mesh: u32,
}

/// The top-level BVH over instances and the groups' hierarchies.
pub(super) struct InstanceLevel {
    blas: Vec<Blas>,
    insts: Vec<Inst>,
    /// obvhs binary nodes over `insts` (root first); a leaf's primitives are
    /// `order[first_index..first_index + prim_count]`.
    tlas: Vec<Bvh2Node>,
    order: Vec<u32>,
    /// World bounds of every instance (min, max).
    pub bounds: Option<(Vec3, Vec3)>,
}

/// The box of `b` moved by the affine `m` (its eight corners).
fn transform_box(m: &Mat4, (lo, hi): (Vec3, Vec3)) -> Aabb {
    let mut out = Aabb::empty();
    for k in 0..8 {
        let c = Vec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
        let w = Vec3A::from(m.transform_point3(c));
        out.min = out.min.min(w);
        out.max = out.max.max(w);
    }
    out
}

impl InstanceLevel {
    /// Builds every group's hierarchy and the top level over the instance meshes of `meshes`;
    /// None if the scene has no instance.
    pub fn build(meshes: &[Mesh], part_tris: usize) -> Option<InstanceLevel> {
        let placed: Vec<u32> = (0..meshes.len() as u32)
            .filter(|&i| meshes[i as usize].instance.is_some())
            .collect();
        if placed.is_empty() {
            return None;
        }
        let groups = meshes
            .iter()
            .filter_map(|m| m.group)
            .chain(
                placed
                    .iter()
                    .filter_map(|&i| meshes[i as usize].instance.as_ref().map(|p| p.group)),
            )
            .max()
            .map_or(0, |g| g as usize + 1);
        let blas: Vec<Blas> = (0..groups as u32)
            .map(|g| {
                let ids = TriIds::new_filtered(meshes, |m| m.group == Some(g));
                let (built, bounds) = build::build(&ids, part_tris);
                Blas {
                    nodes: built.nodes,
                    tris: built.tris,
                    ids: built.ids,
                    mesh_first: ids.first,
                    bounds,
                }
            })
            .collect();
        let mut insts = Vec::new();
        let mut leaves = Vec::new();
        let mut total = Aabb::empty();
        for &i in &placed {
            let Some(p) = &meshes[i as usize].instance else {
                continue;
            };
            let Some(b) = blas[p.group as usize].bounds else {
                continue;
            };
            let wb = transform_box(&p.to_world, b);
            total.min = total.min.min(wb.min);
            total.max = total.max.max(wb.max);
            leaves.push(Bvh2Node::new(wb, 1, insts.len() as u32));
            insts.push(Inst {
                to_object: p.to_object,
                blas: p.group,
                mesh: i,
            });
        }
        let mut tlas = Bvh2 {
            primitive_indices: (0..insts.len() as u32).collect(),
            ..Default::default()
        };
        if !leaves.is_empty() {
            let mut ploc = PlocBuilder::new();
            ploc.current_nodes = leaves;
            ploc.build_ploc_from_leaves::<14, false>(&mut tlas, total, SortPrecision::U64, 3);
        }
        let bounds = (!insts.is_empty()).then(|| (Vec3::from(total.min), Vec3::from(total.max)));
        Some(InstanceLevel {
            blas,
            insts,
            tlas: tlas.nodes,
            order: tlas.primitive_indices,
            bounds,
        })
    }

    /// Bytes held while rendering (group hierarchies, instances, top level).
    pub fn resident_bytes(&self) -> usize {
        let b: usize = self
            .blas
            .iter()
            .map(|b| {
                std::mem::size_of_val(b.nodes.as_slice())
                    + std::mem::size_of_val(b.tris.as_slice())
                    + std::mem::size_of_val(b.ids.as_slice())
                    + std::mem::size_of_val(b.mesh_first.as_slice())
            })
            .sum();
        b + std::mem::size_of_val(self.insts.as_slice())
            + std::mem::size_of_val(self.tlas.as_slice())
            + std::mem::size_of_val(self.order.as_slice())
    }

    /// Triangles stored in the groups' hierarchies (each once).
    pub fn triangle_count(&self) -> usize {
        self.blas
            .iter()
            .flat_map(|b| b.ids.iter().flatten())
            .filter(|&&g| g != u32::MAX)
            .count()
    }

    /// Visits the instances whose box `o + t d` enters within (0, tmax], nearest box first;
    /// `visit` gets the instance and the current tmax and returns the new tmax, or None to
    /// stop.
    #[inline]
    fn walk(&self, o: Vec3, d: Vec3, tmax: f32, mut visit: impl FnMut(&Inst, f32) -> Option<f32>) {
        if self.tlas.is_empty() {
            return;
        }
        let inv = Vec3A::ONE / Vec3A::from(d);
        let o = Vec3A::from(o);
        let enter = |b: &Aabb, tmax: f32| -> Option<f32> {
            let t0 = (b.min - o) * inv;
            let t1 = (b.max - o) * inv;
            let near = t0.min(t1).max_element().max(0.0);
            let far = t0.max(t1).min_element() * FAR_SCALE;
            (near <= far && near <= tmax).then_some(near)
        };
        let mut tmax = tmax;
        let mut stack: Vec<(u32, f32)> = Vec::with_capacity(64);
        if let Some(t) = enter(self.tlas[0].aabb(), tmax) {
            stack.push((0, t));
        }
        while let Some((ni, t)) = stack.pop() {
            if t > tmax {
                continue;
            }
            let n = &self.tlas[ni as usize];
            if n.is_leaf() {
                let f = n.first_index as usize;
                for &k in &self.order[f..f + n.prim_count as usize] {
                    match visit(&self.insts[k as usize], tmax) {
                        Some(t) => tmax = t,
                        None => return,
                    }
                }
                continue;
            }
            let l = n.first_index;
            let tl = enter(self.tlas[l as usize].aabb(), tmax);
            let tr = enter(self.tlas[l as usize + 1].aabb(), tmax);
            match (tl, tr) {
                (Some(a), Some(b)) if a <= b => {
                    stack.push((l + 1, b));
                    stack.push((l, a));
                }
                (Some(a), Some(b)) => {
                    stack.push((l, a));
                    stack.push((l + 1, b));
                }
                (Some(a), None) => stack.push((l, a)),
                (None, Some(b)) => stack.push((l + 1, b)),
                (None, None) => {}
            }
        }
    }

    /// The closest instance hit nearer than `tmax` (else None).
    #[inline]
    pub fn intersect(&self, isa: Isa, o: Vec3, d: Vec3, tmax: f32) -> Option<Hit> {
        let mut best = None;
        self.walk(o, d, tmax, |inst, tmax| {
            let b = &self.blas[inst.blas as usize];
            let lo = inst.to_object.transform_point3(o);
            let ld = inst.to_object.transform_vector3(d);
            let h = traverse::run::<false>(isa, &b.nodes, &b.tris, lo, ld, tmax);
            if h.is_hit() && h.t < tmax {
                let g = b.ids[h.slot as usize / LANES][h.slot as usize % LANES];
                let (mesh, prim) = TriIds::locate(&b.mesh_first, g);
                best = Some(Hit {
                    t: h.t,
                    mesh,
                    prim,
                    b: Vec2::new(h.u, h.v),
                    inst: inst.mesh,
                });
                return Some(h.t);
            }
            Some(tmax)
        });
        best
    }

    /// True if some instance blocks `o + t d` for t in (0, tmax].
    #[inline]
    pub fn occluded(&self, isa: Isa, o: Vec3, d: Vec3, tmax: f32) -> bool {
        let mut hit = false;
        self.walk(o, d, tmax, |inst, tmax| {
            let b = &self.blas[inst.blas as usize];
            let lo = inst.to_object.transform_point3(o);
            let ld = inst.to_object.transform_vector3(d);
            if traverse::run::<true>(isa, &b.nodes, &b.tris, lo, ld, tmax).is_hit() {
                hit = true;
                return None;
            }
            Some(tmax)
        });
        hit
    }
}
