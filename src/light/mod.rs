//! Light sources with Mitsuba 3 semantics: area (one-sided, on a mesh), point, spot,
//! directional, constant and lat-long environment map; uniform emitter selection
//! (a shape with an `area` emitter is one emitter).

// `!(x > 0.0)` deliberately also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod distribution;
pub mod envmap;

use crate::geometry::shading::eval_position_normals;
use crate::geometry::{Mesh, SurfaceInteraction};
use crate::math::{INV_FOUR_PI, Mat4, Spectrum, Vec2, Vec3, warp};
use crate::scene::{Emitter, Scene};
use crate::{Error, Result};
use distribution::Distribution1D;
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
            let areas = (0..mesh.indices.len()).map(|t| mesh.triangle_area(t) as f64);
            let Some(tris) = Distribution1D::new(areas) else {
                // A zero-area emitter can neither be hit nor sampled: it contributes nothing.
                continue;
            };
            let inv_area = (1.0 / tris.total()) as f32;
            mesh_light[mi] = Some(lights.len() as u32);
            lights.push(Light::Area {
                mesh: mi as u32,
                radiance,
                tris,
                inv_area,
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

    /// Samples an emitter uniformly (with `u_sel`) and a direction toward it from `p`.
    pub fn sample(&self, meshes: &[Mesh], p: Vec3, u_sel: f32, u: Vec2) -> Option<LightSample> {
        let n = self.lights.len();
        if n == 0 {
            return None;
        }
        let idx = ((u_sel * n as f32) as usize).min(n - 1);
        let sel = self.select_pdf();
        let mut s = match &self.lights[idx] {
            Light::Area {
                mesh,
                radiance,
                tris,
                inv_area,
            } => {
                let m = &meshes[*mesh as usize];
                let (t, _, ux) = tris.sample(u.x);
                let b = warp::square_to_uniform_triangle(Vec2::new(ux, u.y));
                let (pl, ng, ns) = eval_position_normals(m, t as u32, b);
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
        let Light::Area { inv_area, .. } = &self.lights[li as usize] else {
            return 0.0;
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
