//! The one rule for every command's outputs: check them before any work is done, create no
//! folder the user did not name, and say what is wrong in one sentence naming the path.

use anyhow::bail;
use std::path::{Path, PathBuf};

/// The folder a file output goes into (`.` for a bare file name).
fn parent_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Fails unless `dir` exists as a folder we can create files in (probed with a temporary file
/// that is removed again). `path` is the output the user named, for the message.
fn check_dir_writable(dir: &Path, path: &Path) -> anyhow::Result<()> {
    if !dir.is_dir() {
        bail!(
            "{}: the folder {} does not exist (btfpt creates no folders you did not name)",
            path.display(),
            dir.display()
        );
    }
    let probe = btfpt::io::atomic::temp_path(&dir.join(".btfpt-write-probe"));
    match std::fs::write(&probe, b"") {
        Ok(()) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => bail!(
            "{}: output is not writable (cannot create files in the folder {}: {e})",
            path.display(),
            dir.display()
        ),
    }
}

/// Checks that the output file `path` can be written: its folder exists and is writable and
/// `path` is not a folder.
pub fn check_file(path: &Path) -> anyhow::Result<()> {
    if path.is_dir() {
        bail!("{}: is a folder, expected a file name", path.display());
    }
    check_dir_writable(&parent_of(path), path)
}

/// Checks an optional output file (see [`check_file`]).
pub fn check_optional_file(path: Option<&PathBuf>) -> anyhow::Result<()> {
    path.map_or(Ok(()), |p| check_file(p))
}

/// Checks that the output folder `path` can be written: it is an existing folder, or it does
/// not exist yet and its parent folder does (only `path` itself will be created).
pub fn check_folder(path: &Path) -> anyhow::Result<()> {
    if path.is_dir() {
        return check_dir_writable(path, path);
    }
    if path.exists() {
        bail!("{}: exists and is not a folder", path.display());
    }
    check_dir_writable(&parent_of(path), path)
}

/// Lower-case extension of `path`, if it has one.
pub fn extension(path: &Path) -> Option<String> {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
}

/// What a BTF output path (`synth -o`, `convert … OUT`) asks for, by its extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BtfOutput {
    /// `NAME.btfc`: the memory-mappable cache (any direction set).
    Cache,
    /// A name without extension (or an existing folder): a UBO2003 image folder.
    Folder,
}

/// The format an output path picks: `.btfc` is the cache, no extension a UBO2003 folder; any
/// other extension is an error (instead of a folder called `x.btf`), and the output is checked
/// as in [`check_file`] / [`check_folder`].
pub fn btf_output(path: &Path) -> anyhow::Result<BtfOutput> {
    let kind = match extension(path).as_deref() {
        _ if path.is_dir() => BtfOutput::Folder,
        Some("btfc") => BtfOutput::Cache,
        None => BtfOutput::Folder,
        Some("btf") => bail!(
            "{}: btfpt does not write UBO2014 .btf files (they are factorised); name a .btfc \
             cache or a folder without extension for UBO2003 images",
            path.display()
        ),
        Some(other) => bail!(
            "{}: unknown output extension .{other}; name a .btfc cache or a folder without \
             extension for UBO2003 images",
            path.display()
        ),
    };
    match kind {
        BtfOutput::Cache => check_file(path)?,
        BtfOutput::Folder => check_folder(path)?,
    }
    Ok(kind)
}
