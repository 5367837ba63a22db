//! glTF 2.0 scenes (`.gltf` with external or data-URI buffers, `.glb`) via the `gltf` crate.
//!
//! Mapping (documented choices where glTF and Mitsuba differ):
//! - Meshes: triangle primitives of every node of the default scene, with node transforms; missing
//!   normals → flat (face) normals, as the glTF spec requires; negative-determinant transforms keep
//!   the front side (counter-clockwise winding) outward.
//! - Materials (metallic-roughness): metallic factor ≥ 0.5 → `roughconductor` (GGX,
//!   alpha = roughness², perfect-mirror Fresnel tinted by the base colour), or a smooth `conductor`
//!   when alpha < 1e-4; otherwise `diffuse` with base colour × base-colour texture (sRGB decoded).
//!   `doubleSided` → `twosided`. Only factors are used for metallic/roughness; normal, occlusion
//!   and metallic-roughness textures are ignored. Emissive factor (× KHR_materials_emissive_strength)
//!   → area emitter, times the emissive texture (sRGB decoded) where there is one.
//! - Camera: the first perspective camera met in the node hierarchy (glTF looks along −z, +x right;
//!   converted to btfpt's Mitsuba convention by a 180° turn about y). `yfov` is resolved to the
//!   horizontal fov with aspect = width / height.
//! - KHR_lights_punctual: point and spot intensities (candela) are used as W/sr, directional
//!   illuminance (lux) as W/m², all times the light colour; spot outer/inner cone angles →
//!   `cutoff_angle` / `beam_width`; `range` is ignored (physically based inverse-square falloff).
//! - Settings glTF lacks, overridable with defines: `width` (768), `height` (576, or width / the
//!   camera's aspectRatio if given), `spp` (64), `max_depth` (−1). Other defines are errors.

use super::shapes::{self, MeshOptions};
use super::{Camera, Emitter, IntegratorSettings, LoadOptions, Scene};
use crate::bsdf::{Bsdf, Conductor, Diffuse, MicrofacetType, RoughConductor, Texture, TwoSided};
use crate::geometry::Mesh;
use crate::io::RgbImage;
use crate::math::color::{srgb_to_linear, srgb8_to_linear_table};
use crate::math::{Mat3, Mat4, Spectrum, Vec3};
use crate::{Error, Result};
use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

mod mesh;

/// Default film width in pixels (Mitsuba's).
pub const DEFAULT_WIDTH: u32 = 768;
/// Default film height in pixels (Mitsuba's).
pub const DEFAULT_HEIGHT: u32 = 576;
/// Default samples per pixel.
pub const DEFAULT_SPP: u32 = 64;

/// Rotation by 180° about y: maps btfpt/Mitsuba camera space (+z forward, +x left) to glTF's
/// (−z forward, +x right).
const FLIP_YZ: Mat4 = Mat4::from_cols_array(&[
    -1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
]);

struct Settings {
    width: Option<u32>,
    height: Option<u32>,
    spp: u32,
    max_depth: i32,
}

fn settings(path: &Path, defines: &[(String, String)]) -> Result<Settings> {
    let mut s = Settings {
        width: None,
        height: None,
        spp: DEFAULT_SPP,
        max_depth: -1,
    };
    for (k, v) in defines {
        let bad = || Error::format(path, format!("define {k}={v}: expected a positive integer"));
        match k.as_str() {
            "width" => {
                s.width = Some(
                    v.trim()
                        .parse()
                        .ok()
                        .filter(|&w: &u32| w > 0)
                        .ok_or_else(bad)?,
                )
            }
            "height" => {
                s.height = Some(
                    v.trim()
                        .parse()
                        .ok()
                        .filter(|&w: &u32| w > 0)
                        .ok_or_else(bad)?,
                )
            }
            "spp" => {
                s.spp = v
                    .trim()
                    .parse()
                    .ok()
                    .filter(|&w: &u32| w > 0)
                    .ok_or_else(bad)?
            }
            "max_depth" => {
                s.max_depth = v
                    .trim()
                    .parse()
                    .ok()
                    .filter(|&d: &i32| d >= -1)
                    .ok_or_else(|| {
                        Error::format(
                            path,
                            format!("define {k}={v}: expected -1 or an integer >= 0"),
                        )
                    })?
            }
            _ => {
                return Err(Error::format(
                    path,
                    format!(
                        "unknown define \"{k}\" for a glTF scene (known: width, height, spp, max_depth)"
                    ),
                ));
            }
        }
    }
    Ok(s)
}

