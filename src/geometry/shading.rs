//! Turning a BVH hit into a full [`SurfaceInteraction`], following Mitsuba 3's `Mesh`:
//! position re-interpolated from barycentrics, face normal from the winding, interpolated unit
//! shading normal, uv interpolation and ∂p/∂u, ∂p/∂v from the uv parameterisation.

use super::accel::{Hit, NO_INSTANCE};
use super::mesh::Placement;
use super::{Mesh, SurfaceInteraction};
use crate::math::frame::FrameX;
use crate::math::simd::f16::{F16, M16, V2x, V3x};
use crate::math::{Frame, Vec2, Vec3};

/// Barycentrics (b1, b2) of the point where the line `o + t d` meets the plane of (p0, p1, p2)
/// (Möller–Trumbore, normalised by the determinant), clamped into the triangle.
#[inline]
pub fn barycentrics(p0: Vec3, p1: Vec3, p2: Vec3, o: Vec3, d: Vec3) -> Vec2 {
    let e1 = p1 - p0;
    let e2 = p2 - p0;
    let pvec = d.cross(e2);
    let det = e1.dot(pvec);
    if det == 0.0 || !det.is_finite() {
        return Vec2::new(1.0 / 3.0, 1.0 / 3.0);
    }
    let inv = 1.0 / det;
    let tvec = o - p0;
    let qvec = tvec.cross(e1);
    let b1 = (tvec.dot(pvec) * inv).clamp(0.0, 1.0);
    let b2 = (d.dot(qvec) * inv).clamp(0.0, 1.0);
    let s = b1 + b2;
    if s > 1.0 {
        Vec2::new(b1 / s, b2 / s)
    } else {
        Vec2::new(b1, b2)
    }
}

/// Position, unit geometric normal and unit shading normal at barycentrics `b` of triangle
/// `prim` (what light sampling needs; the same arithmetic as [`eval_triangle`]).
#[inline]
pub fn eval_position_normals(mesh: &Mesh, prim: u32, b: Vec2) -> (Vec3, Vec3, Vec3) {
    let [i0, i1, i2] = mesh.indices[prim as usize].map(|i| i as usize);
    let (p0, p1, p2) = (mesh.positions[i0], mesh.positions[i1], mesh.positions[i2]);
    let b0 = 1.0 - b.x - b.y;
    let p = p0 * b0 + p1 * b.x + p2 * b.y;
    let n = (p1 - p0).cross(p2 - p0).normalize_or_zero();
    let ns = if mesh.normals.is_empty() {
        n
    } else {
        let s = mesh.normals[i0] * b0 + mesh.normals[i1] * b.x + mesh.normals[i2] * b.y;
        let s = s.normalize_or_zero();
        if s == Vec3::ZERO { n } else { s }
    };
    (p, n, ns)
}

/// Surface data at barycentrics `b` of triangle `prim` of `mesh`: (p, n_geo, n_shading, uv, dpdu, dpdv).
#[inline]
pub fn eval_triangle(mesh: &Mesh, prim: u32, b: Vec2) -> (Vec3, Vec3, Vec3, Vec2, Vec3, Vec3) {
    let [i0, i1, i2] = mesh.indices[prim as usize].map(|i| i as usize);
    let p = [mesh.positions[i0], mesh.positions[i1], mesh.positions[i2]];
    let normals =
        (!mesh.normals.is_empty()).then(|| [mesh.normals[i0], mesh.normals[i1], mesh.normals[i2]]);
    let uvs = (!mesh.uvs.is_empty()).then(|| [mesh.uvs[i0], mesh.uvs[i1], mesh.uvs[i2]]);
    triangle_surface(p, normals, uvs, b)
}

/// The placement of an instance hit (None for the scene's own geometry).
#[inline]
pub fn placement<'m>(meshes: &'m [Mesh], hit: &Hit) -> Option<&'m Placement> {
    if hit.inst == NO_INSTANCE {
        return None;
    }
    meshes[hit.inst as usize].instance.as_deref()
}

/// The corners of triangle `prim` with its vertex normals and uvs where the mesh has them.
#[inline]
#[allow(clippy::type_complexity)]
pub fn triangle_vertices(
    mesh: &Mesh,
    prim: u32,
) -> ([Vec3; 3], Option<[Vec3; 3]>, Option<[Vec2; 3]>) {
    let [i0, i1, i2] = mesh.indices[prim as usize].map(|i| i as usize);
    let p = [mesh.positions[i0], mesh.positions[i1], mesh.positions[i2]];
    let normals =
        (!mesh.normals.is_empty()).then(|| [mesh.normals[i0], mesh.normals[i1], mesh.normals[i2]]);
    let uvs = (!mesh.uvs.is_empty()).then(|| [mesh.uvs[i0], mesh.uvs[i1], mesh.uvs[i2]]);
    (p, normals, uvs)
}

