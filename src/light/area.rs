//! Area light on a triangle mesh (Mitsuba `area` emitter): uniform sampling by area, one-sided
//! emission toward the shading normal's side; the radiance a constant or a texture over the
//! mesh's uvs.

// `!(x > 0.0)` deliberately also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::{LightSample, LightSampleX};
use crate::bsdf::Texture;
use crate::geometry::{Mesh, SurfaceInteraction};
use crate::math::distribution::Distribution1D;
use crate::math::simd::f16::{F16, M16, V2x, V3x};
use crate::math::{Spectrum, Vec2, Vec3, warp};

/// Uniform area sampling over one emissive mesh (triangles chosen by area).
#[derive(Clone, Debug)]
pub struct AreaLight {
    /// Index of the emissive mesh in the scene.
    pub mesh: u32,
    /// Emitted radiance (W/(m²·sr)) where `texture` is None.
    pub radiance: Spectrum,
    /// A spatially varying radiance (Mitsuba: a `<texture name="radiance">`), looked up at the
    /// uv of the emitting point; it replaces `radiance`.
    texture: Option<Texture>,
    /// Per triangle, the uvs of its corners when `texture` is set (the barycentric corners
    /// for a mesh without uvs, as the hit's uv is then the barycentric); else empty.
    uvs: Vec<[Vec2; 3]>,
    tris: Distribution1D,
    /// 1 / total area (1/m²).
    inv_area: f32,
    /// Per triangle: what sampling needs, gathered once (no index lookups per sample).
    geo: Vec<AreaTri>,
}

impl AreaLight {
    /// The light of mesh `mi` with constant `radiance`, or with the radiance `texture` (which
    /// replaces it) if one is given; None for a zero-area mesh (it can neither be hit nor
    /// sampled, so it contributes nothing).
    pub fn new(
        mesh: &Mesh,
        mi: u32,
        radiance: Spectrum,
        texture: Option<Texture>,
    ) -> Option<AreaLight> {
        let areas = (0..mesh.indices.len()).map(|t| mesh.triangle_area(t) as f64);
        let tris = Distribution1D::new(areas)?;
        let inv_area = (1.0 / tris.total()) as f32;
        let geo = (0..mesh.indices.len())
            .map(|t| AreaTri::new(mesh, t))
            .collect();
        let uvs = match (&texture, mesh.uvs.is_empty()) {
            (None, _) => Vec::new(),
            (Some(_), true) => vec![[Vec2::ZERO, Vec2::X, Vec2::Y]; mesh.indices.len()],
            (Some(_), false) => mesh
                .indices
                .iter()
                .map(|t| t.map(|i| mesh.uvs[i as usize]))
                .collect(),
        };
        Some(AreaLight {
            mesh: mi,
            radiance,
            texture,
            uvs,
            tris,
            inv_area,
            geo,
        })
    }

    /// Samples a point on the mesh as seen from `p` (pdf in solid angle, no selection).
    #[inline]
    pub fn sample_li(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        let (t, ux) = self.pick(u.x);
        let b = warp::square_to_uniform_triangle(Vec2::new(ux, u.y));
        sample_toward(
            self.radiance_at(t, b),
            self.inv_area,
            p,
            self.triangle(t).eval(b),
        )
    }

    /// Radiance emitted at barycentrics `b` of triangle `t` (the uv interpolated as a hit's).
    #[inline]
    pub fn radiance_at(&self, t: u32, b: Vec2) -> Spectrum {
        match &self.texture {
            None => self.radiance,
            Some(tex) => {
                let [t0, t1, t2] = self.uvs[t as usize];
                tex.eval(t0 * (1.0 - b.x - b.y) + t1 * b.x + t2 * b.y)
            }
        }
    }

    /// Radiance emitted at the hit `si` of this mesh (toward any direction on its side).
    #[inline]
    pub fn radiance_at_hit(&self, si: &SurfaceInteraction) -> Spectrum {
        match &self.texture {
            None => self.radiance,
            Some(tex) => tex.eval(si.uv),
        }
    }

