//! Measured BTF data: direction sets and their interpolation, the raw BTF in memory, its file
//! formats, the measurement simulator, and (later) the PLM-C evaluation core.

pub mod directions;
pub mod raw;
pub mod synth;
pub mod ubo2003;

pub use directions::DirectionSet;
pub use raw::{BtfSource, RawBtf, StoredEncoding};

/// Opens any BTF on disk (UBO2003 folder, UBO2014 `.btf`, our cache) for per-view streaming.
pub fn open(path: &std::path::Path) -> crate::Result<Box<dyn BtfSource + Send>> {
    // TEMPORARY: replaced by the btf-io helper.
    Err(crate::Error::format(
        path,
        "BTF reading not implemented yet",
    ))
}

/// Loads a whole BTF into memory (for rendering the raw data).
pub fn load_raw(path: &std::path::Path) -> crate::Result<RawBtf> {
    // TEMPORARY: replaced by the btf-io helper.
    Err(crate::Error::format(
        path,
        "BTF reading not implemented yet",
    ))
}
