//! The `.plmc` model file (docs/formats.md): little-endian, versioned, one CRC32 per section.
//!
//! ```text
//! file    := "PLMC" u32 version(=2; 1 is still read) section* END
//! section := tag[4] u64 len payload[len] u32 crc32(tag ‖ payload)
//! HEAD    := u8 kind(0 LM,1 PLM,2 PLM-C) u8 index_bytes(0|1|2) u8 space(0 linear,1 sRGB) u8 reserved
//!            u32 width u32 height u32 tile_w u32 tile_h u32 clusters u32 views u32 lights
//!            views × (f32 θ°, f32 φ°)  lights × (f32 θ°, f32 φ°)
//! VIEW    := u32 view u32 k  (k = 0: per-texel lobes)
//!            k > 0: table, u8 coding (0 raw, 1 deflate), u32 n, index data[n]
//!                   table := version 2: u8 coding (0 raw, 1 deflated byte planes) u32 n data[n]
//!                            (the k × 3 lobes, as planes: byte b of every lobe for b = 0..8)
//!                          | version 1: k × 3 × lobe
//!            k = 0: W·H·3 × lobe
//! POLY    := version 2: u8 coding (0 plain, 1 zlib) streams      (PLM and PLM-C only)
//!            streams: per polynomial ([view][light][channel]) a header i8 e, i8 s (packed:
//!            Bernstein coefficients q_k·2^s on [0, 2^e], see `model::polynomial::PackedPoly`) or
//!            i8 −128 (raw); then the i16 q_k of the packed ones as byte planes; then 5 f32
//!            a_0..a_4 per raw one (coefficients without an exact packed form); see `poly_payload`
//!            version 1: views × lights × 3 × 5 f32 a_0..a_4
//! TILE    := optional: how the tiles were cut from the sample (see `btf::tiling::Stitch`)
//! "END!"  := empty payload
//! lobe    := u16 ρ (f16 bits) u16 oct_x u16 oct_y u16 n (f16 bits)      (see PackedLobe)
//! ```
//! Index data are the index planes `[channel][texel]` (u8 or u16 little-endian), raw or, when
//! smaller, zlib-deflated after a channel-delta filter (G−R, B−G modulo 2⁸ or 2¹⁶). Lobes are
//! f16/u16 (8 bytes: enough precision, see [`PackedLobe`](crate::model::PackedLobe)). Polynomials
//! are not stored in the power basis (a degree-4 mapping in f16 would lose most digits to
//! cancellation) but as quantised Bernstein coefficients (12 bytes instead of 20, error ≤ half a
//! step on the domain); the fitter snaps its mappings to that form, so the file reproduces the
//! in-memory model bit for bit, and any other coefficients fall back to f32 records.
//!
//! All reading goes through [`crate::io::bytes::Reader`]: errors name the file, the section, the
//! byte offset and the field.

mod head;
mod poly;
mod view;

pub use head::Header;
pub use poly::{poly_bytes, poly_payload};
pub use view::view_payload;

use crate::btf::tiling::Stitch;
use crate::io::bytes::{Reader, Writer};
use crate::model::PlmcModel;
use crate::model::ViewParams;
use crate::{Error, Result};
use std::io::{Read, Write};
use std::path::Path;

/// File magic.
pub const MAGIC: &[u8; 4] = b"PLMC";
/// Current format version.
pub const VERSION: u32 = 2;
/// How a reader names this data in errors.
const KIND: &str = "corrupt .plmc file";

/// The planes of a tiled model: `width / tile_w × height / tile_h` seamless tiles (all sharing
/// their borders), and the stitch that cut them from the measured sample (opaque here, read by
/// `btf::tiling::Stitch::from_bytes`).
#[derive(Clone, Debug, PartialEq)]
pub struct TileSection {
    /// Texels per row of one tile.
    pub tile_w: usize,
    /// Rows of one tile.
    pub tile_h: usize,
    /// The TILE section payload.
    pub payload: Vec<u8>,
}