    /// The triangle (index for [`AreaLight::triangle`]) that sample number `ux` selects by
    /// area, and `ux` rescaled to [0, 1) within it, for the triangle's own warp.
    #[inline]
    pub fn pick(&self, ux: f32) -> (u32, f32) {
        let (t, _, ux) = self.tris.sample(ux);
        (t as u32, ux)
    }

    /// [`AreaLight::pick`] for 16 lanes: the triangle indices and the re-scaled numbers.
    #[inline(always)]
    pub fn pick_x(&self, ux: F16) -> ([u32; 16], F16) {
        let (t, _, ux) = self.tris.sample_x(ux);
        (t, ux)
    }

    /// Triangle `t` (an index [`AreaLight::pick_x`] returned).
    #[inline]
    pub fn triangle(&self, t: u32) -> &AreaTri {
        &self.geo[t as usize]
    }

    /// 1 / total area (1/m²).
    #[inline]
    pub fn inv_area(&self) -> f32 {
        self.inv_area
    }

    /// `sel` × the solid-angle pdf with which [`AreaLight::sample_li`] from `p_ref` produces the
    /// point `si` of this mesh (`sel`: the selection probability, 1 for none; folded in first so
    /// the product rounds as it always has).
    #[inline]
    pub fn pdf_li(&self, sel: f32, p_ref: Vec3, si: &SurfaceInteraction) -> f32 {
        let d2 = (si.p - p_ref).length_squared();
        let cos_l = si.wi.z.abs();
        if !(cos_l > 0.0) {
            return 0.0;
        }
        sel * self.inv_area * d2 / cos_l
    }
}

/// The rest of [`AreaLight::sample_li`] once the point is placed: `(pl, ng, ns)` (position,
/// geometric and shading normal) seen from `p`, for a light of `radiance` and 1/area
/// `inv_area`. None below the light's horizon or at zero distance. Shared with the packet
/// kernels, which run it lane by lane.
#[inline(always)]
pub fn sample_toward(
    radiance: Spectrum,
    inv_area: f32,
    p: Vec3,
    (pl, ng, ns): (Vec3, Vec3, Vec3),
) -> Option<LightSample> {
    let to = pl - p;
    let d2 = to.length_squared();
    if !(d2 > 0.0) {
        return None;
    }
    let dist = d2.sqrt();
    let wi = to / dist;
    let cos_l = -ns.dot(wi);
    // One-sided: emits toward the side of the shading normal.
    if !(cos_l > 0.0) {
        return None;
    }
    let pdf = inv_area * d2 / cos_l;
    Some(LightSample {
        wi,
        dist,
        n_geo: ng,
        weight: radiance / pdf,
        pdf,
        delta: false,
    })
}

/// [`sample_toward`] per lane: (sample, valid) where valid is false for the lanes whose
/// sample is None (their values are not meaningful).
#[inline(always)]
pub fn sample_toward_x(
    radiance: V3x,
    inv_area: F16,
    p: V3x,
    (pl, ng, ns): (V3x, V3x, V3x),
) -> (LightSampleX, M16) {
    let to = pl.sub(p);
    let d2 = to.length_squared();
    let dist = d2.sqrt();
    let wi = to.div(dist);
    let cos_l = -ns.dot(wi);
    let ok = d2.gt(F16::splat(0.0)).and(cos_l.gt(F16::splat(0.0)));
    let pdf = inv_area * d2 / cos_l;
    let s = LightSampleX {
        wi,
        dist,
        n_geo: ng,
        weight: radiance.div(pdf),
        pdf,
        delta: M16::splat(false),
    };
    (s, ok)
}

/// One triangle of an area light, pre-gathered for sampling.
#[derive(Clone, Debug)]
pub struct AreaTri {
    /// First vertex and the edges to the second and third.
    pub p0: Vec3,
    pub e1: Vec3,
    pub e2: Vec3,
    /// Unit geometric normal (from the winding).
    pub ng: Vec3,
    /// Vertex normals if they are not all equal to `ng` (then the shading normal is
    /// interpolated as in [`crate::geometry::shading::eval_position_normals`]); None for flat triangles.
    pub normals: Option<[Vec3; 3]>,
}

