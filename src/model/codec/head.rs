//! The HEAD section: what a `.plmc` file holds (kind, value space, plane and tile size, cluster
//! count) and its direction sets.

use super::{KIND, index_bytes};
use crate::btf::DirectionSet;
use crate::io::bytes::{Reader, Writer};
use crate::model::{ModelKind, PlmcModel, ValueSpace};
use crate::{Error, Result};
use std::path::Path;

/// Largest direction count a reader accepts (guards allocations on corrupt headers).
pub(super) const MAX_DIRECTIONS: usize = 1 << 16;

/// A model file's header: everything but the planes and polynomials.
#[derive(Clone, Debug)]
pub struct Header {
    /// Format version of the file.
    pub version: u32,
    /// The model the file holds.
    pub kind: ModelKind,
    /// Encoding of the model's values.
    pub space: ValueSpace,
    /// Texels per row of the parameter planes.
    pub width: usize,
    /// Rows of the parameter planes.
    pub height: usize,
    /// Texels per row of one tile (= `width` when untiled).
    pub tile_w: usize,
    /// Rows of one tile (= `height` when untiled).
    pub tile_h: usize,
    /// Clusters per view and channel (PLM-C), 0 otherwise.
    pub clusters: usize,
    /// Bytes per stored cluster index (0, 1 or 2).
    pub index_bytes: u8,
    /// Measured view directions.
    pub views: DirectionSet,
    /// Measured light directions.
    pub lights: DirectionSet,
}

/// The HEAD payload of `m` with tiles of `tile` texels.
pub(super) fn payload(m: &PlmcModel, tile: (usize, usize)) -> Result<Vec<u8>> {
    let mut w = Writer::new();
    w.u8(m.kind.code())
        .u8(index_bytes(m.clusters))
        .u8(m.space.code())
        .u8(0);
    for (v, field) in [
        (m.width, "width"),
        (m.height, "height"),
        (tile.0, "tile width"),
        (tile.1, "tile height"),
        (m.clusters, "clusters"),
        (m.views.len(), "view count"),
        (m.lights.len(), "light count"),
    ] {
        w.len32(v, field)?;
    }
    for &(t, f) in m.views.angles_deg.iter().chain(&m.lights.angles_deg) {
        w.f32(t).f32(f);
    }
    Ok(w.into_bytes())
}

impl Header {
    /// Parses and checks a HEAD payload. With `file_len`, also checks that planes of the stated
    /// size can be stored in a file that long (so a corrupt size never drives an allocation).
    pub(super) fn parse(
        head: &[u8],
        path: &Path,
        version: u32,
        file_len: Option<usize>,
    ) -> Result<Header> {
        let mut h = Reader::new(head, path, KIND);
        h.set_part("HEAD");
        let kind =
            ModelKind::from_code(h.u8("model kind")?).ok_or_else(|| h.err("unknown model kind"))?;
        let ib = h.u8("index width")?;
        let space = ValueSpace::from_code(h.u8("value space")?)
            .ok_or_else(|| h.err("unknown value space"))?;
        if h.u8("reserved byte")? != 0 {
            return Err(h.err("reserved header byte is not 0"));
        }
        let width = h.len32("width")?;
        let height = h.len32("height")?;
        let tile_w = h.len32("tile width")?;
        let tile_h = h.len32("tile height")?;
        let clusters = h.len32("clusters")?;
        let nv = h.len32("view count")?;
        let nl = h.len32("light count")?;
        if width == 0
            || height == 0
            || tile_w == 0
            || tile_h == 0
            || !width.is_multiple_of(tile_w)
            || !height.is_multiple_of(tile_h)
        {
            return Err(h.err(format!(
                "bad plane size {width}×{height} (tile {tile_w}×{tile_h})"
            )));
        }
        if nv == 0 || nl == 0 || nv > MAX_DIRECTIONS || nl > MAX_DIRECTIONS {
            return Err(h.err(format!("bad direction counts ({nv} views, {nl} lights)")));
        }
        if (kind == ModelKind::PlmC) != (clusters > 0)
            || clusters > 65536
            || ib != index_bytes(clusters)
        {
            return Err(h.err(format!(
                "cluster count {clusters} / index width {ib} do not fit a {} model",
                kind.name()
            )));
        }
        let views = read_dirs(&mut h, nv, "view directions")?;
        let lights = read_dirs(&mut h, nl, "light directions")?;
        h.finish()?;
        if let Some(len) = file_len {
            // Planes must be representable by the file: 24 bytes per texel for per-texel lobes,
            // and deflate cannot expand more than ~1032:1 for index images.
            let limit = len.saturating_mul(if kind == ModelKind::PlmC { 1100 } else { 1 });
            let fits = width.checked_mul(height).is_some_and(|t| {
                t.checked_mul(if kind == ModelKind::PlmC { 3 } else { 24 })
                    .is_some_and(|b| b <= limit)
            });
            if !fits {
                return Err(Error::format(
                    path,
                    format!("{KIND}: {width}×{height} texels cannot fit in a {len} byte file"),
                ));
            }
        }
        Ok(Header {
            version,
            kind,
            space,
            width,
            height,
            tile_w,
            tile_h,
            clusters,
            index_bytes: ib,
            views,
            lights,
        })
    }

    /// True if the planes are a grid of several seamless tiles.
    pub fn is_tiled(&self) -> bool {
        self.tile_w != self.width || self.tile_h != self.height
    }
}

fn read_dirs(r: &mut Reader, n: usize, field: &str) -> Result<DirectionSet> {
    let mut a = Vec::with_capacity(n);
    for _ in 0..n {
        let (t, f) = (r.f32(field)?, r.f32(field)?);
        if !(0.0..=90.0).contains(&t) || !f.is_finite() {
            return Err(r.err(format!(
                "{field}: (θ={t}, φ={f}) is not on the upper hemisphere"
            )));
        }
        a.push((t, f));
    }
    Ok(DirectionSet::from_angles_deg(a))
}
