//! Ray acceleration: one obvhs CWBVH over every triangle of every mesh, closest-hit and shadow
//! queries, and the mapping of BVH primitives back to (mesh, triangle).

use super::Mesh;
use crate::math::Vec3;
use glam::Vec3A;
use obvhs::BvhBuildParams;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::ray::{Ray, RayHit};
use obvhs::rt_triangle::RtTriangle;
use obvhs::triangle::Triangle;

/// A closest hit: distance along the (unit) ray direction and the triangle that was hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray in world units (direction is unit length).
    pub t: f32,
    /// Index of the mesh in the scene.
    pub mesh: u32,
    /// Triangle index inside the mesh.
    pub prim: u32,
}

/// The scene's bounding volume hierarchy. Triangles are stored in BVH leaf order, so the leaf
/// index obvhs hands to the intersection callback addresses them directly (no indirection).
pub struct Accel {
    bvh: Option<CwBvh>,
    /// Intersection-optimised triangles in BVH order.
    tris: Vec<RtTriangle>,
    /// (mesh, triangle) of each entry of `tris`.
    ids: Vec<[u32; 2]>,
    /// World-space bounds of all geometry (min, max); both zero for an empty scene.
    bounds: (Vec3, Vec3),
}

impl Accel {
    /// Builds the BVH over all triangles of `meshes` (obvhs `medium_build` preset).
    pub fn build(meshes: &[Mesh]) -> Accel {
        let mut tris = Vec::new();
        let mut ids = Vec::new();
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for (mi, mesh) in meshes.iter().enumerate() {
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
                tris.push(Triangle {
                    v0: p[0].into(),
                    v1: p[1].into(),
                    v2: p[2].into(),
                });
                ids.push([mi as u32, ti as u32]);
            }
        }
        if tris.is_empty() {
            return Accel {
                bvh: None,
                tris: Vec::new(),
                ids: Vec::new(),
                bounds: (Vec3::ZERO, Vec3::ZERO),
            };
        }
        let bvh = build_cwbvh_from_tris(
            &tris,
            BvhBuildParams::medium_build(),
            &mut std::time::Duration::default(),
        );
        let ordered: Vec<RtTriangle> = bvh
            .primitive_indices
            .iter()
            .map(|&i| RtTriangle::from(&tris[i as usize]))
            .collect();
        let ordered_ids = bvh
            .primitive_indices
            .iter()
            .map(|&i| ids[i as usize])
            .collect();
        Accel {
            bvh: Some(bvh),
            tris: ordered,
            ids: ordered_ids,
            bounds: (lo, hi),
        }
    }

    /// Number of triangles in the hierarchy.
    pub fn triangle_count(&self) -> usize {
        self.ids.len()
    }

    /// Axis-aligned bounds (min, max) of all geometry in world units.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    /// Closest hit along `o + t d` for t in (0, tmax]; `d` must be unit length.
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, tmax: f32) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        let ray = Ray::new(o.into(), positive_zeros(d), 0.0, tmax);
        let mut hit = RayHit::none();
        if bvh.ray_traverse(ray, &mut hit, |r, id| self.tris[id].intersect(r)) {
            let [mesh, prim] = self.ids[hit.primitive_id as usize];
            Some(Hit {
                t: hit.t,
                mesh,
                prim,
            })
        } else {
            None
        }
    }

    /// True if anything blocks `o + t d` for t in (0, tmax] (shadow rays).
    #[inline]
    pub fn occluded(&self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        let Some(bvh) = self.bvh.as_ref() else {
            return false;
        };
        let ray = Ray::new(o.into(), positive_zeros(d), 0.0, tmax);
        !bvh.ray_traverse_miss(ray, |r, id| self.tris[id].intersect(r))
    }
}

/// obvhs 0.4 picks the traversal octant and the inverse direction from different sign tests,
/// so a −0.0 component makes it miss; adding +0.0 turns every −0.0 into +0.0 (IEEE 754).
#[inline]
fn positive_zeros(d: Vec3) -> Vec3A {
    Vec3A::from(d) + Vec3A::ZERO
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
