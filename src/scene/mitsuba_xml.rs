//! Mitsuba 3 XML scenes (the subset btfpt renders) → [`Scene`].
//!
//! Semantics follow Mitsuba 3's `xml.cpp` and plugins: `<default>`/`$name` substitution with CLI
//! defines winning, ids unique, `<ref>` to any object with an id, unknown plugins, elements or
//! unqueried properties are errors naming the file and line.

use super::props::{Props, XmlDoc};
use super::shapes::{self, MeshOptions};
use super::{Camera, Emitter, IntegratorSettings, LoadOptions, Scene};
use crate::bsdf::{
    Bsdf, Conductor, Dielectric, Diffuse, RoughConductor, Texture, ThinDielectric, TwoSided,
};
use crate::geometry::Mesh;
use crate::geometry::sphere::Sphere;
use crate::math::transform::{is_finite, xf_point};
use crate::math::{Mat3, Mat4, Spectrum, Vec3};
use crate::{Error, Result};
use roxmltree::{Node, NodeId};
use std::collections::{HashMap, HashSet};
use std::path::Path;
use std::sync::Arc;

/// Mitsuba's film defaults.
const DEFAULT_WIDTH: i64 = 768;
const DEFAULT_HEIGHT: i64 = 576;

/// Loads a Mitsuba 3 XML scene; `options.defines` override `<default>` values (CLI `-D
/// name=value`), `options.btf_model` replaces every BTF's `model`.
pub fn load(path: &Path, options: &LoadOptions) -> Result<Scene> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let opts = roxmltree::ParsingOptions {
        allow_dtd: true,
        ..Default::default()
    };
    let doc = roxmltree::Document::parse_with_options(&text, opts).map_err(|e| Error::Scene {
        file: path.to_path_buf(),
        line: e.pos().row,
        msg: format!("malformed XML: {e}"),
    })?;
    let x = XmlDoc::new(path, &doc, &options.defines)?;
    let mut b = Builder {
        x: &x,
        btf_model: options.btf_model.as_deref(),
        bsdfs: Vec::new(),
        bsdf_memo: HashMap::new(),
        tex_memo: HashMap::new(),
        busy: HashSet::new(),
        default_bsdf: None,
        meshes: Vec::new(),
        emitters: Vec::new(),
    };
    b.scene(doc.root_element())
}

struct Builder<'a, 'x> {
    x: &'x XmlDoc<'a>,
    /// [`LoadOptions::btf_model`]: replaces every BTF's `model` property.
    btf_model: Option<&'x str>,
    bsdfs: Vec<Bsdf>,
    bsdf_memo: HashMap<NodeId, u32>,
    tex_memo: HashMap<NodeId, Texture>,
    /// Objects being built (reference-cycle detection).
    busy: HashSet<NodeId>,
    default_bsdf: Option<u32>,
    meshes: Vec<crate::geometry::Mesh>,
    emitters: Vec<Emitter>,
}

type N<'a> = Node<'a, 'a>;