/// Loads a glTF 2.0 scene (see the module docs for the mapping).
pub fn load(path: &Path, options: &LoadOptions) -> Result<Scene> {
    let settings = settings(path, &options.defines)?;
    if !path.exists() {
        return Err(Error::format(path, "file not found"));
    }
    let (doc, buffers, images) =
        ::gltf::import(path).map_err(|e| Error::format(path, format!("cannot load glTF: {e}")))?;
    // External buffers and images (not `data:` URIs, not the .glb's own chunk).
    let dir = path.parent().unwrap_or(Path::new(""));
    let external = |uri: &str| (!uri.starts_with("data:")).then(|| dir.join(uri));
    let inputs: Vec<std::path::PathBuf> = doc
        .buffers()
        .filter_map(|b| match b.source() {
            ::gltf::buffer::Source::Uri(u) => external(u),
            ::gltf::buffer::Source::Bin => None,
        })
        .chain(doc.images().filter_map(|i| match i.source() {
            ::gltf::image::Source::Uri { uri, .. } => external(uri),
            ::gltf::image::Source::View { .. } => None,
        }))
        .collect();
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| Error::format(path, "the glTF file has no scene"))?;
    let mut b = GltfBuilder {
        path,
        buffers: &buffers,
        images: &images,
        bsdfs: Vec::new(),
        material_memo: HashMap::new(),
        image_memo: HashMap::new(),
        meshes: Vec::new(),
        emitters: Vec::new(),
        emission_textures: Vec::new(),
        camera: None,
        settings: &settings,
    };
    for node in scene.nodes() {
        b.visit(&node, Mat4::IDENTITY)?;
    }
    let camera = b
        .camera
        .take()
        .ok_or_else(|| Error::format(path, "the glTF scene has no perspective camera"))?;
    Ok(Scene {
        source: path.to_path_buf(),
        camera,
        integrator: IntegratorSettings {
            max_depth: settings.max_depth,
            ..Default::default()
        },
        channels: Default::default(),
        spp: settings.spp,
        meshes: b.meshes,
        bsdfs: b.bsdfs,
        emitters: b.emitters,
        emission_textures: b.emission_textures,
        btf_uses: Vec::new(),
        inputs,
    })
}

struct GltfBuilder<'p> {
    path: &'p Path,
    buffers: &'p [::gltf::buffer::Data],
    images: &'p [::gltf::image::Data],
    bsdfs: Vec<Bsdf>,
    /// Material index (None = glTF default material) → (bsdf index, emitted radiance).
    material_memo: HashMap<Option<usize>, (u32, Option<Texture>)>,
    image_memo: HashMap<usize, Arc<RgbImage>>,
    meshes: Vec<Mesh>,
    emitters: Vec<Emitter>,
    /// Radiance textures of emissive meshes, by mesh index (see [`Scene::emission_textures`]).
    emission_textures: Vec<(u32, Texture)>,
    camera: Option<Camera>,
    settings: &'p Settings,
}