/// [`eval_triangle`] on a triangle's gathered vertices (positions, optional unit normals and
/// uvs): the arithmetic the packet kernels run lane by lane, so both give the same bits.
#[inline(always)]
pub fn triangle_surface(
    [p0, p1, p2]: [Vec3; 3],
    normals: Option<[Vec3; 3]>,
    uvs: Option<[Vec2; 3]>,
    b: Vec2,
) -> (Vec3, Vec3, Vec3, Vec2, Vec3, Vec3) {
    let b0 = 1.0 - b.x - b.y;
    let p = p0 * b0 + p1 * b.x + p2 * b.y;
    let dp0 = p1 - p0;
    let dp1 = p2 - p0;
    let n = dp0.cross(dp1).normalize_or_zero();
    let ns = match normals {
        None => n,
        Some([n0, n1, n2]) => {
            let s = n0 * b0 + n1 * b.x + n2 * b.y;
            let s = s.normalize_or_zero();
            if s == Vec3::ZERO { n } else { s }
        }
    };
    let (uv, dpdu, dpdv) = match uvs {
        None => (b, dp0, dp1),
        Some([t0, t1, t2]) => {
            let uv = t0 * b0 + t1 * b.x + t2 * b.y;
            let duv0 = t1 - t0;
            let duv1 = t2 - t0;
            let det = duv0.x * duv1.y - duv0.y * duv1.x;
            if det != 0.0 && det.is_finite() {
                let inv = 1.0 / det;
                (
                    uv,
                    (dp0 * duv1.y - dp1 * duv0.y) * inv,
                    (dp1 * duv0.x - dp0 * duv1.x) * inv,
                )
            } else {
                let f = Frame::from_normal(n);
                (uv, f.s, f.t)
            }
        }
    };
    (p, n, ns, uv, dpdu, dpdv)
}

/// [`triangle_surface`] per lane: `has_normals` / `has_uvs` say which lanes' `normals` /
/// `uvs` are real (the others are ignored). Returns (p, n_geo, n_shading, uv, dpdu, dpdv).
#[inline(always)]
#[allow(clippy::type_complexity)]
pub fn triangle_surface_x(
    [p0, p1, p2]: [V3x; 3],
    has_normals: M16,
    [n0, n1, n2]: [V3x; 3],
    has_uvs: M16,
    [t0, t1, t2]: [V2x; 3],
    b: V2x,
) -> (V3x, V3x, V3x, V2x, V3x, V3x) {
    let b0 = 1.0 - b.x - b.y;
    let p = p0.scale(b0).add(p1.scale(b.x)).add(p2.scale(b.y));
    let dp0 = p1.sub(p0);
    let dp1 = p2.sub(p0);
    let n = dp0.cross(dp1).normalize_or_zero();
    let s = n0.scale(b0).add(n1.scale(b.x)).add(n2.scale(b.y));
    let s = s.normalize_or_zero();
    let ns = V3x::select(has_normals.and(s.is_zero().not()), s, n);
    let uv = t0.scale(b0).add(t1.scale(b.x)).add(t2.scale(b.y));
    let duv0 = t1.sub(t0);
    let duv1 = t2.sub(t0);
    let det = duv0.x * duv1.y - duv0.y * duv1.x;
    let det_ok = det.ne(F16::splat(0.0)).and(det.is_finite());
    let inv = 1.0 / det;
    let du = dp0.scale(duv1.y).sub(dp1.scale(duv0.y)).scale(inv);
    let dv = dp1.scale(duv0.x).sub(dp0.scale(duv1.x)).scale(inv);
    let f = FrameX::from_normal(n);
    let du = V3x::select(det_ok, du, f.s);
    let dv = V3x::select(det_ok, dv, f.t);
    (
        p,
        n,
        ns,
        V2x::select(has_uvs, uv, b),
        V3x::select(has_uvs, du, dp0),
        V3x::select(has_uvs, dv, dp1),
    )
}

