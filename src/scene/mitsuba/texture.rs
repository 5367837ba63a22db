//! `<texture>`: the table from plugin name to the constructor in the texture's own file
//! (`crate::bsdf::texture`: `bitmap`, `checkerboard`, `rawconstant`, `mesh_attribute`), nested in a BSDF parameter or
//! referenced by id, built once per element.

use super::bsdf::Element;
use super::properties::Props;
use super::{Builder, N, plugin_constructor};
use crate::Result;
use crate::bsdf::texture::{
    BitmapTexture, Checkerboard, MeshAttributeTexture, raw_constant_from_props,
};
use crate::bsdf::{BsdfProperties, Texture};

/// A texture plugin's constructor: reads the element's properties, builds what it nests.
type TextureConstructor = fn(&mut dyn BsdfProperties) -> Result<Texture>;

/// Every `<texture>` plugin btfpt implements, by Mitsuba plugin name.
const TEXTURE_PLUGINS: &[(&str, TextureConstructor)] = &[
    ("bitmap", BitmapTexture::from_props),
    ("checkerboard", Checkerboard::from_props),
    ("rawconstant", raw_constant_from_props),
    ("mesh_attribute", MeshAttributeTexture::from_props),
];

impl<'a, 'x> Builder<'a, 'x> {
    /// The texture an element describes (built once per element).
    pub(super) fn texture(&mut self, node: N<'a>) -> Result<Texture> {
        let x = self.x;
        let key = x.key(node);
        if let Some(t) = self.tex_memo.get(&key) {
            return Ok(t.clone());
        }
        if !self.busy.insert(key) {
            return Err(x.err(node, "cyclic <ref> between textures"));
        }
        let r = self.build_texture(node);
        self.busy.remove(&key);
        let t = r?;
        self.tex_memo.insert(key, t.clone());
        Ok(t)
    }

    fn build_texture(&mut self, node: N<'a>) -> Result<Texture> {
        let x = self.x;
        if node.tag_name().name() != "texture" {
            return Err(x.err(
                node,
                format!("expected a <texture>, found <{}>", node.tag_name().name()),
            ));
        }
        let p = Props::parse(x, node)?;
        let construct = *plugin_constructor(TEXTURE_PLUGINS, &p, "texture type", &[])?;
        let mut element = Element { b: self, p };
        let texture = construct(&mut element)?;
        element.p.finish()?;
        Ok(texture)
    }
}