impl AreaTri {
    fn new(mesh: &Mesh, t: usize) -> AreaTri {
        let [i0, i1, i2] = mesh.indices[t].map(|i| i as usize);
        let p0 = mesh.positions[i0];
        let e1 = mesh.positions[i1] - p0;
        let e2 = mesh.positions[i2] - p0;
        let ng = e1.cross(e2).normalize_or_zero();
        let normals = if mesh.normals.is_empty() {
            None
        } else {
            let n = [mesh.normals[i0], mesh.normals[i1], mesh.normals[i2]];
            if n.iter().all(|&v| v == ng) {
                None
            } else {
                Some(n)
            }
        };
        AreaTri {
            p0,
            e1,
            e2,
            ng,
            normals,
        }
    }

    /// Position, geometric and shading normal at barycentrics `b`.
    #[inline]
    pub fn eval(&self, b: Vec2) -> (Vec3, Vec3, Vec3) {
        tri_point(self.p0, self.e1, self.e2, self.ng, self.normals, b)
    }
}

/// [`AreaTri::eval`] on the triangle's fields (for the packet kernels' lane loops).
#[inline(always)]
pub fn tri_point(
    p0: Vec3,
    e1: Vec3,
    e2: Vec3,
    ng: Vec3,
    normals: Option<[Vec3; 3]>,
    b: Vec2,
) -> (Vec3, Vec3, Vec3) {
    let p = p0 + e1 * b.x + e2 * b.y;
    let ns = match normals {
        None => ng,
        Some([n0, n1, n2]) => {
            let s = (n0 * (1.0 - b.x - b.y) + n1 * b.x + n2 * b.y).normalize_or_zero();
            if s == Vec3::ZERO { ng } else { s }
        }
    };
    (p, ng, ns)
}

/// [`tri_point`] per lane; `has_normals` marks the lanes with vertex normals.
#[inline(always)]
pub fn tri_point_x(
    p0: V3x,
    e1: V3x,
    e2: V3x,
    ng: V3x,
    has_normals: M16,
    [n0, n1, n2]: [V3x; 3],
    b: V2x,
) -> (V3x, V3x, V3x) {
    let p = p0.add(e1.scale(b.x)).add(e2.scale(b.y));
    let s = n0
        .scale(1.0 - b.x - b.y)
        .add(n1.scale(b.x))
        .add(n2.scale(b.y))
        .normalize_or_zero();
    let ns = V3x::select(has_normals.and(s.is_zero().not()), s, ng);
    (p, ng, ns)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pre-gathered light triangles evaluate like the mesh (flat and smooth normals).
    #[test]
    fn area_triangles_match_mesh_evaluation() {
        use crate::geometry::shading::eval_position_normals;
        let smooth =
            crate::geometry::generate::sphere(Vec3::new(0.3, -0.2, 1.0), 0.7, 6, 12, false, true);
        let flat = crate::geometry::generate::quad(Vec3::ZERO, Vec3::X, Vec3::Y);
        for m in [&smooth, &flat] {
            for t in 0..m.indices.len() {
                let a = AreaTri::new(m, t);
                for b in [
                    Vec2::new(0.2, 0.3),
                    Vec2::new(1.0, 0.0),
                    Vec2::new(0.0, 0.0),
                ] {
                    let (p, ng, ns) = a.eval(b);
                    let (q, mg, ms) = eval_position_normals(m, t as u32, b);
                    assert!((p - q).length() < 1e-5 && (ng - mg).length() < 1e-5);
                    assert!((ns - ms).length() < 1e-5, "{ns} {ms}");
                }
            }
        }
        assert!(AreaTri::new(&flat, 0).normals.is_none());
        assert!(AreaTri::new(&smooth, 0).normals.is_some());
    }
}