impl<'a, 'x> Builder<'a, 'x> {
    fn scene(&mut self, root: N<'a>) -> Result<Scene> {
        let x = self.x;
        if root.tag_name().name() != "scene" {
            return Err(x.err(
                root,
                format!(
                    "root element must be <scene>, found <{}>",
                    root.tag_name().name()
                ),
            ));
        }
        x.check_attrs(root, &["version", "type", "id"])?;
        let version = x.req_attr(root, "version")?;
        let major = version
            .split('.')
            .next()
            .and_then(|v| v.trim().parse::<u32>().ok());
        match major {
            Some(2..=3) => {}
            _ => {
                return Err(x.err(
                    root,
                    format!("unsupported scene version \"{version}\" (btfpt reads Mitsuba 3 scenes, version 2.x or 3.x)"),
                ));
            }
        }
        let mut camera: Option<(Camera, u32)> = None;
        let mut integrator: Option<IntegratorSettings> = None;
        for ch in root.children() {
            if !ch.is_element() {
                if ch.is_text() && !ch.text().unwrap_or("").trim().is_empty() {
                    return Err(x.err(ch, "unexpected text content in <scene>"));
                }
                continue;
            }
            match ch.tag_name().name() {
                "default" => {}
                "integrator" => {
                    if integrator.is_some() {
                        return Err(x.err(ch, "more than one <integrator>"));
                    }
                    integrator = Some(self.integrator(ch)?);
                }
                "sensor" => {
                    if camera.is_some() {
                        return Err(x.err(ch, "more than one <sensor> (btfpt renders one camera)"));
                    }
                    camera = Some(self.sensor(ch)?);
                }
                "shape" => self.shape(ch)?,
                "bsdf" => {
                    self.bsdf_index(ch)?;
                }
                "texture" => {
                    self.texture(ch)?;
                }
                "emitter" => {
                    let p = Props::parse(x, ch)?;
                    if p.ty == "area" {
                        return Err(x.err(ch, "an area emitter must be nested inside a <shape>"));
                    }
                    let e = self.emitter(&p)?;
                    p.finish()?;
                    self.emitters.push(e);
                }
                other => {
                    return Err(x.err(
                        ch,
                        format!("unexpected element <{other}> at the top level of the scene"),
                    ));
                }
            }
        }
        let (camera, spp) = camera.ok_or_else(|| x.err(root, "the scene has no <sensor>"))?;
        Ok(Scene {
            source: x.file.clone(),
            camera,
            integrator: integrator.unwrap_or_default(),
            spp,
            meshes: std::mem::take(&mut self.meshes),
            bsdfs: std::mem::take(&mut self.bsdfs),
            emitters: std::mem::take(&mut self.emitters),
        })
    }

