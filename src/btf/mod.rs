//! Measured BTF data: direction sets and their interpolation, the raw BTF in memory, its file
//! formats, the measurement simulator, and (later) the PLM-C evaluation core.

pub mod directions;
pub mod raw;

pub use directions::DirectionSet;
pub use raw::{BtfSource, RawBtf, StoredEncoding};
