//! Light sources with Mitsuba 3 semantics: area (one-sided, on a mesh), point, spot,
//! directional, constant and lat-long environment map; uniform emitter selection
//! (a shape with an `area` emitter is one emitter).

// `!(x > 0.0)` deliberately also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod envmap;

use crate::geometry::sphere::Sphere;
use crate::geometry::{Mesh, SurfaceInteraction};
use crate::math::distribution::Distribution1D;
use crate::math::{INV_FOUR_PI, Mat4, Spectrum, Vec2, Vec3, warp};
use crate::scene::{Emitter, Scene};
use crate::{Error, Result};
pub use envmap::EnvMapLight;

/// One emitter, ready for sampling.
#[derive(Clone, Debug)]
pub enum Light {
    /// Uniform area sampling over mesh `mesh` (triangles chosen by area).
    Area {
        mesh: u32,
        radiance: Spectrum,
        tris: Distribution1D,
        inv_area: f32,
        /// Per triangle: what sampling needs, gathered once (no index lookups per sample).
        geo: Vec<AreaTri>,
    },
    /// An area emitter on an analytic sphere (Mitsuba: cone sampling from outside).
    SphereArea {
        sphere: Sphere,
        radiance: Spectrum,
    },
    Point {
        position: Vec3,
        intensity: Spectrum,
    },
    Spot {
        position: Vec3,
        /// World → light-local rotation (light shines along local +z).
        to_local: glam::Mat3,
        intensity: Spectrum,
        cos_cutoff: f32,
        cos_beam: f32,
        cutoff: f32,
        inv_transition: f32,
    },
    Directional {
        /// Unit direction of travel of the light.
        direction: Vec3,
        irradiance: Spectrum,
    },
    Constant {
        radiance: Spectrum,
    },
    EnvMap(Box<EnvMapLight>),
}

/// One triangle of an area light, pre-gathered for sampling.
#[derive(Clone, Debug)]
pub struct AreaTri {
    /// First vertex and the edges to the second and third.
    p0: Vec3,
    e1: Vec3,
    e2: Vec3,
    /// Unit geometric normal (from the winding).
    ng: Vec3,
    /// Vertex normals if they are not all equal to `ng` (then the shading normal is
    /// interpolated as in [`crate::geometry::shading::eval_position_normals`]); None for flat triangles.
    normals: Option<[Vec3; 3]>,
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
    fn eval(&self, b: Vec2) -> (Vec3, Vec3, Vec3) {
        let p = self.p0 + self.e1 * b.x + self.e2 * b.y;
        let ns = match &self.normals {
            None => self.ng,
            Some([n0, n1, n2]) => {
                let s = (*n0 * (1.0 - b.x - b.y) + *n1 * b.x + *n2 * b.y).normalize_or_zero();
                if s == Vec3::ZERO { self.ng } else { s }
            }
        };
        (p, self.ng, ns)
    }
}

/// The result of sampling a light from a reference point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit world direction from the reference point toward the light.
    pub wi: Vec3,
    /// Distance to the sampled point (∞ for lights at infinity).
    pub dist: f32,
    /// Geometric normal at the sampled point (zero for points and infinite lights), used to
    /// offset the far end of the shadow ray.
    pub n_geo: Vec3,
    /// Radiance (or intensity / d², or irradiance) divided by the pdf, including the
    /// emitter-selection probability.
    pub weight: Spectrum,
    /// Solid-angle pdf including selection (for delta lights: the selection probability).
    pub pdf: f32,
    /// True for point, spot and directional lights (no MIS).
    pub delta: bool,
}

/// All emitters of a scene plus the lookups the integrator needs.
#[derive(Clone, Debug)]
pub struct LightSet {
    pub lights: Vec<Light>,
    /// For each mesh, the index of its area light in `lights`.
    mesh_light: Vec<Option<u32>>,
    /// Indices of lights at infinity (constant, envmap), evaluated on escaped rays.
    infinite: Vec<u32>,
    /// Scene bounding sphere (centre, radius), as Mitsuba's `bbox().bounding_sphere()`.
    pub bsphere: (Vec3, f32),
}

fn rotation_inverse(m: Mat4, what: &str) -> Result<glam::Mat3> {
    let m3 = glam::Mat3::from_mat4(m);
    let det = m3.determinant();
    if !det.is_finite() || det.abs() < 1e-12 {
        return Err(Error::Invalid(format!("{what}: to_world is singular")));
    }
    Ok(m3.inverse())
}

