//! The renderer: scene preparation (BVH, lights, camera), the driver's tiled deterministic
//! sample passes on rayon, the integrators that trace a tile's samples (packet, and the scalar
//! path and direct ones), film accumulation, checkpoints and partial-render EXRs that merge
//! exactly.

pub mod camera;
pub mod channels;
pub mod checkpoint;
pub mod direct;
pub mod driver;
pub mod film;
pub mod integrator;
pub mod packet;
pub mod partial;
pub mod path;

use crate::geometry::Mesh;
use crate::geometry::accel::Accel;
use crate::light::LightSet;
use crate::scene::Scene;
use crate::{Error, Result};
use camera::ProjectiveCamera;
use integrator::Integrator;

pub use film::{RenderSettings, RenderState};

/// Which integrator traces the samples; both give the same image bits (the scalar one is the
/// test oracle of the packet one).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IntegratorKind {
    /// One path per thread at a time ([`Integrator::li`]).
    Scalar,
    /// A per-thread pool of paths run 16 lanes at a time with lane refill ([`packet`]): the
    /// render core.
    Packet(packet::PacketOptions),
}

impl Default for IntegratorKind {
    fn default() -> Self {
        IntegratorKind::Packet(packet::PacketOptions::default())
    }
}

/// A scene prepared for rendering.
pub struct RenderScene {
    pub scene: Scene,
    pub accel: Accel,
    pub lights: LightSet,
    pub camera: ProjectiveCamera,
    pub integrator: Integrator,
    /// The integrator asked for (packet unless chosen otherwise; see [`Self::integrator_kind`]).
    pub kind: IntegratorKind,
    /// Lane utilisation of the packet integrator, summed over the render.
    pub lanes: packet::LaneCounters,
    /// Seconds spent building the BVH.
    pub bvh_secs: f64,
}

impl RenderScene {
    /// Builds the BVH and the light tables and validates camera and integrator settings.
    pub fn new(scene: Scene) -> Result<RenderScene> {
        for (i, m) in scene.meshes.iter().enumerate() {
            let nv = m.positions.len();
            if let Some(bad) = m.indices.iter().flatten().find(|&&k| k as usize >= nv) {
                return Err(Error::Invalid(format!(
                    "mesh {i} '{}': vertex index {bad} out of range ({nv} vertices)",
                    m.name
                )));
            }
            if (!m.normals.is_empty() && m.normals.len() != nv)
                || (!m.uvs.is_empty() && m.uvs.len() != nv)
            {
                return Err(Error::Invalid(format!(
                    "mesh {i} '{}': normals/uvs count differs from the {nv} positions",
                    m.name
                )));
            }
            if m.bsdf as usize >= scene.bsdfs.len() {
                return Err(Error::Invalid(format!(
                    "mesh {i} '{}': BSDF index {} out of range ({} BSDFs)",
                    m.name,
                    m.bsdf,
                    scene.bsdfs.len()
                )));
            }
        }
        let total: u64 = scene.meshes.iter().map(|m| m.indices.len() as u64).sum();
        if total >= u32::MAX as u64 {
            return Err(Error::Invalid(format!(
                "{total} triangles in the scene: the BVH numbers triangles in 32 bits (at most {})",
                u32::MAX - 1
            )));
        }
        let t0 = std::time::Instant::now();
        let accel = Accel::build(&scene.meshes);
        let bvh_secs = t0.elapsed().as_secs_f64();
        let lights = LightSet::new(
            &scene.meshes,
            &scene.emitters,
            &scene.emission_textures,
            accel.bounds(),
        )?;
        let camera = ProjectiveCamera::new(&scene.camera)?;
        let integrator = Integrator::new(&scene.integrator)?;
        Ok(RenderScene {
            scene,
            accel,
            lights,
            camera,
            integrator,
            kind: IntegratorKind::default(),
            lanes: packet::LaneCounters::default(),
            bvh_secs,
        })
    }

    /// The integrator that renders: the one asked for, except that scenes with Mitsuba's
    /// `direct` integrator, which only the scalar code implements, render with the scalar one.
    pub fn integrator_kind(&self) -> IntegratorKind {
        match self.kind {
            IntegratorKind::Packet(_) if self.integrator.direct.is_some() => IntegratorKind::Scalar,
            k => k,
        }
    }

    /// One line naming the integrator that renders, and why when it is not the one asked for.
    pub fn integrator_line(&self) -> String {
        match (self.kind, self.integrator_kind()) {
            (IntegratorKind::Packet(o), IntegratorKind::Packet(_)) => format!(
                "integrator: packet (pool {}, refill {})",
                o.pool,
                if o.refill { "on" } else { "off" }
            ),
            (IntegratorKind::Packet(_), IntegratorKind::Scalar) => {
                "integrator: scalar (the scene's `direct` integrator has no packet kernel)"
                    .to_string()
            }
            _ => "integrator: scalar (asked for)".to_string(),
        }
    }

    /// A few lines describing the scene, printed before rendering.
    pub fn summary(&self) -> String {
        let s = &self.scene;
        let (lo, hi) = self.accel.bounds();
        let max_depth = if self.integrator.max_depth == u32::MAX {
            "∞".to_string()
        } else {
            self.integrator.max_depth.to_string()
        };
        let integrator = match &self.integrator.direct {
            Some(d) => format!(
                "direct: emitter_samples {}, bsdf_samples {}, hide_emitters {}",
                d.emitter_samples, d.bsdf_samples, self.integrator.hide_emitters
            ),
            None => format!(
                "path: max_depth {}, rr_depth {}, hide_emitters {}",
                max_depth, self.integrator.rr_depth, self.integrator.hide_emitters
            ),
        };
        let sampler = s.integrator.sampler;
        let sampler = if sampler == crate::scene::SamplerType::Independent {
            String::new()
        } else {
            format!(
                " ({} sampler: drawn from btfpt's independent sampler, same expected image, different noise)",
                sampler.name()
            )
        };
        format!(
            "scene {}\n  film {}×{}, fov_x {:.2}°, {} spp{}, filter {}\n  {} meshes, {} triangles, bounds [{:.3}, {:.3}, {:.3}]–[{:.3}, {:.3}, {:.3}]\n  resident: meshes {:.1} MiB, BVH {:.1} MiB\n  {} BSDFs, {} emitters ({} at infinity)\n  {}\n  {}",
            s.source.display(),
            s.camera.width,
            s.camera.height,
            s.camera.fov_x_deg,
            s.spp,
            sampler,
            s.camera.filter.name(),
            s.meshes.len(),
            self.accel.triangle_count(),
            lo.x,
            lo.y,
            lo.z,
            hi.x,
            hi.y,
            hi.z,
            mib(s.meshes.iter().map(Mesh::resident_bytes).sum()),
            mib(self.accel.resident_bytes()),
            s.bsdfs.len(),
            self.lights.lights.len(),
            self.lights.infinite_count(),
            integrator,
            self.integrator_line(),
        )
    }
}

/// `bytes` in MiB.
fn mib(bytes: usize) -> f64 {
    bytes as f64 / (1u64 << 20) as f64
}
