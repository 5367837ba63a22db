//! BTF enlargement (paper §3): seamless tiles cut out of the measured sample with
//! minimum-error boundary cuts, so a fitted material wraps without visible seams.
//!
//! Two stages, as in the paper. (1) On a few representative images (view/light pairs spread over
//! the hemisphere, compared in the data's stored encoding) we search the source offset of the
//! template and the cut paths through the overlap error maps that make it wrap in x and y, and the
//! adaptive blend radius along each path. The result is a [`Stitch`]: for every tile texel the
//! sample texels it is made of and their weights. (2) The same stitch is applied to every image
//! of every view ([`TiledSource`]), so the cut is consistent across all 6561 images, and the
//! fitter sees only the tile's texels.
//!
//! Cuts are the optimal dynamic-programming paths of Efros & Freeman (the wrapping vertical cut is
//! solved exactly as a cyclic path by fixing its start column). The paper uses the sub-optimal
//! search of Somol & Haindl to save time on 800² parameter images; our bands are a few texels wide
//! and at most a few hundred long, so the exact DP costs O(len · band²) ≈ microseconds and leaves
//! no reason to accept a worse path. Blending is adaptive: along the path, the feather half-width
//! grows with the local cut error relative to the mean error of the band (0 where the two sources
//! agree, so matching content stays sharp).
//!
//! Multiple tiles (`count > 1`, Wang-tile-like variety): tile 0 is the template; tile k copies it
//! and covers its inner area (a margin of one overlap width stays untouched) with a patch from
//! another position of the sample, stitched in with four minimum-error cuts. All tiles share the
//! template's borders, so any sequence of tiles in any arrangement is seamless. Tiles are stacked
//! vertically in the parameter planes (width = tile width, height = count · tile height).
//!
//! Files: `stitch.rs` (the stitch and its byte codec), `cut.rs` (minimum-error paths and blend
//! radii), `quilt.rs` (finding the stitch on representative images), `source.rs` (stage 2, the
//! tiled view of a source), `seams.rs` (the seam metric).
//!
//! This is raw-data processing: it knows nothing of the models fitted to the tiles.

mod cut;
mod quilt;
mod seams;
mod source;
mod stitch;
#[cfg(test)]
mod tests;

pub use cut::min_error_cut;
pub use quilt::{find_stitch, find_stitch_in, representative_pairs};
pub use seams::{SeamStats, source_seams};
pub use source::TiledSource;
pub use stitch::Stitch;

use crate::{Error, Result};

/// What to cut out of the sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TileSpec {
    /// Tile width in texels.
    pub width: usize,
    /// Tile height in texels.
    pub height: usize,
    /// Number of tiles (1 = the template only).
    pub count: usize,
    /// Overlap band in texels; `None` = min(w, h)/4 clamped to 2..=16 and to the room in the sample.
    pub overlap: Option<usize>,
}

impl TileSpec {
    /// One tile of `width × height`, default overlap.
    pub fn new(width: usize, height: usize) -> Self {
        TileSpec {
            width,
            height,
            count: 1,
            overlap: None,
        }
    }
}

/// Parses `WxH` (or `N` for a square) as a tile size.
pub fn parse_size(s: &str) -> Result<(usize, usize)> {
    let bad = || Error::Invalid(format!("tile size '{s}' is not N or WxH (e.g. 64x64)"));
    let p = |t: &str| t.trim().parse::<usize>().map_err(|_| bad());
    let (w, h) = match s.split_once(['x', 'X']) {
        Some((w, h)) => (p(w)?, p(h)?),
        None => {
            let n = p(s)?;
            (n, n)
        }
    };
    if w == 0 || h == 0 {
        return Err(Error::Invalid(format!("tile size '{s}' must be positive")));
    }
    Ok((w, h))
}
