//! Mitsuba 3 XML scenes (the subset btfpt renders) → [`Scene`]: the `load` entry and the top
//! level of the scene builder. Each plugin kind has a file (`sensor`, `shape`, `bsdf`,
//! `texture`, `emitter`) with its table from plugin name to the constructor in the file of the
//! concept it builds, which reads the element's [`Props`]; `document` and `properties` are the
//! XML side (substitution, ids, typed properties, the report-unused check) and `transform`
//! parses `<transform>`. Model: pbrt-v4's parser.cpp + paramdict.h, Mitsuba 3's xml.cpp +
//! properties.h.
//!
//! Semantics follow Mitsuba 3's `xml.cpp` and plugins: `<default>`/`$name` substitution with CLI
//! defines winning, ids unique, `<ref>` to any object with an id, unknown plugins, elements or
//! unqueried properties are errors naming the file and line.

mod bsdf;
mod document;
mod emitter;
mod properties;
mod sensor;
mod shape;
mod texture;
mod transform;

use crate::bsdf::{Bsdf, BsdfFlags, Texture};
use crate::model::BtfModel;
use crate::scene::channels::ImageChannels;
use crate::scene::measured_material::BtfUse;
use crate::scene::{Camera, Emitter, IntegratorSettings, LoadOptions, Scene};
use crate::{Error, Result};
use document::{Key, Loaded, XmlDoc};
use properties::Props;
use roxmltree::Node;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

/// Loads a Mitsuba 3 XML scene; `options.defines` override `<default>` values (CLI `-D
/// name=value`), `options.btf_model` replaces every BTF's `model`.
pub fn load(path: &Path, options: &LoadOptions) -> Result<Scene> {
    // The root file, then each included file in the order the includes occur. roxmltree
    // documents borrow their text, so the documents are parsed again whenever a new include
    // is found (scenes have a handful of includes; parsing is cheap next to loading meshes).
    let mut texts: Vec<(PathBuf, String)> = vec![(path.to_path_buf(), read_text(path)?)];
    loop {
        let need = {
            let mut docs = Vec::with_capacity(texts.len());
            for (file, text) in &texts {
                docs.push(parse_xml(file, text)?);
            }
            let files: Vec<PathBuf> = texts.iter().map(|t| t.0.clone()).collect();
            match XmlDoc::load(&files, docs.iter().collect(), &options.defines)? {
                Loaded::Need(p) => p,
                Loaded::Done(x) => {
                    let mut b = Builder {
                        x: &x,
                        btf_model: options.btf_model,
                        synth_cache: options.synth_cache.clone(),
                        btf_uses: Vec::new(),
                        bsdfs: Vec::new(),
                        bsdf_memo: HashMap::new(),
                        tex_memo: HashMap::new(),
                        busy: HashSet::new(),
                        default_bsdf: [None, None],
                        meshes: Vec::new(),
                        emitters: Vec::new(),
                        emission_textures: Vec::new(),
                        area_emitters_used: HashSet::new(),
                        groups: HashMap::new(),
                        group_spheres: Vec::new(),
                    };
                    return b.scene(docs[0].root_element());
                }
            }
        };
        if texts.len() > 4096 {
            return Err(Error::Invalid(format!(
                "{}: more than 4096 <include>d files",
                path.display()
            )));
        }
        let text = read_text(&need)?;
        texts.push((need, text));
    }
}

fn read_text(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).map_err(|e| Error::io(path, e))
}

fn parse_xml<'t>(path: &Path, text: &'t str) -> Result<roxmltree::Document<'t>> {
    let opts = roxmltree::ParsingOptions {
        allow_dtd: true,
        ..Default::default()
    };
    roxmltree::Document::parse_with_options(text, opts).map_err(|e| Error::Scene {
        file: path.to_path_buf(),
        line: e.pos().row,
        msg: format!("malformed XML: {e}"),
    })
}

