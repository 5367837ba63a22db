//! `<bsdf>`: the table from plugin name to the constructor in the BSDF's own file
//! (`crate::bsdf::Diffuse::from_props`, ...), which reads the element's properties through
//! [`BsdfProperties`]; nested BSDFs, textures (`texture.rs` builds the `<texture>`s) and
//! measured materials (`scene::measured_material`) are built here when a constructor asks.

use super::properties::Props;
use super::{Builder, N, plugin_constructor};
use crate::bsdf::{
    BlendBsdf, Bsdf, BsdfProperties, BumpMap, Conductor, Dielectric, Diffuse, Mask, NormalMap,
    PPlastic, Plastic, Polarizer, Principled, PrincipledThin, RoughConductor, RoughDielectric,
    RoughPlastic, Texture, ThinDielectric, TwoSided,
};
use crate::math::Spectrum;
use crate::math::Vec3;
use crate::math::cie1931::SpectrumUse;
use crate::model::BtfModel;
use crate::plugin::{Properties, Value};
use crate::scene::measured_material::build_btf;
use crate::{Error, Result};

impl<'a, 'x> Builder<'a, 'x> {
    /// The BSDF of a shape that names none, as Mitsuba 3 creates it: diffuse with reflectance
    /// 0.5, or 0 on a shape carrying an area emitter (built once each).
    pub(super) fn default_bsdf(&mut self, emitter: bool) -> u32 {
        let slot = usize::from(emitter);
        if let Some(i) = self.default_bsdf[slot] {
            return i;
        }
        self.bsdfs.push(Bsdf::Diffuse(Diffuse {
            reflectance: Texture::Constant(Spectrum::splat(if emitter { 0.0 } else { 0.5 })),
        }));
        let i = (self.bsdfs.len() - 1) as u32;
        self.default_bsdf[slot] = Some(i);
        i
    }

    /// The index in `Scene::bsdfs` of a `<bsdf>` element (built once per element).
    pub(super) fn bsdf_index(&mut self, node: N<'a>) -> Result<u32> {
        if let Some(&i) = self.bsdf_memo.get(&self.x.key(node)) {
            return Ok(i);
        }
        let b = self.build_bsdf(node)?;
        self.bsdfs.push(b);
        let i = (self.bsdfs.len() - 1) as u32;
        self.bsdf_memo.insert(self.x.key(node), i);
        Ok(i)
    }

    pub(super) fn build_bsdf(&mut self, node: N<'a>) -> Result<Bsdf> {
        let x = self.x;
        if node.tag_name().name() != "bsdf" {
            return Err(x.err(
                node,
                format!("expected a <bsdf>, found <{}>", node.tag_name().name()),
            ));
        }
        if let Some(&i) = self.bsdf_memo.get(&self.x.key(node)) {
            return Ok(self.bsdfs[i as usize].clone());
        }
        if !self.busy.insert(x.key(node)) {
            return Err(x.err(node, "cyclic <ref> between bsdfs"));
        }
        let r = self.build_bsdf_inner(node);
        self.busy.remove(&x.key(node));
        r
    }

    pub(super) fn build_bsdf_inner(&mut self, node: N<'a>) -> Result<Bsdf> {
        let p = Props::parse(self.x, node)?;
        let construct = *plugin_constructor(BSDF_PLUGINS, &p, "bsdf type", &[])?;
        let mut element = Element { b: self, p };
        let bsdf = construct(&mut element)?;
        element.p.finish()?;
        Ok(bsdf)
    }

    /// A texture-or-colour parameter used as `usage`: a nested/referenced `<texture>`, else a
    /// constant (rgb/float/spectrum; what a `<spectrum>` list converts to depends on the usage:
    /// Mitsuba's unbounded textures, eta/k/alpha, are not clipped at 1), else `default`.
    pub(super) fn texture_param_as(
        &mut self,
        p: &Props<'a, 'x>,
        name: &str,
        default: Vec3,
        usage: SpectrumUse,
    ) -> Result<Texture> {
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
            let t = self.texture(c.node)?;
            let slot = (p.ty.as_str(), name);
            if matches!(t, Texture::MeshAttribute(_)) && !MESH_ATTRIBUTE_SLOTS.contains(&slot) {
                return Err(self.x.err(c.at, MESH_ATTRIBUTE_USE));
            }
            return Ok(t);
        }
        Ok(Texture::Constant(
            p.color_opt_as(name, usage)?.unwrap_or(default),
        ))
    }
}

/// Where a `mesh_attribute` texture may stand, as (plugin, parameter): the slots whose BSDF
/// looks its texture up through the hit (the attribute needs the hit's triangle, not only its
/// uv) and that `shape.rs`'s `bound_copy` binds to each shape's mesh.
pub(super) const MESH_ATTRIBUTE_SLOTS: [(&str, &str); 2] =
    [("diffuse", "reflectance"), ("blendbsdf", "weight")];

/// The error for a `mesh_attribute` anywhere else ([`MESH_ATTRIBUTE_SLOTS`] in words).
const MESH_ATTRIBUTE_USE: &str = "mesh_attribute textures are supported as a diffuse BSDF's reflectance and a blendbsdf's weight";

