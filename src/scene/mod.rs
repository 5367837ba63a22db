//! The scene description: what the Mitsuba-XML and glTF loaders produce and the renderer consumes.

pub mod channels;
pub mod gltf;
pub mod load_options;
pub mod measured_material;
pub mod mitsuba;
pub mod obj;
pub mod ply;
pub mod sensor;
pub mod serialized;
pub mod shapes;

use crate::bsdf::Bsdf;
use crate::geometry::Mesh;
pub use crate::light::Emitter;
use crate::plugin::Properties;
pub use load_options::LoadOptions;
pub use sensor::{Camera, Projection, SamplerType};
use std::path::PathBuf;

/// Mitsuba's `direct` integrator: emitter and BSDF samples per camera-ray hit, combined with
/// the power heuristic.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DirectSettings {
    /// Samples of the emitter-sampling technique per hit (`emitter_samples`).
    pub emitter_samples: u32,
    /// Samples of the BSDF-sampling technique per hit (`bsdf_samples`).
    pub bsdf_samples: u32,
}

/// Settings of the `path` (or `direct`) integrator (Mitsuba 3 semantics).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IntegratorSettings {
    /// Some: Mitsuba's `direct` integrator instead of `path` (max_depth and rr_depth unused).
    pub direct: Option<DirectSettings>,
    /// The sampler the scene names (see [`SamplerType`]).
    pub sampler: SamplerType,
    /// Longest path in vertices: 1 = emitters seen directly, 2 = direct lighting; −1 = unbounded.
    pub max_depth: i32,
    /// Depth at which Russian roulette starts.
    pub rr_depth: i32,
    /// Do not show directly visible emitters.
    pub hide_emitters: bool,
}

impl IntegratorSettings {
    /// Mitsuba's `path`: `max_depth` (−1, unbounded), `rr_depth` (5), `hide_emitters`.
    pub fn path_from_props(p: &dyn Properties) -> crate::Result<IntegratorSettings> {
        let max_depth = p.int("max_depth", -1)?;
        let rr_depth = p.int("rr_depth", 5)?;
        let hide_emitters = p.bool("hide_emitters", false)?;
        if max_depth < -1 || max_depth > i32::MAX as i64 {
            return Err(p.err("\"max_depth\" must be -1 (infinite) or a value >= 0"));
        }
        if rr_depth <= 0 || rr_depth > i32::MAX as i64 {
            return Err(p.err("\"rr_depth\" must be set to a value greater than zero"));
        }
        Ok(IntegratorSettings {
            max_depth: max_depth as i32,
            rr_depth: rr_depth as i32,
            hide_emitters,
            ..Default::default()
        })
    }

    /// Mitsuba's `volpath` and `volpathmis` on a scene without participating media (btfpt
    /// refuses `<medium>` where it appears): the same estimate as `path` (next-event estimation
    /// and BSDF sampling with MIS, Russian roulette from `rr_depth`), so the same parameters.
    pub fn volpath_from_props(p: &dyn Properties) -> crate::Result<IntegratorSettings> {
        IntegratorSettings::path_from_props(p)
    }

    /// Mitsuba's `ptracer` (a particle tracer: light paths connected to the camera) on the
    /// scenes where it and `path` estimate the same image — no specular (delta) surface, no
    /// environment emitter, a perspective or thin-lens camera; the loader refuses the others:
    /// rendered by the path tracer with the same `max_depth`, `rr_depth` and `hide_emitters`
    /// (the image converges to Mitsuba's; its noise is the path tracer's). `samples_per_pass`
    /// only divides Mitsuba's work into passes.
    pub fn ptracer_from_props(p: &dyn Properties) -> crate::Result<IntegratorSettings> {
        p.int("samples_per_pass", -1)?;
        IntegratorSettings::path_from_props(p)
    }

