//! `<emitter>`: the table from plugin name to the constructor that reads the emitter's
//! properties ([`Emitter`]'s, in `light/emitter.rs`; area emitters are attached by `shape`),
//! with the builder for the textures an emitter nests.

use super::bsdf::Element;
use super::properties::Props;
use super::{Builder, plugin_constructor};
use crate::Result;
use crate::bsdf::BsdfProperties;
use crate::light::Emitter;

/// An emitter plugin's constructor: reads the element's properties, builds what it nests.
type EmitterConstructor = fn(&mut dyn BsdfProperties) -> Result<Emitter>;

/// Every `<emitter>` plugin btfpt implements besides `area`, by Mitsuba plugin name.
const EMITTER_PLUGINS: &[(&str, EmitterConstructor)] = &[
    ("point", |p| Emitter::point_from_props(p)),
    ("spot", Emitter::spot_from_props),
    ("projector", Emitter::projector_from_props),
    ("directional", |p| Emitter::directional_from_props(p)),
    ("constant", |p| Emitter::constant_from_props(p)),
    ("envmap", |p| Emitter::envmap_from_props(p)),
];

impl<'a, 'x> Builder<'a, 'x> {
    /// The emitter an `<emitter>` element describes, its properties checked for unread ones.
    pub(super) fn emitter(&mut self, p: Props<'a, 'x>) -> Result<Emitter> {
        let construct = *plugin_constructor(EMITTER_PLUGINS, &p, "emitter type", &["area"])?;
        let mut element = Element { b: self, p };
        let e = construct(&mut element)?;
        element.p.finish()?;
        Ok(e)
    }
}
