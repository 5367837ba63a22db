//! What the caller adds to a scene file when loading it (the CLI's `-D` and `--btf-model`),
//! passed explicitly to every loader.

use crate::model::BtfModel;

/// Options of [`crate::scene::load`] and the XML and glTF loaders.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LoadOptions {
    /// `name=value` pairs that override XML `<default>` values (the CLI's `-D`); for glTF they
    /// set `width`, `height`, `spp`, `max_depth` (see [`crate::scene::gltf`]).
    pub defines: Vec<(String, String)>,
    /// Model used by every `<bsdf type="btf">` instead of its own `model` property (the CLI's
    /// `--btf-model`); None leaves the scene as written.
    pub btf_model: Option<BtfModel>,
    /// Folder where generated `synth:` materials are kept between processes (the CLI passes
    /// the user's cache folder, [`crate::btf::synth::disk_cache::default_cache_dir`]); None
    /// generates them in memory, once per process.
    pub synth_cache: Option<std::path::PathBuf>,
}

impl LoadOptions {
    /// Options with these defines and nothing else.
    pub fn with_defines(defines: &[(String, String)]) -> LoadOptions {
        LoadOptions {
            defines: defines.to_vec(),
            ..LoadOptions::default()
        }
    }
}