impl LightSet {
    /// Collects the emitters of `scene`; `bounds` are the geometry's (min, max).
    pub fn new(scene: &Scene, bounds: (Vec3, Vec3)) -> Result<LightSet> {
        let mut lights = Vec::new();
        let mut mesh_light = vec![None; scene.meshes.len()];
        for (mi, mesh) in scene.meshes.iter().enumerate() {
            let Some(radiance) = mesh.emitter else {
                continue;
            };
            if let Some(sphere) = mesh.sphere {
                mesh_light[mi] = Some(lights.len() as u32);
                lights.push(Light::SphereArea { sphere, radiance });
                continue;
            }
            let areas = (0..mesh.indices.len()).map(|t| mesh.triangle_area(t) as f64);
            let Some(tris) = Distribution1D::new(areas) else {
                // A zero-area emitter can neither be hit nor sampled: it contributes nothing.
                continue;
            };
            let inv_area = (1.0 / tris.total()) as f32;
            mesh_light[mi] = Some(lights.len() as u32);
            let geo = (0..mesh.indices.len())
                .map(|t| AreaTri::new(mesh, t))
                .collect();
            lights.push(Light::Area {
                mesh: mi as u32,
                radiance,
                tris,
                inv_area,
                geo,
            });
        }
        let mut infinite = Vec::new();
        for e in &scene.emitters {
            let l = match e {
                Emitter::Point {
                    position,
                    intensity,
                } => Light::Point {
                    position: *position,
                    intensity: *intensity,
                },
                Emitter::Spot {
                    to_world,
                    intensity,
                    cutoff_angle,
                    beam_width,
                } => {
                    let cutoff = cutoff_angle.to_radians();
                    let beam = beam_width.to_radians().min(cutoff);
                    Light::Spot {
                        position: to_world.transform_point3(Vec3::ZERO),
                        to_local: rotation_inverse(*to_world, "spot emitter")?,
                        intensity: *intensity,
                        cos_cutoff: cutoff.cos(),
                        cos_beam: beam.cos(),
                        cutoff,
                        inv_transition: if cutoff > beam {
                            1.0 / (cutoff - beam)
                        } else {
                            0.0
                        },
                    }
                }
                Emitter::Directional {
                    direction,
                    irradiance,
                } => {
                    let d = direction.normalize_or_zero();
                    if d == Vec3::ZERO {
                        return Err(Error::Invalid(
                            "directional emitter with a zero direction".into(),
                        ));
                    }
                    Light::Directional {
                        direction: d,
                        irradiance: *irradiance,
                    }
                }
                Emitter::Constant { radiance } => {
                    infinite.push(lights.len() as u32);
                    Light::Constant {
                        radiance: *radiance,
                    }
                }
                Emitter::EnvMap {
                    image,
                    to_world,
                    scale,
                    filename,
                } => {
                    infinite.push(lights.len() as u32);
                    Light::EnvMap(Box::new(EnvMapLight::new(
                        image, *to_world, *scale, filename,
                    )?))
                }
            };
            lights.push(l);
        }
        let (lo, hi) = bounds;
        let center = 0.5 * (lo + hi);
        let radius = (0.5 * (hi - lo).length()).max(1e-4);
        Ok(LightSet {
            lights,
            mesh_light,
            infinite,
            bsphere: (center, radius * (1.0 + 1e-4)),
        })
    }

    /// True if the scene has no emitters at all.
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// Probability of selecting any one emitter (uniform, as Mitsuba).
    #[inline]
    fn select_pdf(&self) -> f32 {
        1.0 / self.lights.len() as f32
    }

    /// Samples an emitter uniformly (with `u_sel`) and a direction toward it from `p`. (`meshes`
    /// is no longer read: area lights keep their own triangle copies; kept for callers.)
    pub fn sample(&self, _meshes: &[Mesh], p: Vec3, u_sel: f32, u: Vec2) -> Option<LightSample> {
        let n = self.lights.len();
        if n == 0 {
            return None;
        }
        let idx = ((u_sel * n as f32) as usize).min(n - 1);
        let sel = self.select_pdf();
        let mut s = match &self.lights[idx] {
            Light::Area {
                radiance,
                tris,
                inv_area,
                geo,
                ..
            } => {
                let (t, _, ux) = tris.sample(u.x);
                let b = warp::square_to_uniform_triangle(Vec2::new(ux, u.y));
                let (pl, ng, ns) = geo[t].eval(b);
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
                LightSample {
                    wi,
                    dist,
                    n_geo: ng,
                    weight: *radiance / pdf,
                    pdf,
                    delta: false,
                }
            }
            Light::SphereArea { sphere, radiance } => {
                let s = sphere.sample(p, u)?;
                // One-sided: emits toward the side of the (possibly flipped) normal.
                if !(s.d.dot(s.n) < 0.0 && s.pdf > 0.0) {
                    return None;
                }
                LightSample {
                    wi: s.d,
                    dist: s.dist,
                    n_geo: s.n,
                    weight: *radiance / s.pdf,
                    pdf: s.pdf,
                    delta: false,
                }
            }
            Light::Point {
                position,
                intensity,
            } => {
                let to = *position - p;
                let d2 = to.length_squared();
                if !(d2 > 0.0) {
                    return None;
                }
                let dist = d2.sqrt();
                LightSample {
                    wi: to / dist,
                    dist,
                    n_geo: Vec3::ZERO,
                    weight: *intensity / d2,
                    pdf: 1.0,
                    delta: true,
                }
            }
            Light::Spot {
                position,
                to_local,
                intensity,
                cos_cutoff,
                cos_beam,
                cutoff,
                inv_transition,
            } => {
                let to = *position - p;
                let d2 = to.length_squared();
                if !(d2 > 0.0) {
                    return None;
                }
                let dist = d2.sqrt();
                let wi = to / dist;
                let local = (*to_local * -wi).normalize_or_zero();
                let c = local.z;
                let falloff = if c <= *cos_cutoff {
                    0.0
                } else if c >= *cos_beam {
                    1.0
                } else {
                    (*cutoff - c.clamp(-1.0, 1.0).acos()) * inv_transition
                };
                if !(falloff > 0.0) {
                    return None;
                }
                LightSample {
                    wi,
                    dist,
                    n_geo: Vec3::ZERO,
                    weight: *intensity * (falloff / d2),
                    pdf: 1.0,
                    delta: true,
                }
            }
            Light::Directional {
                direction,
                irradiance,
            } => {
                let (c, r) = self.bsphere;
                LightSample {
                    wi: -*direction,
                    // Past the scene's bounding sphere nothing can occlude (Mitsuba: 2·radius).
                    dist: 2.0 * r.max((p - c).length()),
                    n_geo: Vec3::ZERO,
                    weight: *irradiance,
                    pdf: 1.0,
                    delta: true,
                }
            }
            Light::Constant { radiance } => {
                let wi = warp::square_to_uniform_sphere(u);
                LightSample {
                    wi,
                    dist: f32::INFINITY,
                    n_geo: Vec3::ZERO,
                    weight: *radiance / INV_FOUR_PI,
                    pdf: INV_FOUR_PI,
                    delta: false,
                }
            }
            Light::EnvMap(env) => {
                let (wi, val, pdf) = env.sample(u)?;
                LightSample {
                    wi,
                    dist: f32::INFINITY,
                    n_geo: Vec3::ZERO,
                    weight: val / pdf,
                    pdf,
                    delta: false,
                }
            }
        };
        s.pdf *= sel;
        s.weight /= sel;
        Some(s)
    }