    fn integrator(&mut self, node: N<'a>) -> Result<IntegratorSettings> {
        let p = Props::parse(self.x, node)?;
        if p.ty != "path" {
            return Err(p.err("unsupported integrator type (btfpt implements only \"path\")"));
        }
        let max_depth = p.int("max_depth", -1)?;
        let rr_depth = p.int("rr_depth", 5)?;
        let hide_emitters = p.bool("hide_emitters", false)?;
        p.finish()?;
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
        })
    }

    fn sensor(&mut self, node: N<'a>) -> Result<(Camera, u32)> {
        let x = self.x;
        let p = Props::parse(x, node)?;
        if p.ty != "perspective" {
            return Err(p.err("unsupported sensor type (btfpt implements only \"perspective\")"));
        }
        // Film first: the aspect ratio resolves fov_axis.
        let film = p.single_child("film")?.ok_or_else(|| {
            p.err(
                "missing <film>: Mitsuba's default film uses a gaussian reconstruction filter; add \
                 <film type=\"hdrfilm\"> with <rfilter type=\"box\"/>",
            )
        })?;
        let f = Props::parse(x, film.node)?;
        if f.ty != "hdrfilm" {
            return Err(f.err("unsupported film type (btfpt implements only \"hdrfilm\")"));
        }
        let width = f.int("width", DEFAULT_WIDTH)?;
        let height = f.int("height", DEFAULT_HEIGHT)?;
        if width <= 0 || height <= 0 || width > 1 << 20 || height > 1 << 20 {
            return Err(f.err(format!("invalid film size {width} x {height}")));
        }
        let cox = f.int("crop_offset_x", 0)?;
        let coy = f.int("crop_offset_y", 0)?;
        let cw = f.int("crop_width", width)?;
        let ch = f.int("crop_height", height)?;
        if cox < 0 || coy < 0 || cw <= 0 || ch <= 0 || cox + cw > width || coy + ch > height {
            return Err(f.err(format!(
                "invalid crop window (offset {cox}, {coy}, size {cw} x {ch}) for a {width} x {height} film"
            )));
        }
        let crop = if (cox, coy, cw, ch) == (0, 0, width, height) {
            None
        } else {
            Some([cox as u32, coy as u32, cw as u32, ch as u32])
        };
        // Output-format options that do not change RGB pixel values are accepted.
        for (name, default, ok) in [
            ("file_format", "openexr", &["openexr", "exr"][..]),
            ("pixel_format", "rgb", &["rgb", "rgba"][..]),
            ("component_format", "float32", &["float16", "float32"][..]),
        ] {
            let v = f.string(name, default)?.to_ascii_lowercase();
            if !ok.contains(&v.as_str()) {
                return Err(f.err(format!(
                    "{name} \"{v}\" is not supported (use one of {ok:?})"
                )));
            }
        }
        // With a box filter of radius 0.5 no sample reaches a neighbouring pixel: no effect.
        let _ = f.bool("sample_border", false)?;
        let rf = f.single_child("rfilter")?.ok_or_else(|| {
            f.err(
                "missing <rfilter>: Mitsuba would use its default gaussian filter, which btfpt does not \
                 implement; add <rfilter type=\"box\"/> inside the <film>",
            )
        })?;
        let r = Props::parse(x, rf.node)?;
        if r.ty != "box" {
            return Err(r.err(
                "unsupported reconstruction filter (btfpt implements only \"box\" of radius 0.5)",
            ));
        }
        let radius = r.float("radius", 0.5)?;
        if radius != 0.5 {
            return Err(r.err("only the default box radius 0.5 (one pixel) is supported"));
        }
        r.finish()?;
        f.finish()?;

        let aspect = width as f64 / height as f64;
        let fov_x = parse_fov(&p, aspect)?;
        let near_clip = p.float("near_clip", 1e-2)?;
        let far_clip = p.float("far_clip", 1e4)?;
        if near_clip <= 0.0 {
            return Err(p.err("the \"near_clip\" parameter must be greater than zero"));
        }
        if near_clip >= far_clip {
            return Err(p.err("the \"near_clip\" parameter must be smaller than \"far_clip\""));
        }
        // A pinhole camera is in focus everywhere: the focus distance changes nothing.
        let _ = p.float("focus_distance", far_clip)?;
        let to_world = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
        let l = Mat3::from_mat4(to_world);
        let g = l.transpose() * l;
        if (g - Mat3::IDENTITY)
            .to_cols_array()
            .iter()
            .any(|v| v.abs() > 1e-3)
        {
            return Err(
                p.err("scale factors in the camera-to-world transformation are not allowed")
            );
        }

        let spp = match p.single_child("sampler")? {
            None => 4,
            Some(s) => {
                let s = Props::parse(x, s.node)?;
                if s.ty != "independent" {
                    return Err(
                        s.err("unsupported sampler type (btfpt implements only \"independent\")")
                    );
                }
                let n = s.int("sample_count", 4)?;
                // The seed only changes the noise pattern, never the expected image.
                let _ = s.int("seed", 0)?;
                s.finish()?;
                if n <= 0 || n > u32::MAX as i64 {
                    return Err(s.err(format!("invalid sample_count {n}")));
                }
                n as u32
            }
        };
        p.finish()?;
        Ok((
            Camera {
                to_world,
                fov_x_deg: fov_x,
                near_clip,
                far_clip,
                width: width as u32,
                height: height as u32,
                crop,
            },
            spp,
        ))
    }

    fn shape(&mut self, node: N<'a>) -> Result<()> {
        let x = self.x;
        let p = Props::parse(x, node)?;
        let mut xf = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
        let flip_normals = p.bool("flip_normals", false)?;
        let mut opts = MeshOptions {
            flip_normals,
            ..Default::default()
        };
        let mut name = x.attr(node, "id").map(str::to_string);
        let wrap = |e: Error| x.err(node, format!("shape \"{}\": {e}", p.ty));
        let mut mesh_file = None;
        let mut analytic = false;
        let local = match p.ty.as_str() {
            "obj" | "ply" => {
                let file = p.string_req("filename")?;
                let path = x.resolve(&file);
                mesh_file = Some(path.clone());
                opts.face_normals = p.bool("face_normals", false)?;
                opts.recompute_normals = true;
                let flip_uv = p.bool("flip_tex_coords", p.ty == "obj")?;
                name.get_or_insert(file);
                if p.ty == "obj" {
                    super::obj::load(&path, flip_uv).map_err(wrap)?
                } else {
                    super::ply::load(&path, flip_uv).map_err(wrap)?
                }
            }
            "rectangle" => {
                let l = Mat3::from_mat4(xf);
                if l.x_axis.normalize().dot(l.y_axis.normalize()).abs() > 1e-4 {
                    return Err(p.err("the to_world transformation contains shear, which Mitsuba's rectangle does not support"));
                }
                opts.keep_orientation = true;
                shapes::rectangle()
            }
            "disk" => {
                opts.keep_orientation = true;
                shapes::disk(shapes::DISK_RINGS, shapes::DISK_SEGMENTS)
            }
            "cube" => shapes::cube(),
            "sphere" => {
                let center = p.vec3_opt("center")?.unwrap_or(Vec3::ZERO);
                let radius = p.float("radius", 1.0)?;
                if radius <= 0.0 {
                    return Err(p.err("the sphere radius must be positive"));
                }
                xf = xf * Mat4::from_translation(center) * Mat4::from_scale(Vec3::splat(radius));
                // Mitsuba's sphere is analytic: it keeps only the centre and the radius of to_world
                // (warning about the rest), so an ellipsoid here would not match its render.
                let l = Mat3::from_mat4(xf);
                let g = l.transpose() * l;
                let s2 = g.x_axis.x;
                if (g - Mat3::from_diagonal(Vec3::splat(s2)))
                    .to_cols_array()
                    .iter()
                    .any(|v| v.abs() > 1e-4 * s2)
                {
                    return Err(p.err("to_world must not contain non-uniform scale or shear for a sphere (Mitsuba ignores it)"));
                }
                // Analytic, as Mitsuba's: centre, radius and orientation of to_world.
                analytic = true;
                shapes::LocalMesh::default()
            }
            _ => {
                return Err(p.err(
                    "unsupported shape type (btfpt implements obj, ply, rectangle, cube, sphere, disk)",
                ));
            }
        };
        if !is_finite(&xf) {
            return Err(p.err("to_world contains NaN or infinite values"));
        }
        let bsdf = match p.single_child("bsdf")? {
            Some(c) => self.bsdf_index(c.node)?,
            None => self.default_bsdf(),
        };
        let emitter = match p.single_child("emitter")? {
            None => None,
            Some(c) => {
                let e = Props::parse(x, c.node)?;
                if e.ty != "area" {
                    return Err(e.err("only \"area\" emitters can be attached to a shape"));
                }
                let radiance = e.color("radiance", Vec3::ONE)?;
                e.finish()?;
                Some(radiance)
            }
        };
        p.finish()?;
        let mut mesh = if analytic {
            let sphere = Sphere::from_to_world(&xf, flip_normals)
                .ok_or_else(|| p.err("to_world is singular for a sphere"))?;
            Mesh {
                sphere: Some(sphere),
                ..Default::default()
            }
        } else {
            shapes::to_world(local, &xf, opts).map_err(|m| p.err(m))?
        };
        if mesh.indices.is_empty() && mesh.sphere.is_none() {
            return Err(p.err(match mesh_file {
                Some(f) => format!(
                    "{}: the mesh has no triangles of non-zero area",
                    f.display()
                ),
                None => "the shape has no triangles of non-zero area".into(),
            }));
        }
        mesh.name = name.unwrap_or_else(|| p.ty.clone());
        mesh.bsdf = bsdf;
        mesh.emitter = emitter;
        self.meshes.push(mesh);
        Ok(())
    }

    fn default_bsdf(&mut self) -> u32 {
        *self.default_bsdf.get_or_insert_with(|| {
            self.bsdfs.push(Bsdf::Diffuse(Diffuse {
                reflectance: Texture::Constant(Spectrum::splat(0.5)),
            }));
            (self.bsdfs.len() - 1) as u32
        })
    }

    /// The index in `Scene::bsdfs` of a `<bsdf>` element (built once per element).
    fn bsdf_index(&mut self, node: N<'a>) -> Result<u32> {
        if let Some(&i) = self.bsdf_memo.get(&node.id()) {
            return Ok(i);
        }
        let b = self.build_bsdf(node)?;
        self.bsdfs.push(b);
        let i = (self.bsdfs.len() - 1) as u32;
        self.bsdf_memo.insert(node.id(), i);
        Ok(i)
    }

    fn build_bsdf(&mut self, node: N<'a>) -> Result<Bsdf> {
        let x = self.x;
        if node.tag_name().name() != "bsdf" {
            return Err(x.err(
                node,
                format!("expected a <bsdf>, found <{}>", node.tag_name().name()),
            ));
        }
        if let Some(&i) = self.bsdf_memo.get(&node.id()) {
            return Ok(self.bsdfs[i as usize].clone());
        }
        if !self.busy.insert(node.id()) {
            return Err(x.err(node, "cyclic <ref> between bsdfs"));
        }
        let r = self.build_bsdf_inner(node);
        self.busy.remove(&node.id());
        r
    }

    fn build_bsdf_inner(&mut self, node: N<'a>) -> Result<Bsdf> {
        let x = self.x;
        let p = Props::parse(x, node)?;
        let b = match p.ty.as_str() {
            "diffuse" => Bsdf::Diffuse(Diffuse {
                reflectance: self.texture_param(&p, "reflectance", Vec3::splat(0.5))?,
            }),
            "conductor" | "roughconductor" => {
                let (eta, k) = conductor_ior(&p)?;
                let specular_reflectance =
                    self.texture_param(&p, "specular_reflectance", Vec3::ONE)?;
                if p.ty == "conductor" {
                    Bsdf::Conductor(Conductor {
                        eta,
                        k,
                        specular_reflectance,
                    })
                } else {
                    let dist = p.string_opt("distribution")?;
                    match dist.as_deref() {
                        Some("ggx") => {}
                        None => {
                            return Err(p.err(
                                "Mitsuba's default microfacet distribution is beckmann, which btfpt does not \
                                 implement: add <string name=\"distribution\" value=\"ggx\"/>",
                            ));
                        }
                        Some(d) => {
                            return Err(
                                p.err(format!("unsupported distribution \"{d}\" (only ggx)"))
                            );
                        }
                    }
                    let (alpha_u, alpha_v) = if p.has("alpha_u") || p.has("alpha_v") {
                        if p.has("alpha") {
                            return Err(p.err(
                                "specify either \"alpha\" or \"alpha_u\"/\"alpha_v\", not both",
                            ));
                        }
                        let (u, v) = (p.float_opt("alpha_u")?, p.float_opt("alpha_v")?);
                        match (u, v) {
                            (Some(u), Some(v)) => (u, v),
                            _ => {
                                return Err(
                                    p.err("both \"alpha_u\" and \"alpha_v\" must be specified")
                                );
                            }
                        }
                    } else {
                        let a = p.float("alpha", 0.1)?;
                        (a, a)
                    };
                    if alpha_u < 0.0 || alpha_v < 0.0 {
                        return Err(p.err("roughness must be non-negative"));
                    }
                    Bsdf::RoughConductor(RoughConductor {
                        alpha_u,
                        alpha_v,
                        eta,
                        k,
                        specular_reflectance,
                        sample_visible: p.bool("sample_visible", true)?,
                    })
                }
            }
            "dielectric" | "thindielectric" => {
                let int_ior = ior(&p, "int_ior", "bk7")?;
                let ext_ior = ior(&p, "ext_ior", "air")?;
                if int_ior < 0.0 || ext_ior < 0.0 {
                    return Err(
                        p.err("the interior and exterior indices of refraction must be positive")
                    );
                }
                let specular_reflectance =
                    self.texture_param(&p, "specular_reflectance", Vec3::ONE)?;
                let specular_transmittance =
                    self.texture_param(&p, "specular_transmittance", Vec3::ONE)?;
                let eta = int_ior / ext_ior;
                if p.ty == "dielectric" {
                    Bsdf::Dielectric(Dielectric {
                        eta,
                        specular_reflectance,
                        specular_transmittance,
                    })
                } else {
                    Bsdf::ThinDielectric(ThinDielectric {
                        eta,
                        specular_reflectance,
                        specular_transmittance,
                    })
                }
            }
            "twosided" => {
                let kids = p.children_tagged("bsdf");
                let nodes: Vec<N<'a>> = kids.iter().map(|c| c.node).collect();
                let (front, back) = match nodes.as_slice() {
                    [one] => {
                        let b = self.build_bsdf(*one)?;
                        (b.clone(), b)
                    }
                    [a, b] => (self.build_bsdf(*a)?, self.build_bsdf(*b)?),
                    _ => return Err(p.err("twosided needs one or two nested bsdfs")),
                };
                if matches!(front, Bsdf::TwoSided(_)) || matches!(back, Bsdf::TwoSided(_)) {
                    return Err(p.err("a twosided bsdf cannot contain another twosided bsdf"));
                }
                Bsdf::TwoSided(TwoSided {
                    front: Box::new(front),
                    back: Box::new(back),
                })
            }
            "btf" => {
                let file = p.string_req("filename")?;
                let uv_scale = p.float("uv_scale", 1.0)?;
                let model = p.string("model", "raw")?;
                p.finish()?;
                if uv_scale <= 0.0 {
                    return Err(p.err("\"uv_scale\" must be positive"));
                }
                return super::btf_bsdf::build_btf(
                    &x.file,
                    x.line(node),
                    &file,
                    &|f| x.resolve(f),
                    uv_scale,
                    self.btf_model.unwrap_or(&model),
                );
            }
            _ => {
                return Err(p.err(
                    "unsupported bsdf type (btfpt implements diffuse, conductor, roughconductor, dielectric, \
                     thindielectric, twosided, btf)",
                ));
            }
        };
        p.finish()?;
        Ok(b)
    }

    /// A reflectance-like parameter: constant (rgb/float/spectrum) or nested/referenced bitmap.
    fn texture_param(&mut self, p: &Props<'a, 'x>, name: &str, default: Vec3) -> Result<Texture> {
        if let Some(c) = p.child_named(name) {
            if c.tag() != "texture" {
                return Err(self.x.err(
                    c.at,
                    format!(
                        "\"{name}\" must be a <texture> or a colour, not a <{}>",
                        c.tag()
                    ),
                ));
            }
            return self.texture(c.node);
        }
        Ok(Texture::Constant(p.color(name, default)?))
    }

    fn texture(&mut self, node: N<'a>) -> Result<Texture> {
        if let Some(t) = self.tex_memo.get(&node.id()) {
            return Ok(t.clone());
        }
        let x = self.x;
        let p = Props::parse(x, node)?;
        if p.ty != "bitmap" {
            return Err(p.err("unsupported texture type (btfpt implements only \"bitmap\")"));
        }
        let file = p.string_req("filename")?;
        let filter = p.string("filter_type", "bilinear")?;
        if filter != "bilinear" {
            return Err(p.err(format!(
                "filter_type \"{filter}\" is not supported (only bilinear)"
            )));
        }
        let wrap = p.string("wrap_mode", "repeat")?;
        if wrap != "repeat" {
            return Err(p.err(format!(
                "wrap_mode \"{wrap}\" is not supported (only repeat)"
            )));
        }
        let raw = p.bool("raw", false)?;
        if let Some(m) = p.transform_opt("to_uv")?
            && m != Mat4::IDENTITY
        {
            return Err(p.err("a non-identity \"to_uv\" transform is not supported"));
        }
        p.finish()?;
        let path = x.resolve(&file);
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        if raw && ext != "exr" {
            return Err(p.err("raw=\"true\" (no sRGB decoding of 8-bit images) is not supported"));
        }
        let img = crate::io::read_image(&path).map_err(|e| p.err(e.to_string()))?;
        check_finite(&img, &path).map_err(|m| p.err(m))?;
        let t = Texture::Bitmap(Arc::new(img));
        self.tex_memo.insert(node.id(), t.clone());
        Ok(t)
    }

    fn emitter(&mut self, p: &Props<'a, 'x>) -> Result<Emitter> {
        let x = self.x;
        Ok(match p.ty.as_str() {
            "point" => {
                let intensity = p.color("intensity", Vec3::ONE)?;
                let pos = p.vec3_opt("position")?;
                let xf = p.transform_opt("to_world")?;
                let position = match (pos, xf) {
                    (Some(_), Some(_)) => {
                        return Err(
                            p.err("only one of \"position\" and \"to_world\" can be specified")
                        );
                    }
                    (Some(v), None) => v,
                    (None, Some(m)) => xf_point(&m, Vec3::ZERO),
                    (None, None) => Vec3::ZERO,
                };
                if !position.is_finite() {
                    return Err(p.err("non-finite position"));
                }
                Emitter::Point {
                    position,
                    intensity,
                }
            }
            "spot" => {
                let intensity = p.color("intensity", Vec3::ONE)?;
                let cutoff_angle = p.float("cutoff_angle", 20.0)?;
                let mut beam_width = p.float("beam_width", cutoff_angle * 0.75)?;
                if beam_width > cutoff_angle {
                    beam_width = cutoff_angle; // Mitsuba clamps (with a warning)
                }
                if !(cutoff_angle > 0.0 && cutoff_angle <= 180.0) {
                    return Err(p.err("cutoff_angle must be in (0, 180] degrees"));
                }
                let to_world = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
                Emitter::Spot {
                    to_world,
                    intensity,
                    cutoff_angle,
                    beam_width,
                }
            }
            "directional" => {
                let irradiance = p.color("irradiance", Vec3::ONE)?;
                let d = p.vec3_opt("direction")?;
                let xf = p.transform_opt("to_world")?;
                let direction = match (d, xf) {
                    (Some(_), Some(_)) => {
                        return Err(
                            p.err("only one of \"direction\" and \"to_world\" can be specified")
                        );
                    }
                    (Some(v), None) => v.normalize(),
                    (None, Some(m)) => m.transform_vector3(Vec3::Z).normalize(),
                    (None, None) => Vec3::Z,
                };
                if !direction.is_finite() {
                    return Err(p.err("the direction must be a non-zero finite vector"));
                }
                Emitter::Directional {
                    direction,
                    irradiance,
                }
            }
            "constant" => Emitter::Constant {
                radiance: p.color("radiance", Vec3::ONE)?,
            },
            "envmap" => {
                let file = p.string_req("filename")?;
                let scale = p.float("scale", 1.0)?;
                let to_world = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
                let path = x.resolve(&file);
                let image = crate::io::read_image(&path).map_err(|e| p.err(e.to_string()))?;
                check_finite(&image, &path).map_err(|m| p.err(m))?;
                Emitter::EnvMap {
                    image: Arc::new(image),
                    to_world,
                    scale,
                    filename: path,
                }
            }
            _ => {
                return Err(p.err(
                    "unsupported emitter type (btfpt implements area, point, spot, directional, constant, envmap)",
                ));
            }
        })
    }
}

