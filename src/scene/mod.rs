//! The scene description: what the Mitsuba-XML and glTF loaders produce and the renderer consumes.

pub mod gltf;
pub mod load_options;
pub mod measured_material;
pub mod mitsuba;
pub mod obj;
pub mod ply;
pub mod serialized;
pub mod shapes;

use crate::bsdf::Bsdf;
use crate::geometry::Mesh;
pub use crate::light::Emitter;
use crate::math::Mat4;
pub use load_options::LoadOptions;
use std::path::PathBuf;

/// A perspective pinhole camera with an `hdrfilm` and box reconstruction filter (Mitsuba semantics).
///
/// **Image orientation (what the renderer must do to match Mitsuba pixel for pixel).** Camera
/// space looks along +z with +y up, and — as in Mitsuba's `perspective.cpp`, whose sample-space
/// transform scales x by −½ — camera-space **+x appears on the LEFT of the image** (Mitsuba's
/// `lookat` puts +x = up × dir, i.e. to the viewer's left, so the image is not mirrored). For a
/// film position (fx, fy) in pixels of the full film (x right, y down, pixel (i, j) covering
/// [i, i+1) × [j, j+1)), with t = tan(fov_x / 2) and aspect = width / height:
///
/// d_cam = normalize(((1 − 2 fx / width) · t, (1 − 2 fy / height) · t / aspect, 1)),
/// ray origin = to_world · (0, 0, 0), direction = linear part of to_world · d_cam,
/// t_min = near_clip / d_cam.z, t_max = far_clip / d_cam.z. The renderer's
/// [`crate::render::camera::PerspectiveCamera`] does exactly this. With a crop window, pixel (i, j) of the output is pixel (i + x, j + y) of the full film.
#[derive(Clone, Debug)]
pub struct Camera {
    /// Camera → world (no scale); the camera looks along +z with +y up and +x to the image's left.
    pub to_world: Mat4,
    /// Full horizontal field of view in degrees (any `fov_axis` resolved by the loader).
    pub fov_x_deg: f32,
    pub near_clip: f32,
    pub far_clip: f32,
    /// Film resolution in pixels.
    pub width: u32,
    pub height: u32,
    /// Optional crop window (x, y, w, h) in pixels of the full film.
    pub crop: Option<[u32; 4]>,
    /// The film's reconstruction filter (Mitsuba's default: gaussian, σ = 0.5 pixel).
    pub filter: crate::math::filter::Filter,
}

impl Camera {
    /// Size (width, height) in pixels of the image actually rendered (the crop window if any).
    pub fn image_size(&self) -> (u32, u32) {
        match self.crop {
            Some([_, _, w, h]) => (w, h),
            None => (self.width, self.height),
        }
    }
}

/// Mitsuba's `direct` integrator: emitter and BSDF samples per camera-ray hit, combined with
/// the power heuristic.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DirectSettings {
    /// Samples of the emitter-sampling technique per hit (`emitter_samples`).
    pub emitter_samples: u32,
    /// Samples of the BSDF-sampling technique per hit (`bsdf_samples`).
    pub bsdf_samples: u32,
}

/// The Mitsuba sampler a scene names. All of them draw from btfpt's independent sampler: the
/// expected image is the same, only the noise differs; the sample count is the one Mitsuba's
/// sampler would take (rounded as it rounds).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SamplerType {
    #[default]
    Independent,
    Stratified,
    Multijitter,
    LdSampler,
    Orthogonal,
}

impl SamplerType {
    /// Mitsuba's plugin name.
    pub fn name(self) -> &'static str {
        match self {
            SamplerType::Independent => "independent",
            SamplerType::Stratified => "stratified",
            SamplerType::Multijitter => "multijitter",
            SamplerType::LdSampler => "ldsampler",
            SamplerType::Orthogonal => "orthogonal",
        }
    }
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
    /// `sampler.sample_count`.
    pub spp: u32,
    pub meshes: Vec<Mesh>,
    pub bsdfs: Vec<Bsdf>,
    pub emitters: Vec<Emitter>,
    /// The file and model each `<bsdf type="btf">` renders, in scene order (for the summary).
    pub btf_uses: Vec<measured_material::BtfUse>,
    /// Every file the scene reads besides its own (included files, meshes, textures, BTF data
    /// and models), in load order: what a partial render's fingerprint covers.
    pub inputs: Vec<std::path::PathBuf>,
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
