//! Emitter selection: every light of a scene, chosen uniformly as Mitsuba does (a shape with an
//! `area` emitter is one emitter), plus the lookups the integrator needs for MIS.

// `!(x > 0.0)` deliberately also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::{
    AreaLight, ConstantLight, DirectionalLight, Emitter, EnvMapLight, Light, LightSample,
    LightSampleX, PointLight, ProjectorLight, SphereAreaLight, SpotLight,
};
use crate::Result;
use crate::bsdf::Texture;
use crate::geometry::{Mesh, SurfaceInteraction};
use crate::math::simd::WIDTH;
use crate::math::simd::f16::{F16, M16, V2x, V3x};
use crate::math::{Spectrum, Vec2, Vec3};

/// A light's sample with the selection probability `sel` folded in (pdf × sel, weight / sel).
#[inline(always)]
pub fn with_selection(mut s: LightSample, sel: f32) -> LightSample {
    s.pdf *= sel;
    s.weight /= sel;
    s
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

impl LightSet {
    /// The lights of a scene: the area emitters of `meshes` (with the radiance textures of
    /// `emission_textures`, by mesh index) and the `emitters`; `bounds` are the geometry's
    /// (min, max).
    pub fn new(
        meshes: &[Mesh],
        emitters: &[Emitter],
        emission_textures: &[(u32, Texture)],
        bounds: (Vec3, Vec3),
    ) -> Result<LightSet> {
        let mut lights = Vec::new();
        let mut mesh_light = vec![None; meshes.len()];
        for (mi, mesh) in meshes.iter().enumerate() {
            let Some(radiance) = mesh.emitter else {
                continue;
            };
            let texture = emission_textures
                .iter()
                .find(|(m, _)| *m as usize == mi)
                .map(|(_, t)| t.clone())
                .filter(Texture::is_spatially_varying);
            let light = match mesh.sphere {
                Some(sphere) => Light::SphereArea(SphereAreaLight {
                    sphere,
                    radiance,
                    texture,
                }),
                None => match AreaLight::new(mesh, mi as u32, radiance, texture) {
                    Some(a) => Light::Area(a),
                    // A zero-area emitter can neither be hit nor sampled: it contributes nothing.
                    None => continue,
                },
            };
            mesh_light[mi] = Some(lights.len() as u32);
            lights.push(light);
        }
        let mut infinite = Vec::new();
        for e in emitters {
            let l = match e {
                Emitter::Point {
                    position,
                    intensity,
                } => Light::Point(PointLight {
                    position: *position,
                    intensity: *intensity,
                }),
                Emitter::Spot {
                    to_world,
                    intensity,
                    cutoff_angle,
                    beam_width,
                    texture,
                } => Light::Spot(SpotLight::new(
                    *to_world,
                    *intensity,
                    *cutoff_angle,
                    *beam_width,
                    texture.clone(),
                )?),
                Emitter::Projector {
                    to_world,
                    irradiance,
                    scale,
                    fov_x,
                } => Light::Projector(ProjectorLight::new(
                    *to_world,
                    irradiance.clone(),
                    *scale,
                    *fov_x,
                )?),
                Emitter::Directional {
                    direction,
                    irradiance,
                } => Light::Directional(DirectionalLight::new(*direction, *irradiance)?),
                Emitter::Constant { radiance } => {
                    infinite.push(lights.len() as u32);
                    Light::Constant(ConstantLight {
                        radiance: *radiance,
                    })
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
    pub fn select_pdf(&self) -> f32 {
        1.0 / self.lights.len() as f32
    }

    /// Samples an emitter uniformly (with `u_sel`) and a direction toward it from `p`; the
    /// sample's pdf and weight include the selection probability.
    pub fn sample(&self, p: Vec3, u_sel: f32, u: Vec2) -> Option<LightSample> {
        let n = self.lights.len();
        if n == 0 {
            return None;
        }
        let idx = self.select(u_sel);
        let s = self.sample_light(idx, p, u)?;
        Some(with_selection(s, self.select_pdf()))
    }

    /// A direction toward light `idx` from `p` (selection not included).
    #[inline]
    fn sample_light(&self, idx: usize, p: Vec3, u: Vec2) -> Option<LightSample> {
        match &self.lights[idx] {
            Light::Area(l) => l.sample_li(p, u),
            Light::SphereArea(l) => l.sample_li(p, u),
            Light::Point(l) => l.sample_li(p),
            Light::Spot(l) => l.sample_li(p),
            Light::Projector(l) => l.sample_li(p),
            Light::Directional(l) => Some(l.sample_li(p, self.bsphere)),
            Light::Constant(l) => Some(l.sample_li(u)),
            Light::EnvMap(l) => l.sample_li(u),
        }
    }

    /// [`LightSet::sample`] for the 16 lanes of `want`, each with the emitter `chosen[l]` (from
    /// [`LightSet::select`] of its `u_sel`): the samples, selection included, and the lanes that
    /// have one — the same bits per lane. The lanes that chose one emitter are sampled together
    /// in SoA (an analytic sphere, a projector and a textured spot lane by lane).
    #[inline(always)]
    pub fn sample_x(
        &self,
        p: V3x,
        chosen: &[u32; WIDTH],
        want: M16,
        u: V2x,
    ) -> (LightSampleX, M16) {
        let mut out = LightSampleX {
            wi: V3x::splat(Vec3::Z),
            dist: F16::splat(1.0),
            n_geo: V3x::ZERO,
            weight: V3x::ZERO,
            pdf: F16::splat(1.0),
            delta: M16::splat(false),
        };
        let mut ok = M16::splat(false);
        if self.lights.is_empty() {
            return (out, ok);
        }
        let sel = self.select_pdf();
        let mut left = want;
        while let Some(first) = (0..WIDTH).find(|&l| left.0[l]) {
            let idx = chosen[first];
            let m = M16(std::array::from_fn(|l| left.0[l] && chosen[l] == idx));
            left = left.and(m.not());
            let (s, has) = match &self.lights[idx as usize] {
                Light::Point(l) => l.sample_li_x(p),
                Light::Spot(l) if !l.is_textured() => l.sample_li_x(p),
                Light::Directional(l) => (l.sample_li_x(p, self.bsphere), M16::splat(true)),
                Light::Constant(l) => (l.sample_li_x(u), M16::splat(true)),
                Light::EnvMap(l) => l.sample_li_x(u),
                Light::Area(_) | Light::SphereArea(_) | Light::Spot(_) | Light::Projector(_) => {
                    let mut s = out;
                    let mut has = M16::splat(false);
                    for l in (0..WIDTH).filter(|&l| m.0[l]) {
                        if let Some(ls) = self.sample_light(idx as usize, p.get(l), u.get(l)) {
                            s.set(l, &ls);
                            has.0[l] = true;
                        }
                    }
                    (s, has)
                }
            };
            let m = m.and(has);
            out = LightSampleX::select(m, &s.with_selection(sel), &out);
            ok = ok.or(m);
        }
        (out, ok)
    }

    /// The index in `lights` of the emitter that sample number `u_sel` selects (uniformly; 0
    /// when there are none).
    #[inline]
    pub fn select(&self, u_sel: f32) -> usize {
        let n = self.lights.len();
        ((u_sel * n as f32) as usize).min(n.saturating_sub(1))
    }

    /// Radiance emitted by the surface at `si` toward `si.wi` (0 unless the mesh has an area
    /// emitter and the direction is on the shading normal's side).
    #[inline]
    pub fn area_radiance(&self, si: &SurfaceInteraction) -> Spectrum {
        let Some(li) = self.mesh_light[si.mesh as usize] else {
            return Spectrum::ZERO;
        };
        if !(si.wi.z > 0.0) {
            return Spectrum::ZERO;
        }
        match &self.lights[li as usize] {
            Light::Area(l) => l.radiance_at_hit(si),
            Light::SphereArea(l) => l.radiance_at_hit(si),
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
        match &self.lights[li as usize] {
            Light::Area(l) => l.pdf_li(self.select_pdf(), p_ref, si),
            Light::SphereArea(l) => self.select_pdf() * l.pdf_li(p_ref, si.p, si.n),
            _ => 0.0,
        }
    }

    /// Number of lights at infinity (constant, envmap).
    pub fn infinite_count(&self) -> usize {
        self.infinite.len()
    }

    /// Radiance and selection-inclusive pdf of the `k`-th light at infinity for an escaped ray
    /// with unit world direction `d`.
    pub fn eval_infinite(&self, k: usize, d: Vec3) -> (Spectrum, f32) {
        let (le, pdf) = match &self.lights[self.infinite[k] as usize] {
            Light::Constant(l) => l.eval_pdf(),
            Light::EnvMap(env) => env.eval_pdf(d),
            _ => return (Spectrum::ZERO, 0.0),
        };
        (le, pdf * self.select_pdf())
    }

    /// [`LightSet::eval_infinite`] for 16 escaped rays (the same bits per lane).
    #[inline(always)]
    pub fn eval_infinite_x(&self, k: usize, d: V3x) -> (V3x, F16) {
        let (le, pdf) = match &self.lights[self.infinite[k] as usize] {
            Light::Constant(l) => {
                let (le, pdf) = l.eval_pdf();
                (V3x::splat(le), F16::splat(pdf))
            }
            Light::EnvMap(env) => env.eval_pdf_x(d),
            _ => return (V3x::ZERO, F16::splat(0.0)),
        };
        (le, pdf * self.select_pdf())
    }
}