/// A BSDF plugin's constructor: reads the element's properties, builds what it nests.
type BsdfConstructor = fn(&mut dyn BsdfProperties) -> Result<Bsdf>;

/// Every `<bsdf>` plugin btfpt implements, by Mitsuba plugin name.
const BSDF_PLUGINS: &[(&str, BsdfConstructor)] = &[
    ("diffuse", |p| Diffuse::from_props(p).map(Bsdf::from)),
    ("conductor", |p| Conductor::from_props(p).map(Bsdf::from)),
    ("roughconductor", |p| {
        RoughConductor::from_props(p).map(Bsdf::from)
    }),
    ("dielectric", |p| Dielectric::from_props(p).map(Bsdf::from)),
    ("thindielectric", |p| {
        ThinDielectric::from_props(p).map(Bsdf::from)
    }),
    ("roughdielectric", |p| {
        RoughDielectric::from_props(p).map(Bsdf::from)
    }),
    ("plastic", |p| Plastic::from_props(p).map(Bsdf::from)),
    ("roughplastic", |p| {
        RoughPlastic::from_props(p).map(Bsdf::from)
    }),
    ("pplastic", |p| PPlastic::from_props(p).map(Bsdf::from)),
    ("polarizer", |p| Polarizer::from_props(p).map(Bsdf::from)),
    ("twosided", |p| TwoSided::from_props(p).map(Bsdf::from)),
    ("blendbsdf", |p| BlendBsdf::from_props(p).map(Bsdf::from)),
    ("mixturebsdf", |p| {
        BlendBsdf::mixture_from_props(p).map(Bsdf::from)
    }),
    ("mask", |p| Mask::from_props(p).map(Bsdf::from)),
    ("normalmap", |p| NormalMap::from_props(p).map(Bsdf::from)),
    ("bumpmap", |p| BumpMap::from_props(p).map(Bsdf::from)),
    ("principled", |p| Principled::from_props(p).map(Bsdf::from)),
    ("principledthin", |p| {
        PrincipledThin::from_props(p).map(Bsdf::from)
    }),
    ("btf", crate::bsdf::btf::from_props),
];

/// A `<bsdf>` or `<texture>` element as its constructor reads it: the element's properties,
/// and the builder that builds what it nests (memoised, reference cycles refused).
pub(super) struct Element<'b, 'a, 'x> {
    pub(super) b: &'b mut Builder<'a, 'x>,
    pub(super) p: Props<'a, 'x>,
}

impl<'a> Element<'_, 'a, '_> {
    /// The `i`-th nested object tagged `tag`.
    fn nested(&self, tag: &str, i: usize) -> Result<N<'a>> {
        let kids = self.p.children_tagged(tag);
        let c = kids
            .get(i)
            .ok_or_else(|| self.p.err(format!("needs a nested {tag} number {}", i + 1)))?;
        Ok(c.node)
    }
}

impl Properties for Element<'_, '_, '_> {
    fn plugin_type(&self) -> &str {
        self.p.plugin_type()
    }

    fn err(&self, msg: &str) -> Error {
        self.p.err(msg)
    }

    fn err_at(&self, name: &str, msg: &str) -> Error {
        self.p.err_at(name, msg)
    }

    fn has(&self, name: &str) -> bool {
        self.p.has(name)
    }

    fn value(&self, name: &str) -> Option<&Value> {
        self.p.value(name)
    }

    fn nested_tag(&self, name: &str) -> Option<&str> {
        self.p.nested_tag(name)
    }

    fn resolve(&self, filename: &str) -> std::path::PathBuf {
        self.p.resolve(filename)
    }

    fn mitsuba_0_6(&self) -> bool {
        self.p.mitsuba_0_6()
    }
}

impl BsdfProperties for Element<'_, '_, '_> {
    fn texture_as(&mut self, name: &str, default: Vec3, usage: SpectrumUse) -> Result<Texture> {
        self.b.texture_param_as(&self.p, name, default, usage)
    }

    fn nested_bsdf_count(&mut self) -> usize {
        self.p.children_tagged("bsdf").len()
    }

    fn nested_bsdf(&mut self, i: usize) -> Result<Bsdf> {
        let node = self.nested("bsdf", i)?;
        self.b.build_bsdf(node)
    }

    fn nested_texture_count(&mut self) -> usize {
        self.p.children_tagged("texture").len()
    }

    fn nested_texture(&mut self, i: usize) -> Result<Texture> {
        let node = self.nested("texture", i)?;
        let t = self.b.texture(node)?;
        if matches!(t, Texture::MeshAttribute(_)) {
            return Err(self.b.x.err(node, MESH_ATTRIBUTE_USE));
        }
        Ok(t)
    }

    fn measured(&mut self, filename: &str, uv_scale: f32, model: Option<BtfModel>) -> Result<Bsdf> {
        let x = self.b.x;
        let (bsdf, used) = build_btf(
            x.file_of(self.p.node),
            x.line(self.p.node),
            filename,
            &|f| x.resolve(f),
            uv_scale,
            self.b.btf_model.or(model),
            self.b.synth_cache.as_deref(),
        )?;
        self.b.btf_uses.push(used);
        Ok(bsdf)
    }

    fn finish(&self) -> Result<()> {
        self.p.finish()
    }
}