    /// Mitsuba's `direct`: `shading_samples` (1), or `emitter_samples` and `bsdf_samples`
    /// (each `shading_samples` by default; at most 65536, not both 0), `hide_emitters`.
    pub fn direct_from_props(p: &dyn Properties) -> crate::Result<IntegratorSettings> {
        if p.has("shading_samples") && (p.has("emitter_samples") || p.has("bsdf_samples")) {
            return Err(p.err(
                "cannot specify both 'shading_samples' and ('emitter_samples' and/or 'bsdf_samples')",
            ));
        }
        let count = |name: &str, default: i64| -> crate::Result<u32> {
            let v = p.int(name, default)?;
            u32::try_from(v)
                .ok()
                .filter(|v| *v <= 1 << 16)
                .ok_or_else(|| p.err(&format!("\"{name}\" = {v} must be in 0..=65536")))
        };
        let shading = count("shading_samples", 1)?;
        let emitter_samples = count("emitter_samples", shading as i64)?;
        let bsdf_samples = count("bsdf_samples", shading as i64)?;
        let hide_emitters = p.bool("hide_emitters", false)?;
        if emitter_samples + bsdf_samples == 0 {
            return Err(p.err("must have at least 1 BSDF or emitter sample"));
        }
        Ok(IntegratorSettings {
            direct: Some(DirectSettings {
                emitter_samples,
                bsdf_samples,
            }),
            hide_emitters,
            ..Default::default()
        })
    }
}

impl Default for IntegratorSettings {
    fn default() -> Self {
        IntegratorSettings {
            direct: None,
            sampler: SamplerType::Independent,
            max_depth: -1,
            rr_depth: 5,
            hide_emitters: false,
        }
    }
}

/// A complete scene, in world space.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The file the scene was loaded from (for messages).
    pub source: PathBuf,
    pub camera: Camera,
    pub integrator: IntegratorSettings,
    /// Channels written beside the image (Mitsuba's `aov` and `moment`; empty otherwise).
    pub channels: channels::ImageChannels,
    /// `sampler.sample_count`.
    pub spp: u32,
    pub meshes: Vec<Mesh>,
    pub bsdfs: Vec<Bsdf>,
    pub emitters: Vec<Emitter>,
    /// Area emitters whose radiance is a texture (Mitsuba: a `<texture name="radiance">`):
    /// (index in `meshes`, the texture over the mesh's uvs), which replaces the mesh's
    /// constant `emitter` radiance.
    pub emission_textures: Vec<(u32, crate::bsdf::Texture)>,
    /// The file and model each `<bsdf type="btf">` renders, in scene order (for the summary).
    pub btf_uses: Vec<measured_material::BtfUse>,
    /// Every file the scene reads besides its own (included files, meshes, textures, BTF data
    /// and models), in load order: what a partial render's fingerprint covers.
    pub inputs: Vec<std::path::PathBuf>,
}

/// Gives `mesh` an area emitter of `radiance`: a constant becomes the mesh's `emitter`; a texture
/// sets it to 1 and is returned, for the loader to record in [`Scene::emission_textures`].
pub(crate) fn attach_emission(
    mesh: &mut Mesh,
    radiance: crate::bsdf::Texture,
) -> Option<crate::bsdf::Texture> {
    match radiance {
        crate::bsdf::Texture::Constant(c) => {
            mesh.emitter = Some(c);
            None
        }
        t => {
            mesh.emitter = Some(crate::math::Spectrum::ONE);
            Some(t)
        }
    }
}

/// Loads a scene file: Mitsuba 3 XML (`.xml`) or glTF 2.0 (`.gltf`, `.glb`), with the caller's
/// defines and BTF model choice (see [`LoadOptions`]).
pub fn load(path: &std::path::Path, options: &LoadOptions) -> crate::Result<Scene> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "xml" => mitsuba::load(path, options),
        "gltf" | "glb" => gltf::load(path, options),
        _ => Err(crate::Error::format(
            path,
            "unknown scene format (expected .xml, .gltf or .glb)",
        )),
    }
}