/// Mitsuba's `parse_fov`: the horizontal field of view in degrees from `fov` + `fov_axis`
/// (x, y, diagonal, smaller, larger) or a 35 mm `focal_length` (default "50mm").
fn parse_fov(p: &Props, aspect: f64) -> Result<f32> {
    if p.has("fov") && p.has("focal_length") {
        return Err(
            p.err("specify either a focal length (\"focal_length\") or a field of view (\"fov\")")
        );
    }
    let (fov, axis) = if p.has("fov") {
        let fov = p.float("fov", 0.0)? as f64;
        let mut axis = p.string("fov_axis", "x")?.to_ascii_lowercase();
        if axis == "smaller" {
            axis = if aspect > 1.0 { "y".into() } else { "x".into() };
        } else if axis == "larger" {
            axis = if aspect > 1.0 { "x".into() } else { "y".into() };
        }
        (fov, axis)
    } else {
        let f = p.string("focal_length", "50mm")?;
        let v: f64 = f.trim_end_matches("mm").trim().parse().map_err(|_| {
            p.err(format!(
                "could not parse the focal length \"{f}\" (expected <x>mm)"
            ))
        })?;
        let fov = 2.0
            * ((36.0f64 * 36.0 + 24.0 * 24.0).sqrt() / (2.0 * v))
                .atan()
                .to_degrees();
        (fov, "diagonal".to_string())
    };
    let t = (0.5 * fov.to_radians()).tan();
    let result = match axis.as_str() {
        "x" => fov,
        "y" => (2.0 * (t * aspect).atan()).to_degrees(),
        "diagonal" => {
            let width = 2.0 * t / (1.0 + 1.0 / (aspect * aspect)).sqrt();
            (2.0 * (width * 0.5).atan()).to_degrees()
        }
        _ => {
            return Err(p.err("the \"fov_axis\" parameter must be one of \"smaller\", \"larger\", \"diagonal\", \"x\", \"y\""));
        }
    };
    if !(result > 0.0 && result < 180.0) {
        return Err(p.err(format!(
            "the horizontal field of view must be in (0, 180) degrees, got {result}"
        )));
    }
    Ok(result as f32)
}

