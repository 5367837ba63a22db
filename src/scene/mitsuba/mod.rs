//! Mitsuba 3 XML scenes (the subset btfpt renders) → [`Scene`]: the `load` entry and the top
//! level of the scene builder. The builder's methods live with the plugin kind they build
//! (`sensor`, `shape`, `bsdf`, `emitter`); `document` and `properties` are the XML side
//! (substitution, ids, typed properties, the report-unused check) and `transform` parses
//! `<transform>`. Model: pbrt-v4's parser.cpp + paramdict.h, Mitsuba 3's xml.cpp + properties.h.
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
mod transform;

use crate::bsdf::{Bsdf, Texture};
use crate::model::BtfModel;
use crate::scene::btf_bsdf::BtfUse;
use crate::scene::{Camera, Emitter, IntegratorSettings, LoadOptions, Scene};
use crate::{Error, Result};
use document::XmlDoc;
use properties::Props;
use roxmltree::{Node, NodeId};
use std::collections::{HashMap, HashSet};
use std::path::Path;

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
        btf_model: options.btf_model,
        btf_uses: Vec::new(),
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

pub(super) struct Builder<'a, 'x> {
    x: &'x XmlDoc<'a>,
    /// [`LoadOptions::btf_model`]: replaces every BTF's `model` property.
    btf_model: Option<BtfModel>,
    /// The file and model of every `<bsdf type="btf">` built, in order.
    btf_uses: Vec<BtfUse>,
    bsdfs: Vec<Bsdf>,
    bsdf_memo: HashMap<NodeId, u32>,
    tex_memo: HashMap<NodeId, Texture>,
    /// Objects being built (reference-cycle detection).
    busy: HashSet<NodeId>,
    default_bsdf: Option<u32>,
    meshes: Vec<crate::geometry::Mesh>,
    emitters: Vec<Emitter>,
}

pub(super) type N<'a> = Node<'a, 'a>;
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
            btf_uses: std::mem::take(&mut self.btf_uses),
        })
    }
}

/// Rejects images holding NaN or infinite values (they would poison every sample that sees them).
pub(super) fn check_finite(
    img: &crate::io::RgbImage,
    path: &Path,
) -> std::result::Result<(), String> {
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
