//! The scene description: what the Mitsuba-XML and glTF loaders produce and the renderer consumes.

pub mod btf_bsdf;
pub mod gltf;
pub mod mitsuba_xml;
pub mod obj;
pub mod ply;
pub mod props;
pub mod serialized;
pub mod shapes;
pub mod transform;

use crate::bsdf::Bsdf;
use crate::geometry::Mesh;
use crate::io::RgbImage;
use crate::math::{Mat4, Spectrum, Vec3};
use std::path::PathBuf;
use std::sync::Arc;

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
/// t_min = near_clip / d_cam.z, t_max = far_clip / d_cam.z. [`Camera::generate_ray`] does exactly
/// this. With a crop window, pixel (i, j) of the output is pixel (i + x, j + y) of the full film.
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
}

impl Camera {
    /// The primary ray through film position (`fx`, `fy`) in pixels of the full film (see the type
    /// docs): (origin, unit direction, t_min, t_max), all in world space.
    pub fn generate_ray(&self, fx: f32, fy: f32) -> (Vec3, Vec3, f32, f32) {
        let t = (0.5 * self.fov_x_deg.to_radians()).tan();
        let aspect = self.width as f32 / self.height as f32;
        let d = Vec3::new(
            (1.0 - 2.0 * fx / self.width as f32) * t,
            (1.0 - 2.0 * fy / self.height as f32) * t / aspect,
            1.0,
        )
        .normalize();
        let inv_z = 1.0 / d.z;
        let o = self.to_world.transform_point3(Vec3::ZERO);
        let dw = self.to_world.transform_vector3(d).normalize();
        (o, dw, self.near_clip * inv_z, self.far_clip * inv_z)
    }

    /// Size (width, height) in pixels of the image actually rendered (the crop window if any).
    pub fn image_size(&self) -> (u32, u32) {
        match self.crop {
            Some([_, _, w, h]) => (w, h),
            None => (self.width, self.height),
        }
    }
}

/// Settings of the `path` integrator (Mitsuba 3 semantics).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IntegratorSettings {
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
            max_depth: -1,
            rr_depth: 5,
            hide_emitters: false,
        }
    }
}

/// Emitters that are not attached to a shape (area emitters live on [`Mesh::emitter`]).
#[derive(Clone, Debug)]
pub enum Emitter {
    /// Isotropic point light; `intensity` in W/sr.
    Point { position: Vec3, intensity: Spectrum },
    /// Spot light shining along +z of `to_world`; angles in degrees (Mitsuba defaults 20 and 0.75·cutoff).
    Spot {
        to_world: Mat4,
        intensity: Spectrum,
        cutoff_angle: f32,
        beam_width: f32,
    },
    /// Distant light; `direction` is the unit direction of travel (world), `irradiance` in W/m².
    Directional {
        direction: Vec3,
        irradiance: Spectrum,
    },
    /// Uniform environment radiance.
    Constant { radiance: Spectrum },
    /// Lat-long environment map (Mitsuba `envmap` mapping), radiance = scale · image.
    EnvMap {
        image: Arc<RgbImage>,
        to_world: Mat4,
        scale: f32,
        filename: PathBuf,
    },
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
}

/// Loads a scene file: Mitsuba 3 XML (`.xml`) or glTF 2.0 (`.gltf`, `.glb`). `defines` override
/// XML `<default>` values (the CLI's `-D name=value`); for glTF they set `width`, `height`, `spp`,
/// `max_depth` (see [`gltf`]).
pub fn load(path: &std::path::Path, defines: &[(String, String)]) -> crate::Result<Scene> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "xml" => mitsuba_xml::load(path, defines),
        "gltf" | "glb" => gltf::load(path, defines),
        _ => Err(crate::Error::format(
            path,
            "unknown scene format (expected .xml, .gltf or .glb)",
        )),
    }
}