    /// Radiance emitted by the surface at `si` toward `si.wi` (0 unless the mesh has an area
    /// emitter and the direction is on the shading normal's side).
    #[inline]
    pub fn area_radiance(&self, meshes: &[Mesh], si: &SurfaceInteraction) -> Spectrum {
        match meshes[si.mesh as usize].emitter {
            Some(l) if si.wi.z > 0.0 && self.mesh_light[si.mesh as usize].is_some() => l,
            _ => Spectrum::ZERO,
        }
    }

    /// True if the mesh carries an area emitter.
    #[inline]
    pub fn is_emissive(&self, mesh: u32) -> bool {
        self.mesh_light[mesh as usize].is_some()
    }

    /// Solid-angle pdf (incl. selection) that [`LightSet::sample`] from `p_ref` produces the
    /// point `si` of an area emitter.
    pub fn pdf_area_hit(&self, p_ref: Vec3, si: &SurfaceInteraction) -> f32 {
        let Some(li) = self.mesh_light[si.mesh as usize] else {
            return 0.0;
        };
        let inv_area = match &self.lights[li as usize] {
            Light::Area { inv_area, .. } => inv_area,
            Light::SphereArea { sphere, .. } => {
                return self.select_pdf() * sphere.pdf(p_ref, si.p, si.n);
            }
            _ => return 0.0,
        };
        let d2 = (si.p - p_ref).length_squared();
        let cos_l = si.wi.z.abs();
        if !(cos_l > 0.0) {
            return 0.0;
        }
        self.select_pdf() * inv_area * d2 / cos_l
    }

    /// Number of lights at infinity (constant, envmap).
    pub fn infinite_count(&self) -> usize {
        self.infinite.len()
    }

    /// Radiance and selection-inclusive pdf of the `k`-th light at infinity for an escaped ray
    /// with unit world direction `d`.
    pub fn eval_infinite(&self, k: usize, d: Vec3) -> (Spectrum, f32) {
        match &self.lights[self.infinite[k] as usize] {
            Light::Constant { radiance } => (*radiance, INV_FOUR_PI * self.select_pdf()),
            Light::EnvMap(env) => {
                let (le, pdf) = env.eval_pdf(d);
                (le, pdf * self.select_pdf())
            }
            _ => (Spectrum::ZERO, 0.0),
        }
    }
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

    #[test]
    fn spot_falloff_matches_mitsuba_profile() {
        let to_world = Mat4::IDENTITY;
        let scene_emitters = [Emitter::Spot {
            to_world,
            intensity: Spectrum::ONE,
            cutoff_angle: 20.0,
            beam_width: 10.0,
        }];
        let scene = crate::render::tests_support::empty_scene(scene_emitters.to_vec());
        let ls = LightSet::new(&scene, (Vec3::ZERO, Vec3::ONE)).unwrap();
        let at = |deg: f32| {
            let t = deg.to_radians();
            let p = Vec3::new(t.sin(), 0.0, t.cos()) * 2.0;
            ls.sample(&[], p, 0.0, Vec2::ZERO)
                .map_or(0.0, |s| s.weight.x * 4.0)
        };
        assert!((at(5.0) - 1.0).abs() < 1e-5);
        assert!((at(15.0) - 0.5).abs() < 1e-3);
        assert_eq!(at(25.0), 0.0);
    }
}