/// Mitsuba's named IOR table (`ior.h`).
const IOR_TABLE: &[(&str, f32)] = &[
    ("vacuum", 1.0),
    ("helium", 1.00004),
    ("hydrogen", 1.00013),
    ("air", 1.00028),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

/// An IOR given as a float or one of Mitsuba's named materials.
fn ior(p: &Props, name: &str, default: &str) -> Result<f32> {
    let lookup = |s: &str| {
        let l = s.to_ascii_lowercase();
        IOR_TABLE
            .iter()
            .find(|(n, _)| *n == l)
            .map(|(_, v)| *v)
            .ok_or_else(|| p.err(format!("unknown IOR material \"{s}\" for \"{name}\"")))
    };
    match p.float_or_string(name)? {
        None => lookup(default),
        Some(Ok(v)) => Ok(v),
        Some(Err(s)) => lookup(&s),
    }
}

/// Complex IOR of a conductor: `material="none"` (Mitsuba's default, a perfect mirror: eta 0,
/// k 1) with optional explicit `eta`/`k`. Named metals need Mitsuba's spectral data: error.
fn conductor_ior(p: &Props) -> Result<(Spectrum, Spectrum)> {
    let material = p.string("material", "none")?;
    if material != "none" {
        if p.has("eta") || p.has("k") {
            return Err(p.err("should specify either (eta, k) or material, not both"));
        }
        return Err(p.err(format!(
            "named conductor material \"{material}\" is not supported (btfpt cannot reproduce Mitsuba's \
             spectral-to-RGB values): give <rgb name=\"eta\"> and <rgb name=\"k\"> instead"
        )));
    }
    Ok((p.color("eta", Vec3::ZERO)?, p.color("k", Vec3::ONE)?))
}

/// Rejects images holding NaN or infinite values (they would poison every sample that sees them).
fn check_finite(img: &crate::io::RgbImage, path: &Path) -> std::result::Result<(), String> {
    match img.data.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => {
            let px = i / 3;
            Err(format!(
                "{}: pixel ({}, {}) is NaN or infinite; images must hold finite values",
                path.display(),
                px % img.width.max(1),
                px / img.width.max(1)
            ))
        }
    }
}
