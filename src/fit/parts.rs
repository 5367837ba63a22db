//! Part files of a fit in progress: one finished view each, so an interrupted fit resumes where
//! it stopped (and views can be fitted by separate processes).
//!
//! ```text
//! part := "PLMP" u64 fingerprint u32 view  <a complete one-view .plmc file>
//! ```

use crate::Result;
use crate::io::bytes::{Reader, Writer};
use crate::model::{PlmcModel, codec};
use std::path::Path;

/// Magic of a resumable-fit part file.
pub const PART_MAGIC: &[u8; 4] = b"PLMP";

/// Serialises one finished view of a fit in progress: magic, the fit's fingerprint, the view
/// index, then a complete one-view `.plmc` (so the same CRC-checked code reads it back).
pub fn part_to_bytes(fingerprint: u64, view: usize, one_view: &PlmcModel) -> Result<Vec<u8>> {
    let mut w = Writer::new();
    w.bytes(PART_MAGIC)
        .u64(fingerprint)
        .len32(view, "view index")?
        .bytes(&codec::to_bytes(one_view)?);
    Ok(w.into_bytes())
}

/// Reads a part written by [`part_to_bytes`]; `Ok(None)` if it belongs to another fit (different
/// fingerprint or view), an error if it is corrupt.
pub fn part_from_bytes(
    bytes: &[u8],
    path: &Path,
    fingerprint: u64,
    view: usize,
) -> Result<Option<PlmcModel>> {
    let mut r = Reader::new(bytes, path, "corrupt fit part file");
    r.set_part("part header");
    if r.take(4, "magic").ok() != Some(PART_MAGIC.as_slice()) {
        return Err(crate::Error::format(
            path,
            "not a fit part file (missing 'PLMP' magic)",
        ));
    }
    let fp = r.u64("fingerprint")?;
    let v = r.len32("view index")?;
    if fp != fingerprint || v != view {
        return Ok(None);
    }
    codec::from_bytes(&bytes[r.pos()..], path).map(Some)
}
