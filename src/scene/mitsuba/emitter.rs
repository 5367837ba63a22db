//! `<emitter>`: the table from plugin name to the constructor that reads the emitter's
//! properties ([`Emitter`]'s, in `light/emitter.rs`; area emitters are attached by `shape`).

use super::properties::Props;
use super::{Constructor, plugin_constructor};
use crate::Result;
use crate::light::Emitter;

/// Every `<emitter>` plugin btfpt implements besides `area`, by Mitsuba plugin name.
const EMITTER_PLUGINS: &[(&str, Constructor<Emitter>)] = &[
    ("point", Emitter::point_from_props),
    ("spot", Emitter::spot_from_props),
    ("directional", Emitter::directional_from_props),
    ("constant", Emitter::constant_from_props),
    ("envmap", Emitter::envmap_from_props),
];

/// The emitter an `<emitter>` element describes (its properties not yet checked for unread ones).
pub(super) fn emitter(p: &Props) -> Result<Emitter> {
    plugin_constructor(EMITTER_PLUGINS, p, "emitter type", &["area"])?(p)
}