impl TileSection {
    /// The `.plmc` TILE section holding this stitch.
    pub fn from_stitch(stitch: &Stitch) -> Result<Self> {
        Ok(TileSection {
            tile_w: stitch.tile_w,
            tile_h: stitch.tile_h,
            payload: stitch.to_bytes()?,
        })
    }

    /// The stitch this TILE section of the file `path` holds, checked against its tile size.
    pub fn stitch(&self, path: &Path) -> Result<Stitch> {
        let t = self;
        let s = Stitch::from_bytes(&t.payload, path)?;
        if (s.tile_w, s.tile_h) != (t.tile_w, t.tile_h) {
            return Err(Error::format(
                path,
                format!(
                    "TILE section describes {}×{} tiles, the header {}×{}",
                    s.tile_w, s.tile_h, t.tile_w, t.tile_h
                ),
            ));
        }
        Ok(s)
    }
}

/// Writes the whole model to `path` atomically (temporary file + rename).
pub fn write(path: &Path, model: &PlmcModel) -> Result<()> {
    write_tiled(path, model, None)
}

/// [`write`] with an optional TILE section.
pub fn write_tiled(path: &Path, model: &PlmcModel, tile: Option<&TileSection>) -> Result<()> {
    let bytes = to_bytes_tiled(model, tile)?;
    crate::io::write_atomic(path, |w| {
        w.write_all(&bytes).map_err(|e| Error::io(path, e))
    })
}

/// Reads and fully validates a model file; corrupt or truncated files give an error naming the
/// file and the problem.
pub fn read(path: &Path) -> Result<PlmcModel> {
    Ok(read_tiled(path)?.0)
}

/// [`read`], also returning the TILE section if present.
pub fn read_tiled(path: &Path) -> Result<(PlmcModel, Option<TileSection>)> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    from_bytes_tiled(&bytes, path)
}

/// Reads only the magic, version and HEAD section of a model file (what it holds, its size and
/// directions) without decoding its planes: cheap enough to ask of every candidate file.
pub fn read_header(path: &Path) -> Result<Header> {
    let mut f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut start = [0u8; 20];
    f.read_exact(&mut start).map_err(|e| match e.kind() {
        std::io::ErrorKind::UnexpectedEof => Error::format(path, "not a .plmc file (too short)"),
        _ => Error::io(path, e),
    })?;
    let mut r = Reader::new(&start, path, KIND);
    let version = read_magic(&mut r)?;
    r.set_part("section header");
    let tag = r.array::<4>("tag")?;
    if &tag != b"HEAD" {
        return Err(r.err("first section is not HEAD"));
    }
    let len = r.u64("section length")?;
    // A HEAD holds 32 bytes plus 8 per direction, and at most 2 × 2^16 directions.
    if len > 32 + 16 * head::MAX_DIRECTIONS as u64 {
        return Err(r.err(format!("HEAD section claims {len} bytes")));
    }
    let mut rest = vec![0u8; len as usize + 4];
    f.read_exact(&mut rest)
        .map_err(|_| Error::format(path, "corrupt .plmc file: truncated HEAD section"))?;
    let mut whole = start.to_vec();
    whole.extend_from_slice(&rest);
    let mut r = Reader::new(&whole, path, KIND);
    r.seek(8)?;
    let (_, payload) = next_section(&mut r)?;
    Header::parse(payload, path, version, None)
}

/// Serialises a model (the exact bytes [`write`] stores).
pub fn to_bytes(model: &PlmcModel) -> Result<Vec<u8>> {
    to_bytes_tiled(model, None)
}

/// Serialises a model with an optional TILE section (its tile size goes into HEAD).
pub fn to_bytes_tiled(model: &PlmcModel, tile: Option<&TileSection>) -> Result<Vec<u8>> {
    to_bytes_version(model, tile, VERSION)
}