pub(super) struct Builder<'a, 'x> {
    x: &'x XmlDoc<'a>,
    /// [`LoadOptions::btf_model`]: replaces every BTF's `model` property.
    btf_model: Option<BtfModel>,
    /// [`LoadOptions::synth_cache`]: where generated `synth:` materials are kept.
    synth_cache: Option<PathBuf>,
    /// The file and model of every `<bsdf type="btf">` built, in order.
    btf_uses: Vec<BtfUse>,
    bsdfs: Vec<Bsdf>,
    bsdf_memo: HashMap<Key, u32>,
    tex_memo: HashMap<Key, Texture>,
    /// Objects being built (reference-cycle detection).
    busy: HashSet<Key>,
    /// The default BSDFs once built: `[plain shape, area emitter]` (see `default_bsdf`).
    default_bsdf: [Option<u32>; 2],
    meshes: Vec<crate::geometry::Mesh>,
    emitters: Vec<Emitter>,
    /// Radiance textures of area emitters, by mesh index (see [`Scene::emission_textures`]).
    emission_textures: Vec<(u32, crate::bsdf::Texture)>,
    /// Area `<emitter>` elements a shape has taken (nested or by `<ref>`).
    area_emitters_used: HashSet<Key>,
    /// Each `shapegroup` built, by element: its group index.
    groups: HashMap<Key, u32>,
    /// The analytic spheres of each group (shape as read, BSDF, name): an instance places a
    /// world-space copy of each.
    group_spheres: Vec<Vec<(crate::scene::shapes::Shape, u32, String)>>,
}

pub(super) type N<'a> = Node<'a, 'a>;

/// A plugin's constructor that reads only its own properties (nested objects are passed in or
/// built on request through a wider trait, as `BsdfProperties`).
type Constructor<T> = fn(&dyn crate::plugin::Properties) -> Result<T>;

