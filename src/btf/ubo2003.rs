//! Bonn UBO2003 folder layout: 81 × 81 images named `NNNNN tlTTT plPPP tvTTT pvPPP.ext`.

use super::RawBtf;
use crate::Result;
use std::path::Path;

/// Image encoding used when writing a UBO2003 folder.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageKind {
    /// 8-bit sRGB PNG, what other UBO2003 tools expect.
    Png8,
    /// 16-bit sRGB PNG (more headroom for synthetic data).
    Png16,
    /// Linear 32-bit float EXR.
    Exr,
}

/// Writes `btf` as a flat UBO2003 folder (created if missing).
pub fn write_folder(btf: &RawBtf, dir: &Path, kind: ImageKind) -> Result<()> {
    // TEMPORARY: replaced by the btf-io helper.
    let _ = (btf, kind);
    Err(crate::Error::format(
        dir,
        "UBO2003 writing not implemented yet",
    ))
}