/// The bytes of `model` in format `version` (1 or 2; only tests write version 1).
fn to_bytes_version(
    model: &PlmcModel,
    tile: Option<&TileSection>,
    version: u32,
) -> Result<Vec<u8>> {
    model.validate()?;
    let tile_size = match tile {
        Some(t) => {
            if t.tile_w == 0
                || t.tile_h == 0
                || !model.width.is_multiple_of(t.tile_w)
                || !model.height.is_multiple_of(t.tile_h)
            {
                return Err(Error::Invalid(format!(
                    "{}×{} tiles do not divide the {}×{} planes",
                    t.tile_w, t.tile_h, model.width, model.height
                )));
            }
            (t.tile_w, t.tile_h)
        }
        None => (model.width, model.height),
    };
    let mut out = Writer::new();
    out.bytes(MAGIC).u32(version);
    push_section(&mut out, b"HEAD", &head::payload(model, tile_size)?);
    for (v, p) in model.params.iter().enumerate() {
        push_section(
            &mut out,
            b"VIEW",
            &view::payload_version(v, p, model.clusters, version)?,
        );
    }
    if model.kind.has_polys() {
        let p = if version == 1 {
            let mut p = Writer::new();
            for a in &model.polys {
                a.iter().for_each(|&x| {
                    p.f32(x);
                });
            }
            p.into_bytes()
        } else {
            poly_payload(&model.polys)?
        };
        push_section(&mut out, b"POLY", &p);
    }
    if let Some(t) = tile {
        push_section(&mut out, b"TILE", &t.payload);
    }
    push_section(&mut out, b"END!", &[]);
    Ok(out.into_bytes())
}

/// Bytes the file of a model with these per-view sections and POLY records (see
/// [`poly_bytes`]) would take: used to size models that are evaluated without being written, one
/// view at a time.
pub fn file_size(
    model_without_views: &PlmcModel,
    view_section_bytes: usize,
    poly_record_bytes: usize,
) -> Result<usize> {
    let polys = if model_without_views.kind.has_polys() {
        SECTION_OVERHEAD + poly_record_bytes
    } else {
        0
    };
    Ok(8 + SECTION_OVERHEAD
        + head::payload(model_without_views, (1, 1))?.len()
        + view_section_bytes
        + polys
        + SECTION_OVERHEAD)
}

/// Tag + length + CRC bytes around every payload.
pub const SECTION_OVERHEAD: usize = 4 + 8 + 4;

/// Bytes of the VIEW section of one view (payload plus section overhead).
pub fn view_section_size(view: usize, p: &ViewParams, clusters: usize) -> Result<usize> {
    Ok(SECTION_OVERHEAD + view_payload(view, p, clusters)?.len())
}

/// Index bytes per texel and channel for `clusters` clusters (0: per-texel lobes).
fn index_bytes(clusters: usize) -> u8 {
    match clusters {
        0 => 0,
        1..=256 => 1,
        _ => 2,
    }
}

/// Zlib-deflates `data` at the best level.
fn deflate(data: &[u8], what: &str) -> Result<Vec<u8>> {
    let mut enc = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    enc.write_all(data)
        .map_err(|e| Error::Invalid(format!("deflating {what}: {e}")))?;
    enc.finish()
        .map_err(|e| Error::Invalid(format!("deflating {what}: {e}")))
}

/// Inflates zlib `data` that must come to exactly `expect` bytes (never allocating more).
fn inflate_exact(r: &Reader, data: &[u8], expect: usize, what: &str) -> Result<Vec<u8>> {
    let mut out = Vec::with_capacity(expect);
    flate2::read::ZlibDecoder::new(data)
        .take(expect as u64 + 1)
        .read_to_end(&mut out)
        .map_err(|e| r.err(format!("{what} does not inflate: {e}")))?;
    if out.len() != expect {
        return Err(r.err(format!("{what} has {} bytes, expected {expect}", out.len())));
    }
    Ok(out)
}

fn push_section(out: &mut Writer, tag: &[u8; 4], payload: &[u8]) {
    let mut h = crc32fast::Hasher::new();
    h.update(tag);
    h.update(payload);
    out.bytes(tag)
        .u64(payload.len() as u64)
        .bytes(payload)
        .u32(h.finalize());
}

