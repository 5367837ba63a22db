//! What a BSDF constructor reads: its [`Properties`] plus the objects it nests (textures,
//! BSDFs, a measured material), built by the scene format on demand (Mitsuba 3's
//! `props.texture(...)` / `props.objects()`). Each BSDF's file has the constructor that reads
//! its own parameters (`Diffuse::from_props`, ...); a scene format maps plugin names to them.

use super::{Bsdf, Texture};
use crate::Result;
use crate::math::Vec3;
use crate::math::cie1931::SpectrumUse;
use crate::model::BtfModel;
use crate::plugin::Properties;

/// The properties of a BSDF (or texture) plugin and the builder of what it nests.
pub trait BsdfProperties: Properties {
    /// A texture-or-colour parameter read as `usage`: the nested (or referenced) texture called
    /// `name`, else a constant colour, else `default` (usage says what a spectrum converts to:
    /// Mitsuba's unbounded textures, eta/k/alpha, are not clipped at 1).
    fn texture_as(&mut self, name: &str, default: Vec3, usage: SpectrumUse) -> Result<Texture>;

    /// [`BsdfProperties::texture_as`] for a reflectance.
    fn texture(&mut self, name: &str, default: Vec3) -> Result<Texture> {
        self.texture_as(name, default, SpectrumUse::Reflectance)
    }

    /// The number of nested BSDFs (marking them read).
    fn nested_bsdf_count(&mut self) -> usize;

    /// The `i`-th nested BSDF, built.
    fn nested_bsdf(&mut self, i: usize) -> Result<Bsdf>;

    /// The number of nested textures whatever their names (marking them read).
    fn nested_texture_count(&mut self) -> usize;

    /// The `i`-th nested texture, built.
    fn nested_texture(&mut self, i: usize) -> Result<Texture>;

    /// The measured material `filename` (a file or a `synth:` source, as the scene format
    /// resolves it) as a BSDF, raw or fitted: `model` unless the loader overrides it.
    fn measured(&mut self, filename: &str, uv_scale: f32, model: Option<BtfModel>) -> Result<Bsdf>;

    /// Errors on any property or nested object not read so far (the format checks this after
    /// every constructor; one that loads large data calls it before).
    fn finish(&self) -> Result<()>;
}

/// The one nested BSDF of an adapter (mask, normalmap, bumpmap), checked before anything is
/// read: `none` and `many` are the messages when there is none or more than one.
pub fn single_nested_bsdf(p: &mut dyn BsdfProperties, none: &str, many: &str) -> Result<()> {
    match p.nested_bsdf_count() {
        1 => Ok(()),
        0 => Err(p.err(none)),
        _ => Err(p.err(many)),
    }
}

/// A constant texture must lie in [0, 1] (blend weights, opacities); a texture is not checked.
pub fn check_unit_interval(p: &dyn BsdfProperties, name: &str, t: &Texture) -> Result<()> {
    if let Texture::Constant(c) = t
        && !(c.min_element() >= 0.0 && c.max_element() <= 1.0)
    {
        return Err(p.err(&format!("\"{name}\" must lie in [0, 1], got {c}")));
    }
    Ok(())
}
