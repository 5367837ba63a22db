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
/// as in [`check_file`] / [`check_folder`]. An existing folder that holds anything is refused
/// unless `force` (then its UBO2003 images are replaced, see [`clear_btf_folder`]), so a folder
/// never ends up a mix of two BTFs or two encodings.
pub fn btf_output(path: &Path, force: bool) -> anyhow::Result<BtfOutput> {
    let kind = match extension(path).as_deref() {
        _ if path.is_dir() => BtfOutput::Folder,
        Some("btfc") => BtfOutput::Cache,
        None => BtfOutput::Folder,
        Some("btf") => bail!(
            "{}: btfpt does not write UBO2014 .btf files (they hold a matrix factorisation, \
             which btfpt does not compute); name a .btfc cache or a folder without extension \
             for UBO2003 images",
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
        BtfOutput::Folder => {
            check_folder(path)?;
            let entries = std::fs::read_dir(path).map_or(0, |d| d.count());
            if entries > 0 && !force {
                bail!(
                    "{}: the folder is not empty ({entries} {}); writing a BTF into it would \
                     add to or replace what is there; name a new or empty folder, or pass \
                     --force to replace its UBO2003 images",
                    path.display(),
                    if entries == 1 { "entry" } else { "entries" }
                );
            }
        }
    }
    Ok(kind)
}

/// Removes the UBO2003 images (any encoding) of an existing output folder before a `--force`d
/// write, so the folder holds one BTF in one encoding afterwards; other files are kept.
pub fn clear_btf_folder(path: &Path) -> anyhow::Result<()> {
    if path.is_dir() {
        let n = btfpt::btf::ubo2003::remove_images(path)?;
        if n > 0 {
            eprintln!(
                "--force: removed the {n} UBO2003 images that were in {}",
                path.display()
            );
        }
    }
    Ok(())
}

/// Says how many values an sRGB PNG encoding (`png8`, `png16`) clips at 1; the same values in
/// EXR are kept. `option` names the flag that chose the encoding, for the message.
pub fn warn_clipped(btf: &btfpt::btf::RawBtf, option: &str) {
    let values = btf.data();
    let clipped = values.iter().filter(|v| v.to_f32() > 1.0).count();
    if clipped > 0 {
        let max = values.iter().map(|v| v.to_f32()).fold(0.0f32, f32::max);
        eprintln!(
            "warning: {clipped} of {} values ({:.3}%) exceed 1 (up to {max:.2}) and are clipped to 1 \
             by {option}; exr keeps them",
            values.len(),
            100.0 * clipped as f64 / values.len().max(1) as f64
        );
    }
}

/// The encoding of an image output, chosen by its extension (the one rule for every command:
/// the bytes written are always what the extension says).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFile {
    /// `.exr`: linear 32-bit float RGB, unclamped.
    Exr,
    /// `.png`: 8-bit sRGB-encoded RGB, clamped to [0, 1].
    Png,
}

/// Both encodings: outputs written as `.png` or `.exr`, as the user names them.
pub const ANY_IMAGE: [ImageFile; 2] = [ImageFile::Png, ImageFile::Exr];

impl ImageFile {
    fn extension(self) -> &'static str {
        match self {
            ImageFile::Exr => "exr",
            ImageFile::Png => "png",
        }
    }
    fn describe(self) -> &'static str {
        match self {
            ImageFile::Exr => ".exr (linear 32-bit float)",
            ImageFile::Png => ".png (8-bit sRGB)",
        }
    }
}

/// Checks an image output before any work: its extension must name one of the encodings
/// `accepted` by this output (`what`, e.g. "--diff"), compared case-insensitively, and the file
/// must be writable as in [`check_file`]. Returns the encoding to write.
pub fn image_file(path: &Path, accepted: &[ImageFile], what: &str) -> anyhow::Result<ImageFile> {
    let ext = extension(path);
    let Some(kind) = accepted
        .iter()
        .copied()
        .find(|k| ext.as_deref() == Some(k.extension()))
    else {
        let names: Vec<&str> = accepted.iter().map(|k| k.describe()).collect();
        bail!(
            "{}: {what} is written as {}; name the file with that extension",
            path.display(),
            names.join(" or ")
        );
    };
    check_file(path)?;
    Ok(kind)
}

/// [`image_file`] for an optional output.
pub fn optional_image_file(
    path: Option<&PathBuf>,
    accepted: &[ImageFile],
    what: &str,
) -> anyhow::Result<Option<ImageFile>> {
    path.map(|p| image_file(p, accepted, what)).transpose()
}

/// Writes `img` (linear RGB) in the encoding its extension picked by [`image_file`].
pub fn write_image(path: &Path, img: &btfpt::io::RgbImage) -> anyhow::Result<()> {
    match extension(path).as_deref() {
        Some("exr") => btfpt::io::write_exr(path, img)?,
        Some("png") => btfpt::io::write_png_srgb(path, img)?,
        _ => bail!("{}: not an .exr or .png image file name", path.display()),
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_outputs_must_carry_the_extension_of_their_encoding() {
        let dir = tempfile::tempdir().unwrap();
        let both = [ImageFile::Png, ImageFile::Exr];
        let p = dir.path().join("a.EXR");
        assert_eq!(image_file(&p, &both, "-o").unwrap(), ImageFile::Exr);
        let p = dir.path().join("a.png");
        assert_eq!(image_file(&p, &both, "-o").unwrap(), ImageFile::Png);
        let e = image_file(&p, &[ImageFile::Exr], "--variance")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("a.png") && e.contains("--variance") && e.contains(".exr"),
            "{e}"
        );
        let e = image_file(&dir.path().join("a.jpg"), &both, "-o")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("a.jpg") && e.contains(".png") && e.contains(".exr"),
            "{e}"
        );
    }
}
