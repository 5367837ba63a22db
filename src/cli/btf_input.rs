//! The BTF a command reads (`info`, `fit`, `eval --against`, `convert`, `tile-preview --data`):
//! a path, or a `synth:` source as in scenes, which is generated once and kept as a `.btfc` in
//! the user's cache folder (`BTFPT_CACHE_DIR`, else `$XDG_CACHE_HOME/btfpt`, else
//! `~/.cache/btfpt`), so every command then reads that file.

use btfpt::btf::synth::disk_cache;
use std::path::{Path, PathBuf};

/// The file to read for `input`: `input` itself, or for a `synth:` source its cache entry
/// (generated first if missing or corrupt; the command says which on stderr).
pub fn resolve(input: &Path) -> anyhow::Result<PathBuf> {
    let dir = disk_cache::default_cache_dir();
    let (path, note) = disk_cache::resolve_input(input, dir.as_deref())?;
    if let Some(note) = note {
        eprintln!("{note}");
    }
    Ok(path)
}
