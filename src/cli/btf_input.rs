//! The BTF a command reads (`info`, `fit`, `eval --against`, `convert`, `tile-preview --data`):
//! a path, or a `synth:` source as in scenes, which is generated once and kept as a `.btfc` in
//! the user's cache folder (`BTFPT_CACHE_DIR`, else `$XDG_CACHE_HOME/btfpt`, else
//! `~/.cache/btfpt`), so every command then reads that file.

use anyhow::{Context, bail};
use btfpt::btf::synth::{SynthOrigin, SynthSpec, disk_cache};
use std::path::{Path, PathBuf};

/// The file to read for `input`: `input` itself, or for a `synth:` source its cache entry
/// (generated first if missing or corrupt; the command says which on stderr).
pub fn resolve(input: &Path) -> anyhow::Result<PathBuf> {
    let Some(spec) = input.to_str().and_then(SynthSpec::parse) else {
        return Ok(input.to_path_buf());
    };
    let spec = spec?;
    let Some(dir) = disk_cache::default_cache_dir() else {
        bail!(
            "{}: a synth: source is read through the cache folder, and none is known: set {} \
             (or XDG_CACHE_HOME or HOME)",
            input.display(),
            disk_cache::CACHE_DIR_ENV
        );
    };
    let (_, origin) = disk_cache::load_or_generate(&spec, Some(&dir))
        .with_context(|| format!("generating {}", input.display()))?;
    eprintln!("{}: {origin}", spec.canonical());
    match origin {
        SynthOrigin::Cached(p) | SynthOrigin::Generated { entry: p, .. } => Ok(p),
        SynthOrigin::Uncached { reason, .. } => bail!("{}: {reason}", input.display()),
    }
}