/// Reads the magic and the format version.
fn read_magic(r: &mut Reader) -> Result<u32> {
    r.set_part("file header");
    if r.take(4, "magic").ok() != Some(MAGIC.as_slice()) {
        return Err(Error::format(
            r.path(),
            "not a .plmc file (missing 'PLMC' magic)",
        ));
    }
    let version = r.u32("format version")?;
    if version != 1 && version != VERSION {
        return Err(r.err(format!(
            "unsupported format version {version} (this build reads 1..={VERSION})"
        )));
    }
    Ok(version)
}

/// Reads the next section: (tag, payload), verifying length bounds and the CRC.
fn next_section<'a>(r: &mut Reader<'a>) -> Result<([u8; 4], &'a [u8])> {
    r.set_part("section header");
    let tag: [u8; 4] = r.array("section tag")?;
    let len = r.u64("section length")?;
    if len > r.remaining() as u64 {
        return Err(r.err(format!(
            "section '{}' claims {len} bytes but only {} remain (truncated file?)",
            String::from_utf8_lossy(&tag),
            r.remaining()
        )));
    }
    let payload = r.take(len as usize, "section payload")?;
    let crc = r.u32("section CRC")?;
    let mut h = crc32fast::Hasher::new();
    h.update(&tag);
    h.update(payload);
    if h.finalize() != crc {
        return Err(r.err(format!(
            "CRC32 mismatch in section '{}' (the file is corrupt)",
            String::from_utf8_lossy(&tag)
        )));
    }
    Ok((tag, payload))
}

/// Parses and validates a model from bytes; `path` is only used in error messages.
pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<PlmcModel> {
    Ok(from_bytes_tiled(bytes, path)?.0)
}

/// [`from_bytes`], also returning the TILE section if present.
pub fn from_bytes_tiled(bytes: &[u8], path: &Path) -> Result<(PlmcModel, Option<TileSection>)> {
    let mut c = Reader::new(bytes, path, KIND);
    let version = read_magic(&mut c)?;
    let (tag, head) = next_section(&mut c)?;
    if &tag != b"HEAD" {
        return Err(c.err("first section is not HEAD"));
    }
    let h = Header::parse(head, path, version, Some(bytes.len()))?;
    let texels = h.width * h.height;
    let mut params = Vec::with_capacity(h.views.len());
    for v in 0..h.views.len() {
        let (tag, payload) = next_section(&mut c)?;
        if &tag != b"VIEW" {
            return Err(c.err(format!(
                "expected VIEW section {v}, found '{}'",
                String::from_utf8_lossy(&tag)
            )));
        }
        params.push(view::read(payload, path, &h, v, texels)?);
    }
    let mut polys = Vec::new();
    if h.kind.has_polys() {
        let (tag, payload) = next_section(&mut c)?;
        if &tag != b"POLY" {
            return Err(c.err("missing POLY section"));
        }
        polys = poly::read(payload, path, version, h.views.len() * h.lights.len() * 3)?;
    }
    let (mut tag, mut payload) = next_section(&mut c)?;
    let mut tile = None;
    if &tag == b"TILE" {
        tile = Some(TileSection {
            tile_w: h.tile_w,
            tile_h: h.tile_h,
            payload: payload.to_vec(),
        });
        (tag, payload) = next_section(&mut c)?;
    }
    if &tag != b"END!" || !payload.is_empty() {
        return Err(c.err("missing END! section"));
    }
    c.set_part("end of file");
    c.finish()?;
    let model = PlmcModel {
        kind: h.kind,
        views: h.views,
        lights: h.lights,
        width: h.width,
        height: h.height,
        clusters: h.clusters,
        space: h.space,
        params,
        polys,
    };
    model
        .validate()
        .map_err(|e| Error::format(path, e.to_string()))?;
    Ok((model, tile))
}

#[cfg(test)]
mod tests;
