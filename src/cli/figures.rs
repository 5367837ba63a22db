//! One definition of each figure every command prints about a fitted model (`fit`, `info`,
//! `eval` and its JSON use these and nothing else):
//! - compression ratio = 8-bit RGB raw size of the texels the model stores (views × lights ×
//!   width × height × 3 bytes) / size of the model file; for a tile, the tile's texels, not the
//!   sample it was cut from;
//! - clusters = K-means clusters per view and colour channel (the table each view's texels
//!   index), as produced; never more than the texels of one view.

use btfpt::fit::report::raw_bytes;
use btfpt::model::{PlmcModel, ValueSpace, ViewParams};

/// Raw 8-bit size of the model's own texels, in bytes.
pub fn raw_of(model: &PlmcModel) -> usize {
    raw_bytes(
        model.views.len(),
        model.lights.len(),
        model.width * model.height,
    )
}

/// "1:R vs 8-bit raw data of the W×H texels (B bytes)" for a model file of `file_bytes` bytes.
pub fn compression(model: &PlmcModel, file_bytes: u64) -> String {
    let raw = raw_of(model);
    format!(
        "1:{:.1} vs the 8-bit raw data of its {}×{} texels ({raw} bytes)",
        ratio(model, file_bytes),
        model.width,
        model.height
    )
}

/// The compression ratio (see the module docs).
pub fn ratio(model: &PlmcModel, file_bytes: u64) -> f64 {
    raw_of(model) as f64 / file_bytes.max(1) as f64
}

/// Smallest and largest cluster count per view and colour channel over the views (PLM-C).
pub fn cluster_range(model: &PlmcModel) -> Option<(usize, usize)> {
    let ks = model.params.iter().filter_map(|p| match p {
        ViewParams::Clustered { k, .. } => Some(*k),
        ViewParams::Texel(_) => None,
    });
    ks.fold(None, |acc, k| match acc {
        None => Some((k, k)),
        Some((lo, hi)) => Some((lo.min(k), hi.max(k))),
    })
}

/// "K per view and colour channel (of T texels)", with a note when fewer were produced than
/// requested (`requested` = --clusters, when known).
pub fn clusters(model: &PlmcModel, requested: Option<usize>) -> Option<String> {
    let (lo, hi) = cluster_range(model)?;
    let texels = model.width * model.height;
    let k = if lo == hi {
        format!("{hi}")
    } else {
        format!("{lo}..{hi}")
    };
    let mut s = format!("{k} per view and colour channel, for {texels} texels");
    if let Some(r) = requested.filter(|&r| r > hi) {
        s.push_str(&format!(
            " (warning: {r} requested; K-means cannot make more clusters than distinct texels)"
        ));
    }
    Some(s)
}

/// The model's value space in words.
pub fn value_space(space: ValueSpace) -> &'static str {
    match space {
        ValueSpace::Linear => "linear (the polynomial gives the BTF value)",
        ValueSpace::Srgb => "sRGB-encoded, as 8-bit data (the BTF value is sRGB-decoded)",
    }
}