impl GltfBuilder<'_> {
    fn err(&self, msg: impl Into<String>) -> Error {
        Error::format(self.path, msg)
    }

    fn visit(&mut self, node: &::gltf::Node, parent: Mat4) -> Result<()> {
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        if !crate::math::transform::is_finite(&world) {
            return Err(self.err(format!("node {} has a non-finite transform", node.index())));
        }
        if let Some(mesh) = node.mesh() {
            self.mesh(&mesh, &world, node.index())?;
        }
        if let Some(cam) = node.camera()
            && self.camera.is_none()
            && let ::gltf::camera::Projection::Perspective(p) = cam.projection()
        {
            self.camera = Some(self.make_camera(&p, &world, node.index())?);
        }
        if let Some(light) = node.light() {
            self.light(&light, &world, node.index())?;
        }
        for ch in node.children() {
            self.visit(&ch, world)?;
        }
        Ok(())
    }

    fn make_camera(
        &self,
        p: &::gltf::camera::Perspective,
        world: &Mat4,
        node: usize,
    ) -> Result<Camera> {
        let width = self.settings.width.unwrap_or(DEFAULT_WIDTH);
        let height = match (self.settings.height, p.aspect_ratio()) {
            (Some(h), _) => h,
            (None, Some(a)) if a > 0.0 && self.settings.width.is_some() => {
                ((width as f32 / a).round() as u32).max(1)
            }
            (None, Some(a)) if a > 0.0 => ((DEFAULT_WIDTH as f32 / a).round() as u32).max(1),
            _ => DEFAULT_HEIGHT,
        };
        let aspect = width as f64 / height as f64;
        let yfov = p.yfov() as f64;
        if !(yfov > 0.0 && yfov < std::f64::consts::PI) {
            return Err(self.err(format!(
                "camera of node {node}: yfov {yfov} is out of range"
            )));
        }
        let fov_x = (2.0 * ((0.5 * yfov).tan() * aspect).atan()).to_degrees() as f32;
        // Drop any scale from the node transform (cameras must be rigid).
        let l = Mat3::from_mat4(*world);
        let (c0, c1, c2) = (
            l.x_axis.normalize(),
            l.y_axis.normalize(),
            l.z_axis.normalize(),
        );
        if !(c0.is_finite() && c1.is_finite() && c2.is_finite()) {
            return Err(self.err(format!("camera of node {node} has a degenerate transform")));
        }
        let rigid = Mat4::from_cols(c0.extend(0.0), c1.extend(0.0), c2.extend(0.0), world.w_axis);
        let near = p.znear();
        let far = p.zfar().unwrap_or(1e4);
        if !(near > 0.0 && near < far) {
            return Err(self.err(format!(
                "camera of node {node}: invalid znear {near} / zfar {far}"
            )));
        }
        Ok(Camera {
            to_world: rigid * FLIP_YZ,
            projection: crate::scene::Projection::Perspective,
            fov_x_deg: fov_x,
            near_clip: near,
            far_clip: far,
            width,
            height,
            crop: None,
            filter: crate::math::filter::Filter::BOX,
        })
    }

    fn light(
        &mut self,
        light: &::gltf::khr_lights_punctual::Light,
        world: &Mat4,
        node: usize,
    ) -> Result<()> {
        use ::gltf::khr_lights_punctual::Kind;
        let power = Vec3::from(light.color()) * light.intensity();
        if !power.is_finite() {
            return Err(self.err(format!("light of node {node} has a non-finite intensity")));
        }
        let position = world.transform_point3(Vec3::ZERO);
        let forward = world.transform_vector3(-Vec3::Z).normalize();
        match light.kind() {
            Kind::Point => self.emitters.push(Emitter::Point {
                position,
                intensity: power,
            }),
            Kind::Directional => {
                if !forward.is_finite() {
                    return Err(self.err(format!(
                        "directional light of node {node} has a degenerate transform"
                    )));
                }
                self.emitters.push(Emitter::Directional {
                    direction: forward,
                    irradiance: power,
                })
            }
            Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => {
                let up = world.transform_vector3(Vec3::Y);
                if !forward.is_finite() || up.cross(forward).length_squared() == 0.0 {
                    return Err(self.err(format!(
                        "spot light of node {node} has a degenerate transform"
                    )));
                }
                let to_world = crate::math::transform::look_at(position, position + forward, up);
                let cutoff = outer_cone_angle.to_degrees();
                self.emitters.push(Emitter::Spot {
                    to_world,
                    intensity: power,
                    cutoff_angle: cutoff,
                    beam_width: inner_cone_angle.to_degrees().min(cutoff),
                    texture: None,
                })
            }
        }
        Ok(())
    }

    fn mesh(&mut self, mesh: &::gltf::Mesh, world: &Mat4, node: usize) -> Result<()> {
        let mirror = Mat3::from_mat4(*world).determinant() < 0.0;
        for prim in mesh.primitives() {
            let what = || {
                format!(
                    "mesh {} primitive {} (node {node})",
                    mesh.index(),
                    prim.index()
                )
            };
            if prim.mode() != ::gltf::mesh::Mode::Triangles {
                return Err(self.err(format!(
                    "{}: only triangle primitives are supported",
                    what()
                )));
            }
            let local = mesh::read(&prim, self.buffers, mirror, shapes::available_memory())
                .map_err(|e| self.err(format!("{}: {e}", what())))?;
            let face_normals = local.normals.is_empty();
            let opts = MeshOptions {
                face_normals,
                ..Default::default()
            };
            let mut m = shapes::to_world(local, world, opts)
                .map_err(|e| self.err(format!("{}: {e}", what())))?;
            if m.indices.is_empty() {
                continue;
            }
            let (bsdf, emitter) = self.material(prim.material())?;
            m.name = mesh.name().map(str::to_string).unwrap_or_else(what);
            m.bsdf = bsdf;
            if let Some(t) = emitter.and_then(|r| super::attach_emission(&mut m, r)) {
                self.emission_textures.push((self.meshes.len() as u32, t));
            }
            self.meshes.push(m);
        }
        Ok(())
    }

    fn material(&mut self, mat: ::gltf::Material) -> Result<(u32, Option<Texture>)> {
        if let Some(r) = self.material_memo.get(&mat.index()) {
            return Ok(r.clone());
        }
        let name = mat
            .index()
            .map(|i| format!("material {i}"))
            .unwrap_or_else(|| "the default material".into());
        let pbr = mat.pbr_metallic_roughness();
        let [r, g, b, _a] = pbr.base_color_factor();
        let factor = Vec3::new(r, g, b);
        let base = self.factor_texture(&name, factor, pbr.base_color_texture())?;
        let alpha = pbr.roughness_factor() * pbr.roughness_factor();
        let mut bsdf = if pbr.metallic_factor() >= 0.5 {
            if alpha < 1e-4 {
                Bsdf::Conductor(Conductor {
                    eta: Texture::Constant(Spectrum::ZERO),
                    k: Texture::Constant(Spectrum::ONE),
                    specular_reflectance: base,
                })
            } else {
                Bsdf::RoughConductor(RoughConductor {
                    distribution: MicrofacetType::Ggx,
                    alpha_u: Texture::uniform(alpha),
                    alpha_v: Texture::uniform(alpha),
                    eta: Texture::Constant(Spectrum::ZERO),
                    k: Texture::Constant(Spectrum::ONE),
                    specular_reflectance: base,
                    sample_visible: true,
                })
            }
        } else {
            Bsdf::Diffuse(Diffuse { reflectance: base })
        };
        if mat.double_sided() {
            bsdf = Bsdf::TwoSided(TwoSided {
                front: Box::new(bsdf.clone()),
                back: Box::new(bsdf),
            });
        }
        let e = Vec3::from(mat.emissive_factor()) * mat.emissive_strength().unwrap_or(1.0);
        let emitter = if e.max_element() > 0.0 {
            Some(self.factor_texture(&name, e, mat.emissive_texture())?)
        } else {
            None
        };
        self.bsdfs.push(bsdf);
        let r = ((self.bsdfs.len() - 1) as u32, emitter);
        self.material_memo.insert(mat.index(), r.clone());
        Ok(r)
    }

    /// `factor` times the texture of `info` (TEXCOORD_0 only), or the constant `factor`.
    fn factor_texture(
        &mut self,
        name: &str,
        factor: Vec3,
        info: Option<::gltf::texture::Info>,
    ) -> Result<Texture> {
        let Some(info) = info else {
            return Ok(Texture::Constant(factor));
        };
        if info.tex_coord() != 0 {
            return Err(self.err(format!("{name}: only TEXCOORD_0 is supported")));
        }
        let img = self.image(info.texture().source().index())?;
        let img = if factor == Vec3::ONE {
            img
        } else {
            let mut scaled = (*img).clone();
            for px in scaled.data.chunks_exact_mut(3) {
                for c in 0..3 {
                    px[c] *= factor[c];
                }
            }
            Arc::new(scaled)
        };
        Ok(Texture::Bitmap(img))
    }

    /// A glTF image as linear RGB (8/16-bit data is sRGB-encoded colour; float data is linear).
    fn image(&mut self, index: usize) -> Result<Arc<RgbImage>> {
        if let Some(i) = self.image_memo.get(&index) {
            return Ok(i.clone());
        }
        use ::gltf::image::Format as F;
        let d = self
            .images
            .get(index)
            .ok_or_else(|| self.err(format!("image {index} is missing")))?;
        let (w, h) = (d.width as usize, d.height as usize);
        let (channels, bytes) = match d.format {
            F::R8 => (1, 1),
            F::R8G8 => (2, 1),
            F::R8G8B8 => (3, 1),
            F::R8G8B8A8 => (4, 1),
            F::R16 => (1, 2),
            F::R16G16 => (2, 2),
            F::R16G16B16 => (3, 2),
            F::R16G16B16A16 => (4, 2),
            F::R32G32B32FLOAT => (3, 4),
            F::R32G32B32A32FLOAT => (4, 4),
        };
        if d.pixels.len() != w * h * channels * bytes {
            return Err(self.err(format!(
                "image {index}: pixel buffer size does not match {w} x {h}"
            )));
        }
        let lut = srgb8_to_linear_table();
        let mut img = RgbImage::new(w, h);
        for i in 0..w * h {
            let mut rgb = [0.0f32; 3];
            for (c, out) in rgb.iter_mut().enumerate() {
                let ch = if channels < 3 { 0 } else { c };
                let o = (i * channels + ch) * bytes;
                *out = match bytes {
                    1 => lut[d.pixels[o] as usize],
                    2 => srgb_to_linear(
                        u16::from_le_bytes([d.pixels[o], d.pixels[o + 1]]) as f32 / 65535.0,
                    ),
                    _ => f32::from_le_bytes([
                        d.pixels[o],
                        d.pixels[o + 1],
                        d.pixels[o + 2],
                        d.pixels[o + 3],
                    ]),
                };
            }
            img.data[3 * i..3 * i + 3].copy_from_slice(&rgb);
        }
        let a = Arc::new(img);
        self.image_memo.insert(index, a.clone());
        Ok(a)
    }
}