/// The constructor `table` lists for the element's plugin name, else an error naming `what`
/// (e.g. "bsdf type") and every name btfpt implements (`also` first: those built elsewhere).
fn plugin_constructor<'t, C>(
    table: &'t [(&str, C)],
    p: &Props,
    what: &str,
    also: &[&str],
) -> Result<&'t C> {
    match table.iter().find(|(name, _)| *name == p.ty) {
        Some((_, construct)) => Ok(construct),
        None => {
            let names: Vec<&str> = also
                .iter()
                .copied()
                .chain(table.iter().map(|(name, _)| *name))
                .collect();
            Err(p.err(format!(
                "unsupported {what} (btfpt implements {})",
                names.join(", ")
            )))
        }
    }
}
impl<'a, 'x> Builder<'a, 'x> {
    /// Refuses a `ptracer` (at `at`) on a scene where Mitsuba's particle tracer and btfpt's path
    /// tracer, which renders it, would not converge to the same image: a surface with a delta
    /// lobe (the particle tracer cannot connect it to the camera), an environment emitter, a
    /// camera other than a perspective or thin lens one.
    fn check_ptracer(&self, at: N<'a>, camera: &Camera) -> Result<()> {
        let why = |what: String| {
            self.x.err(
                at,
                format!(
                    "integrator \"ptracer\": btfpt renders particle-tracer scenes with its path \
                     tracer, which gives Mitsuba's particle-tracer image only without specular \
                     surfaces, environment emitters and orthographic cameras; {what}"
                ),
            )
        };
        let delta = |b: u32| self.bsdfs[b as usize].flags().has(BsdfFlags::DELTA);
        let spheres = self.group_spheres.iter().flatten();
        if let Some(name) = self
            .meshes
            .iter()
            .map(|m| (m.bsdf, &m.name))
            .chain(spheres.map(|(_, b, name)| (*b, name)))
            .find_map(|(b, name)| delta(b).then_some(name))
        {
            return Err(why(format!("shape \"{name}\" has a specular (delta) BSDF")));
        }
        if self
            .emitters
            .iter()
            .any(|e| matches!(e, Emitter::Constant { .. } | Emitter::EnvMap { .. }))
        {
            return Err(why("the scene has an environment emitter".into()));
        }
        if camera.projection == crate::scene::Projection::Orthographic {
            return Err(why("the camera is orthographic".into()));
        }
        Ok(())
    }

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
        match version
            .split('.')
            .next()
            .and_then(|v| v.trim().parse::<u32>().ok())
        {
            // 0.x/1.x files are upgraded as Mitsuba 3 does (see document.rs).
            Some(0..=3) => {}
            _ => {
                return Err(x.err(
                    root,
                    format!("unsupported scene version \"{version}\" (btfpt reads Mitsuba scenes up to version 3.x)"),
                ));
            }
        }
        let mut camera: Option<(Camera, crate::scene::sensor::Sampler)> = None;
        let mut integrator: Option<(IntegratorSettings, ImageChannels)> = None;
        let mut ptracer_at = None;
        if let Some(t) = root
            .children()
            .find(|c| c.is_text() && !c.text().unwrap_or("").trim().is_empty())
        {
            return Err(x.err(t, "unexpected text content in <scene>"));
        }
        // Top-level area emitters with an id, built by the shapes that reference them (Mitsuba
        // resolves such references in any order); each must be referenced by some shape.
        let mut area_emitters = Vec::new();
        for ch in x.children(root) {
            match ch.tag_name().name() {
                "integrator" => {
                    if integrator.is_some() {
                        return Err(x.err(ch, "more than one <integrator>"));
                    }
                    integrator = Some(self.integrator(ch)?);
                    let nested = x
                        .children(ch)
                        .into_iter()
                        .filter(|c| c.tag_name().name() == "integrator");
                    for node in std::iter::once(ch).chain(nested) {
                        if Props::parse(x, node)?.ty == "ptracer" {
                            ptracer_at = Some(node);
                        }
                    }
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
                // Built where a <ref> names them (Mitsuba instantiates them at the top level
                // too, but an unreferenced sampler, film or filter changes nothing).
                "sampler" | "film" | "rfilter" if x.attr(ch, "id").is_some() => {}
                "emitter" => {
                    let p = Props::parse(x, ch)?;
                    if p.ty == "area" {
                        if x.attr(ch, "id").is_none() {
                            return Err(x.err(
                                ch,
                                "an area emitter must be nested inside a <shape> or referenced by one",
                            ));
                        }
                        area_emitters.push(ch);
                        continue;
                    }
                    let e = self.emitter(p)?;
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
        if let Some(e) = area_emitters
            .iter()
            .find(|e| !self.area_emitters_used.contains(&x.key(**e)))
        {
            return Err(x.err(
                *e,
                "an area emitter must be nested inside a <shape> or referenced by one (no shape \
                 references this one)",
            ));
        }
        let (camera, sampler) = camera.ok_or_else(|| x.err(root, "the scene has no <sensor>"))?;
        if let Some(at) = ptracer_at {
            self.check_ptracer(at, &camera)?;
        }
        let (mut integrator, channels) = integrator.unwrap_or_default();
        integrator.sampler = sampler.kind;
        Ok(Scene {
            source: x.file.clone(),
            camera,
            integrator,
            channels,
            spp: sampler.spp,
            meshes: std::mem::take(&mut self.meshes),
            bsdfs: std::mem::take(&mut self.bsdfs),
            emitters: std::mem::take(&mut self.emitters),
            emission_textures: std::mem::take(&mut self.emission_textures),
            inputs: {
                let mut inputs = x.inputs();
                for u in &self.btf_uses {
                    if !inputs.contains(&u.file) {
                        inputs.push(u.file.clone());
                    }
                }
                inputs
            },
            btf_uses: std::mem::take(&mut self.btf_uses),
        })
    }
}