/// The full interaction for a hit of the unit-direction ray `o + t d` (the hit's barycentrics
/// place a triangle's point; an analytic sphere's point is `o + t d` re-projected onto it).
pub fn surface_interaction(meshes: &[Mesh], o: Vec3, d: Vec3, hit: &Hit) -> SurfaceInteraction {
    let mesh = &meshes[hit.mesh as usize];
    let (p, n, ns, uv, dpdu, dpdv) = match &mesh.sphere {
        Some(s) => {
            let (p, n, uv, dpdu, dpdv) = s.surface(o, d, hit.t);
            (p, n, n, uv, dpdu, dpdv)
        }
        None => match placement(meshes, hit) {
            None => eval_triangle(mesh, hit.prim, hit.b),
            Some(pl) => {
                let (p, normals, uvs) = triangle_vertices(mesh, hit.prim);
                let (p, normals) = pl.triangle_to_world(p, normals);
                let (p, n, ns, uv, dpdu, dpdv) = triangle_surface(p, normals, uvs, hit.b);
                let (n, ns) = pl.orient(n, ns, normals.is_some());
                (p, n, ns, uv, dpdu, dpdv)
            }
        },
    };
    let sh_frame = Frame::from_normal_tangent(ns, dpdu);
    SurfaceInteraction {
        p,
        t: hit.t,
        n,
        sh_frame,
        uv,
        dpdu,
        dpdv,
        wi: sh_frame.to_local(-d),
        mesh: hit.mesh,
        prim: hit.prim,
        bary: if mesh.sphere.is_some() {
            Vec2::ZERO
        } else {
            hit.b
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::accel::Accel;

    fn tri(uvs: bool, normals: bool) -> Mesh {
        Mesh {
            name: "t".into(),
            positions: vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(0.0, 2.0, 0.0),
            ],
            normals: if normals {
                vec![Vec3::Z, Vec3::new(1.0, 0.0, 1.0).normalize(), Vec3::Z]
            } else {
                vec![]
            },
            uvs: if uvs {
                vec![
                    Vec2::new(0.0, 1.0),
                    Vec2::new(0.0, 0.0),
                    Vec2::new(1.0, 1.0),
                ]
            } else {
                vec![]
            },
            indices: vec![[0, 1, 2]],
            ..Default::default()
        }
    }

    #[test]
    fn barycentrics_position_and_face_normal() {
        let meshes = vec![tri(false, false)];
        let accel = Accel::build(&meshes);
        let o = Vec3::new(0.5, 0.25, 3.0);
        let h = accel.intersect(o, -Vec3::Z, f32::INFINITY).unwrap();
        let si = surface_interaction(&meshes, o, -Vec3::Z, &h);
        assert!((si.p - Vec3::new(0.5, 0.25, 0.0)).length() < 1e-6);
        assert!((si.uv - Vec2::new(0.25, 0.125)).length() < 1e-6);
        assert_eq!(si.n, Vec3::Z);
        assert_eq!(si.dpdu, Vec3::new(2.0, 0.0, 0.0));
        assert_eq!(si.dpdv, Vec3::new(0.0, 2.0, 0.0));
        assert!((si.sh_frame.s - Vec3::X).length() < 1e-6);
        assert!((si.wi - Vec3::Z).length() < 1e-6);
    }

    #[test]
    fn uv_derivatives_and_shading_normal() {
        let meshes = vec![tri(true, true)];
        let o = Vec3::new(0.0, 0.0, 3.0) + Vec3::new(1e-3, 1e-3, 0.0);
        let m = &meshes[0];
        let b = barycentrics(m.positions[0], m.positions[1], m.positions[2], o, -Vec3::Z);
        let h = Hit {
            t: 3.0,
            mesh: 0,
            prim: 0,
            b,
            inst: crate::geometry::accel::NO_INSTANCE,
        };
        let si = surface_interaction(&meshes, o, -Vec3::Z, &h);
        // uv(p) = (y/2, 1 - x/2)  ⇒ ∂p/∂u = (0, 2, 0), ∂p/∂v = (-2, 0, 0).
        assert!((si.dpdu - Vec3::new(0.0, 2.0, 0.0)).length() < 1e-5);
        assert!((si.dpdv - Vec3::new(-2.0, 0.0, 0.0)).length() < 1e-5);
        assert!((si.sh_frame.n.length() - 1.0).abs() < 1e-6);
        // Near vertex 0 the shading normal is ≈ +z; s follows ∂p/∂u projected.
        assert!((si.sh_frame.s - Vec3::Y).length() < 1e-2);
        // At vertex 1 the shading normal tilts toward +x.
        let (_, _, ns, _, _, _) = eval_triangle(&meshes[0], 0, Vec2::new(1.0, 0.0));
        assert!((ns - Vec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-6);
        // The light-sampling subset is bit-identical to the full evaluation.
        for b in [
            Vec2::new(1.0, 0.0),
            Vec2::new(0.2, 0.3),
            Vec2::new(0.0, 0.9),
        ] {
            let (p, n, ns, _, _, _) = eval_triangle(&meshes[0], 0, b);
            assert_eq!(eval_position_normals(&meshes[0], 0, b), (p, n, ns));
        }
    }
}
