//! The `.plmc` model file (DESIGN §3): little-endian, versioned, one CRC32 per section.
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
//!            Bernstein coefficients q_k·2^s on [0, 2^e], see `fit::polynomial::PackedPoly`) or
//!            i8 −128 (raw); then the i16 q_k of the packed ones as byte planes; then 5 f32
//!            a_0..a_4 per raw one (coefficients without an exact packed form); see `poly_payload`
//!            version 1: views × lights × 3 × 5 f32 a_0..a_4
//! TILE    := optional: how the tiles were cut from the sample (see `fit::tiling::Stitch`)
//! "END!"  := empty payload
//! lobe    := u16 ρ (f16 bits) u16 oct_x u16 oct_y u16 n (f16 bits)      (see PackedLobe)
//! ```
//! Index data are the index planes `[channel][texel]` (u8 or u16 little-endian), raw or, when
//! smaller, zlib-deflated after a channel-delta filter (G−R, B−G modulo 2⁸ or 2¹⁶). Lobes are
//! f16/u16 (8 bytes: enough precision, see [`PackedLobe`]). Polynomials are not stored in the power
//! basis (a degree-4 mapping in f16 would lose most digits to cancellation) but as quantised
//! Bernstein coefficients (12 bytes instead of 20, error ≤ half a step on the domain); the fitter
//! snaps its mappings to that form, so the file reproduces the in-memory model bit for bit, and
//! any other coefficients fall back to f32 records.

use crate::btf::DirectionSet;
use crate::fit::model::{ModelKind, PackedLobe, PlmcModel, ValueSpace, ViewParams};
use crate::fit::polynomial::{self, PackedPoly, Poly};
use crate::{Error, Result};
use std::io::{Read, Write};
use std::path::Path;

/// File magic.
pub const MAGIC: &[u8; 4] = b"PLMC";
/// Current format version.
pub const VERSION: u32 = 2;
/// Marker of a POLY record holding f32 coefficients (version 2).
const RAW_POLY: i8 = i8::MIN;
/// Largest direction count a reader accepts (guards allocations on corrupt headers).
const MAX_DIRECTIONS: usize = 1 << 16;

/// The planes of a tiled model: `width / tile_w × height / tile_h` seamless tiles (all sharing
/// their borders), and the stitch that cut them from the measured sample (opaque here, read by
/// `fit::tiling::Stitch::from_bytes`).
#[derive(Clone, Debug, PartialEq)]
pub struct TileSection {
    /// Texels per row of one tile.
    pub tile_w: usize,
    /// Rows of one tile.
    pub tile_h: usize,
    /// The TILE section payload.
    pub payload: Vec<u8>,
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

/// [`read`], also returning the TILE section if the file has one.
pub fn read_tiled(path: &Path) -> Result<(PlmcModel, Option<TileSection>)> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    from_bytes_tiled(&bytes, path)
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
    let mut out = Vec::new();
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&version.to_le_bytes());
    push_section(&mut out, b"HEAD", &head_payload(model, tile_size));
    for (v, p) in model.params.iter().enumerate() {
        push_section(
            &mut out,
            b"VIEW",
            &view_payload_version(v, p, model.clusters, version)?,
        );
    }
    if model.kind.has_polys() {
        let p = if version == 1 {
            let mut p = Vec::with_capacity(model.polys.len() * 20);
            for a in &model.polys {
                a.iter().for_each(|x| p.extend_from_slice(&x.to_le_bytes()));
            }
            p
        } else {
            poly_payload(&model.polys)?
        };
        push_section(&mut out, b"POLY", &p);
    }
    if let Some(t) = tile {
        push_section(&mut out, b"TILE", &t.payload);
    }
    push_section(&mut out, b"END!", &[]);
    Ok(out)
}

/// Bytes the file of a model with these per-view sections and POLY records (see
/// [`poly_bytes`]) would take: used to size models that are evaluated without being written, one
/// view at a time.
pub fn file_size(
    model_without_views: &PlmcModel,
    view_section_bytes: usize,
    poly_record_bytes: usize,
) -> usize {
    let polys = if model_without_views.kind.has_polys() {
        SECTION_OVERHEAD + poly_record_bytes
    } else {
        0
    };
    8 + SECTION_OVERHEAD
        + head_payload(model_without_views, (1, 1)).len()
        + view_section_bytes
        + polys
        + SECTION_OVERHEAD
}

/// Tag + length + CRC bytes around every payload.
pub const SECTION_OVERHEAD: usize = 4 + 8 + 4;

/// Bytes of the VIEW section of one view (payload plus section overhead).
pub fn view_section_size(view: usize, p: &ViewParams, clusters: usize) -> Result<usize> {
    Ok(SECTION_OVERHEAD + view_payload(view, p, clusters)?.len())
}

fn index_bytes(clusters: usize) -> u8 {
    match clusters {
        0 => 0,
        1..=256 => 1,
        _ => 2,
    }
}

fn head_payload(m: &PlmcModel, tile: (usize, usize)) -> Vec<u8> {
    let mut p = vec![m.kind.code(), index_bytes(m.clusters), m.space.code(), 0];
    for v in [
        m.width,
        m.height,
        tile.0,
        tile.1,
        m.clusters,
        m.views.len(),
        m.lights.len(),
    ] {
        p.extend_from_slice(&(v as u32).to_le_bytes());
    }
    for &(t, f) in m.views.angles_deg.iter().chain(&m.lights.angles_deg) {
        p.extend_from_slice(&t.to_le_bytes());
        p.extend_from_slice(&f.to_le_bytes());
    }
    p
}

/// Bytes of the version-2 POLY payload of these polynomials (as [`poly_payload`] makes it).
pub fn poly_bytes(polys: &[Poly]) -> Result<usize> {
    Ok(poly_payload(polys)?.len())
}

/// The version-2 POLY payload: u8 coding (0 plain, 1 zlib) and the streams
/// headers ‖ q planes ‖ raw coefficients, deflated for coding 1. Headers: per polynomial i8 e and
/// i8 s (packed) or i8 −128 (raw); q planes: the low bytes of q_0 of every packed polynomial, then
/// of q_1 … q_4, then the high bytes likewise (similar bytes side by side deflate ~18 % better
/// than whole records); raw: 5 f32 per raw polynomial.
pub fn poly_payload(polys: &[Poly]) -> Result<Vec<u8>> {
    let mut head = Vec::with_capacity(2 * polys.len());
    let mut packed = Vec::with_capacity(polys.len());
    let mut raw = Vec::new();
    for a in polys {
        match polynomial::encode(a) {
            Some(q) => {
                head.push(q.e as u8);
                head.push(q.s as u8);
                packed.push(q.q);
            }
            None => {
                head.push(RAW_POLY as u8);
                a.iter()
                    .for_each(|x| raw.extend_from_slice(&x.to_le_bytes()));
            }
        }
    }
    let mut plain = head;
    for byte in 0..2 {
        for k in 0..5 {
            plain.extend(packed.iter().map(|q| q[k].to_le_bytes()[byte]));
        }
    }
    plain.extend_from_slice(&raw);
    let deflated = deflate(&plain, "polynomials")?;
    let (coding, data) = if deflated.len() < plain.len() {
        (1u8, deflated)
    } else {
        (0u8, plain)
    };
    let mut out = Vec::with_capacity(1 + data.len());
    out.push(coding);
    out.extend_from_slice(&data);
    Ok(out)
}

/// Parses a version-2 POLY payload of `n` polynomials.
fn read_poly_payload(c: &mut Cursor, n: usize) -> Result<Vec<Poly>> {
    let coding = c.u8()?;
    let rest = c.take(c.buf.len() - c.pos)?;
    let plain = match coding {
        0 => rest.to_vec(),
        1 => {
            let mut out = Vec::with_capacity(n * 12);
            flate2::read::ZlibDecoder::new(rest)
                .take(21 * n as u64 + 1)
                .read_to_end(&mut out)
                .map_err(|e| c.err(format!("polynomials do not inflate: {e}")))?;
            out
        }
        _ => return Err(c.err(format!("unknown polynomial coding {coding}"))),
    };
    let mut s = Cursor {
        buf: &plain,
        pos: 0,
        path: c.path,
        what: "POLY streams",
    };
    let mut heads = Vec::with_capacity(n);
    for _ in 0..n {
        let e = s.u8()? as i8;
        heads.push(if e == RAW_POLY {
            None
        } else {
            Some((e, s.u8()? as i8))
        });
    }
    let m = heads.iter().filter(|h| h.is_some()).count();
    let planes = s.take(10 * m)?;
    let mut out = Vec::with_capacity(n);
    let mut j = 0;
    for h in heads {
        out.push(match h {
            Some((e, sx)) => {
                let q = std::array::from_fn(|k| {
                    i16::from_le_bytes([planes[k * m + j], planes[(5 + k) * m + j]])
                });
                j += 1;
                polynomial::decode(&PackedPoly { e, s: sx, q })
                    .ok_or_else(|| s.err("packed polynomial overflows f32"))?
            }
            None => s.raw_poly()?,
        });
    }
    s.done()?;
    Ok(out)
}

fn push_lobe(p: &mut Vec<u8>, l: &PackedLobe) {
    for v in [l.rho, l.oct[0], l.oct[1], l.n] {
        p.extend_from_slice(&v.to_le_bytes());
    }
}

/// The payload of one VIEW section.
pub fn view_payload(view: usize, params: &ViewParams, clusters: usize) -> Result<Vec<u8>> {
    view_payload_version(view, params, clusters, VERSION)
}

/// Zlib-deflates `data` at the best level.
fn deflate(data: &[u8], what: &str) -> Result<Vec<u8>> {
    let mut enc = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
    enc.write_all(data)
        .map_err(|e| Error::Invalid(format!("deflating {what}: {e}")))?;
    enc.finish()
        .map_err(|e| Error::Invalid(format!("deflating {what}: {e}")))
}

fn view_payload_version(
    view: usize,
    params: &ViewParams,
    clusters: usize,
    version: u32,
) -> Result<Vec<u8>> {
    let mut p = Vec::new();
    p.extend_from_slice(&(view as u32).to_le_bytes());
    match params {
        ViewParams::Texel(lobes) => {
            p.extend_from_slice(&0u32.to_le_bytes());
            for l in lobes {
                push_lobe(&mut p, l);
            }
        }
        ViewParams::Clustered { k, table, index } => {
            p.extend_from_slice(&(*k as u32).to_le_bytes());
            let mut lobes = Vec::with_capacity(table.len() * 8);
            for l in table {
                push_lobe(&mut lobes, l);
            }
            if version == 1 {
                p.extend_from_slice(&lobes);
            } else {
                // Version 2: u8 coding (0 raw, 1 deflated byte planes), u32 n, data[n]. The
                // planes (byte b of every lobe, b = 0..8) deflate ~13 % smaller than the lobes.
                let planes: Vec<u8> = (0..8)
                    .flat_map(|b| lobes.iter().skip(b).step_by(8).copied())
                    .collect();
                let deflated = deflate(&planes, "cluster table")?;
                let (coding, data) = if deflated.len() < lobes.len() {
                    (1u8, deflated)
                } else {
                    (0u8, lobes)
                };
                p.push(coding);
                p.extend_from_slice(&(data.len() as u32).to_le_bytes());
                p.extend_from_slice(&data);
            }
            let wide = index_bytes(clusters) == 2;
            let texels = index.len() / 3;
            // Planes [channel][texel], raw and channel-delta filtered.
            let mut raw = Vec::with_capacity(index.len() * if wide { 2 } else { 1 });
            let mut filtered = Vec::with_capacity(raw.capacity());
            for c in 0..3 {
                for t in 0..texels {
                    let v = index[3 * t + c];
                    let d = if c == 0 {
                        v
                    } else {
                        v.wrapping_sub(index[3 * t + c - 1])
                    };
                    if wide {
                        raw.extend_from_slice(&v.to_le_bytes());
                        filtered.extend_from_slice(&d.to_le_bytes());
                    } else {
                        raw.push(v as u8);
                        filtered.push(d as u8);
                    }
                }
            }
            let deflated = deflate(&filtered, "index image")?;
            let (coding, data) = if deflated.len() < raw.len() {
                (1u8, deflated)
            } else {
                (0u8, raw)
            };
            p.push(coding);
            p.extend_from_slice(&(data.len() as u32).to_le_bytes());
            p.extend_from_slice(&data);
        }
    }
    Ok(p)
}

fn push_section(out: &mut Vec<u8>, tag: &[u8; 4], payload: &[u8]) {
    out.extend_from_slice(tag);
    out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(payload);
    let mut h = crc32fast::Hasher::new();
    h.update(tag);
    h.update(payload);
    out.extend_from_slice(&h.finalize().to_le_bytes());
}

/// A bounds-checked little-endian cursor whose errors name the file.
struct Cursor<'a> {
    buf: &'a [u8],
    pos: usize,
    path: &'a Path,
    what: &'static str,
}

impl<'a> Cursor<'a> {
    fn err(&self, msg: impl std::fmt::Display) -> Error {
        Error::format(
            self.path,
            format!(
                "{} (in {} at byte {}): {msg}",
                "corrupt .plmc file", self.what, self.pos
            ),
        )
    }
    fn take(&mut self, n: usize) -> Result<&'a [u8]> {
        if n > self.buf.len() - self.pos {
            return Err(self.err(format!(
                "truncated: need {n} more bytes, {} left",
                self.buf.len() - self.pos
            )));
        }
        let s = &self.buf[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    fn u8(&mut self) -> Result<u8> {
        Ok(self.take(1)?[0])
    }
    fn u16(&mut self) -> Result<u16> {
        let b = self.take(2)?;
        Ok(u16::from_le_bytes([b[0], b[1]]))
    }
    fn u32(&mut self) -> Result<u32> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    fn u64(&mut self) -> Result<u64> {
        let b = self.take(8)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(u64::from_le_bytes(a))
    }
    fn f32(&mut self) -> Result<f32> {
        Ok(f32::from_bits(self.u32()?))
    }
    /// Five f32 coefficients, all finite.
    fn raw_poly(&mut self) -> Result<Poly> {
        let mut a = [0f32; 5];
        for x in a.iter_mut() {
            *x = self.f32()?;
            if !x.is_finite() {
                return Err(self.err("non-finite polynomial coefficient"));
            }
        }
        Ok(a)
    }
    fn lobe(&mut self) -> Result<PackedLobe> {
        let l = PackedLobe {
            rho: self.u16()?,
            oct: [self.u16()?, self.u16()?],
            n: self.u16()?,
        };
        if !l.is_valid() {
            return Err(self.err("lobe parameter is not a finite non-negative number"));
        }
        Ok(l)
    }
    fn done(&self) -> Result<()> {
        if self.pos != self.buf.len() {
            return Err(self.err(format!(
                "{} unexpected trailing bytes",
                self.buf.len() - self.pos
            )));
        }
        Ok(())
    }
}

/// Reads the next section: (tag, payload), verifying length bounds and the CRC.
fn next_section<'a>(c: &mut Cursor<'a>) -> Result<([u8; 4], &'a [u8])> {
    c.what = "section header";
    let tag: [u8; 4] = c.take(4)?.try_into().map_err(|_| c.err("bad tag"))?;
    let len = c.u64()?;
    if len > (c.buf.len() - c.pos) as u64 {
        return Err(c.err(format!(
            "section '{}' claims {len} bytes but only {} remain (truncated file?)",
            String::from_utf8_lossy(&tag),
            c.buf.len() - c.pos
        )));
    }
    let payload = c.take(len as usize)?;
    let crc = c.u32()?;
    let mut h = crc32fast::Hasher::new();
    h.update(&tag);
    h.update(payload);
    if h.finalize() != crc {
        return Err(c.err(format!(
            "CRC32 mismatch in section '{}' (the file is corrupt)",
            String::from_utf8_lossy(&tag)
        )));
    }
    Ok((tag, payload))
}

fn read_dirs(c: &mut Cursor, n: usize) -> Result<DirectionSet> {
    let mut a = Vec::with_capacity(n);
    for _ in 0..n {
        let (t, f) = (c.f32()?, c.f32()?);
        if !(0.0..=90.0).contains(&t) || !f.is_finite() {
            return Err(c.err(format!(
                "direction (θ={t}, φ={f}) is not on the upper hemisphere"
            )));
        }
        a.push((t, f));
    }
    Ok(DirectionSet::from_angles_deg(a))
}

/// Parses and validates a model from bytes; `path` is only used in error messages.
pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<PlmcModel> {
    Ok(from_bytes_tiled(bytes, path)?.0)
}

/// [`from_bytes`], also returning the TILE section if present.
pub fn from_bytes_tiled(bytes: &[u8], path: &Path) -> Result<(PlmcModel, Option<TileSection>)> {
    let mut c = Cursor {
        buf: bytes,
        pos: 0,
        path,
        what: "file header",
    };
    if c.take(4).ok() != Some(MAGIC.as_slice()) {
        return Err(Error::format(
            path,
            "not a .plmc file (missing 'PLMC' magic)",
        ));
    }
    let version = c.u32()?;
    if version != 1 && version != VERSION {
        return Err(c.err(format!(
            "unsupported format version {version} (this build reads 1..={VERSION})"
        )));
    }
    let (tag, head) = next_section(&mut c)?;
    if &tag != b"HEAD" {
        return Err(c.err("first section is not HEAD"));
    }
    let mut h = Cursor {
        buf: head,
        pos: 0,
        path,
        what: "HEAD",
    };
    let kind = ModelKind::from_code(h.u8()?).ok_or_else(|| h.err("unknown model kind"))?;
    let ib = h.u8()?;
    let space = ValueSpace::from_code(h.u8()?).ok_or_else(|| h.err("unknown value space"))?;
    if h.u8()? != 0 {
        return Err(h.err("reserved header byte is not 0"));
    }
    let mut dims = [0usize; 7];
    for d in dims.iter_mut() {
        *d = h.u32()? as usize;
    }
    let [width, height, tile_w, tile_h, clusters, nv, nl] = dims;
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
    let views = read_dirs(&mut h, nv)?;
    let lights = read_dirs(&mut h, nl)?;
    h.done()?;
    // Planes must be representable by the file: 24 bytes per texel for per-texel lobes, and
    // deflate cannot expand more than ~1032:1 for index images.
    let limit = bytes
        .len()
        .saturating_mul(if kind == ModelKind::PlmC { 1100 } else { 1 });
    let texels = width
        .checked_mul(height)
        .filter(|t| {
            t.checked_mul(if kind == ModelKind::PlmC { 3 } else { 24 })
                .is_some_and(|b| b <= limit)
        })
        .ok_or_else(|| {
            c.err(format!(
                "{width}×{height} texels cannot fit in a {} byte file",
                bytes.len()
            ))
        })?;

    let mut params = Vec::with_capacity(nv);
    for v in 0..nv {
        let (tag, payload) = next_section(&mut c)?;
        if &tag != b"VIEW" {
            return Err(c.err(format!(
                "expected VIEW section {v}, found '{}'",
                String::from_utf8_lossy(&tag)
            )));
        }
        let mut s = Cursor {
            buf: payload,
            pos: 0,
            path,
            what: "VIEW",
        };
        let idx = s.u32()? as usize;
        if idx != v {
            return Err(s.err(format!("view section {v} is labelled {idx}")));
        }
        let k = s.u32()? as usize;
        if kind == ModelKind::PlmC {
            if k == 0 || k > clusters {
                return Err(s.err(format!(
                    "view {v} has {k} clusters (1..={clusters} allowed)"
                )));
            }
            let table = if version == 1 {
                (0..3 * k).map(|_| s.lobe()).collect::<Result<Vec<_>>>()?
            } else {
                let coding = s.u8()?;
                let n = s.u32()? as usize;
                let data = s.take(n)?;
                let lobes = match coding {
                    0 => data.to_vec(),
                    1 => {
                        let mut planes = Vec::with_capacity(24 * k);
                        flate2::read::ZlibDecoder::new(data)
                            .take(24 * k as u64 + 1)
                            .read_to_end(&mut planes)
                            .map_err(|e| {
                                s.err(format!("view {v}: cluster table does not inflate: {e}"))
                            })?;
                        if planes.len() != 24 * k {
                            return Err(s.err(format!(
                                "view {v}: cluster table has {} bytes, expected {}",
                                planes.len(),
                                24 * k
                            )));
                        }
                        (0..24 * k)
                            .map(|i| planes[(i % 8) * 3 * k + i / 8])
                            .collect()
                    }
                    _ => return Err(s.err(format!("view {v}: unknown table coding {coding}"))),
                };
                if lobes.len() != 24 * k {
                    return Err(s.err(format!(
                        "view {v}: raw cluster table is {} bytes",
                        lobes.len()
                    )));
                }
                let mut t = Cursor {
                    buf: &lobes,
                    pos: 0,
                    path,
                    what: "VIEW table",
                };
                (0..3 * k).map(|_| t.lobe()).collect::<Result<Vec<_>>>()?
            };
            let coding = s.u8()?;
            let n = s.u32()? as usize;
            let data = s.take(n)?;
            s.done()?;
            let wide = ib == 2;
            let plane_bytes = texels * 3 * if wide { 2 } else { 1 };
            let planes = match coding {
                0 => data.to_vec(),
                1 => {
                    let mut out = Vec::with_capacity(plane_bytes);
                    flate2::read::ZlibDecoder::new(data)
                        .take(plane_bytes as u64 + 1)
                        .read_to_end(&mut out)
                        .map_err(|e| {
                            s.err(format!("view {v}: index image does not inflate: {e}"))
                        })?;
                    out
                }
                _ => return Err(s.err(format!("view {v}: unknown index coding {coding}"))),
            };
            if planes.len() != plane_bytes {
                return Err(s.err(format!(
                    "view {v}: index image has {} bytes, expected {plane_bytes}",
                    planes.len()
                )));
            }
            let mut index = vec![0u16; texels * 3];
            for ch in 0..3 {
                for t in 0..texels {
                    let o = ch * texels + t;
                    let d = if wide {
                        u16::from_le_bytes([planes[2 * o], planes[2 * o + 1]])
                    } else {
                        planes[o] as u16
                    };
                    index[3 * t + ch] = match (coding, ch) {
                        (0, _) | (_, 0) => d,
                        _ if wide => d.wrapping_add(index[3 * t + ch - 1]),
                        _ => (d as u8).wrapping_add(index[3 * t + ch - 1] as u8) as u16,
                    };
                    if index[3 * t + ch] as usize >= k {
                        return Err(s.err(format!(
                            "view {v}: cluster index {} ≥ {k}",
                            index[3 * t + ch]
                        )));
                    }
                }
            }
            params.push(ViewParams::Clustered { k, table, index });
        } else {
            if k != 0 {
                return Err(s.err(format!("view {v}: clusters in a {} model", kind.name())));
            }
            if payload.len() != 8 + texels * 3 * 8 {
                return Err(s.err(format!(
                    "view {v}: {} bytes, expected {}",
                    payload.len(),
                    8 + texels * 24
                )));
            }
            let lobes = (0..3 * texels)
                .map(|_| s.lobe())
                .collect::<Result<Vec<_>>>()?;
            s.done()?;
            params.push(ViewParams::Texel(lobes));
        }
    }
    let mut polys = Vec::new();
    if kind.has_polys() {
        let (tag, payload) = next_section(&mut c)?;
        if &tag != b"POLY" {
            return Err(c.err("missing POLY section"));
        }
        let n = nv * nl * 3;
        let mut s = Cursor {
            buf: payload,
            pos: 0,
            path,
            what: "POLY",
        };
        if version == 1 {
            if payload.len() != n * 20 {
                return Err(c.err(format!(
                    "POLY has {} bytes, expected {}",
                    payload.len(),
                    n * 20
                )));
            }
            polys.reserve(n);
            for _ in 0..n {
                polys.push(s.raw_poly()?);
            }
            s.done()?;
        } else {
            polys = read_poly_payload(&mut s, n)?;
        }
    }
    let (mut tag, mut payload) = next_section(&mut c)?;
    let mut tile = None;
    if &tag == b"TILE" {
        tile = Some(TileSection {
            tile_w,
            tile_h,
            payload: payload.to_vec(),
        });
        (tag, payload) = next_section(&mut c)?;
    }
    if &tag != b"END!" || !payload.is_empty() {
        return Err(c.err("missing END! section"));
    }
    c.what = "end of file";
    c.done()?;
    let model = PlmcModel {
        kind,
        views,
        lights,
        width,
        height,
        clusters,
        space,
        params,
        polys,
    };
    model
        .validate()
        .map_err(|e| Error::format(path, e.to_string()))?;
    Ok((model, tile))
}

/// Magic of a resumable-fit part file (one finished view, see `fit::pipeline`).
pub const PART_MAGIC: &[u8; 4] = b"PLMP";

/// Serialises one finished view of a fit in progress: magic, the fit's fingerprint, the view
/// index, then a complete one-view `.plmc` (so the same CRC-checked code reads it back).
pub fn part_to_bytes(fingerprint: u64, view: usize, one_view: &PlmcModel) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    out.extend_from_slice(PART_MAGIC);
    out.extend_from_slice(&fingerprint.to_le_bytes());
    out.extend_from_slice(&(view as u32).to_le_bytes());
    out.extend_from_slice(&to_bytes(one_view)?);
    Ok(out)
}

/// Reads a part written by [`part_to_bytes`]; `Ok(None)` if it belongs to another fit (different
/// fingerprint or view), an error if it is corrupt.
pub fn part_from_bytes(
    bytes: &[u8],
    path: &Path,
    fingerprint: u64,
    view: usize,
) -> Result<Option<PlmcModel>> {
    if bytes.len() < 16 || &bytes[..4] != PART_MAGIC {
        return Err(Error::format(
            path,
            "not a fit part file (missing 'PLMP' magic)",
        ));
    }
    let fp = u64::from_le_bytes(
        bytes[4..12]
            .try_into()
            .map_err(|_| Error::format(path, "short part header"))?,
    );
    let v = u32::from_le_bytes(
        bytes[12..16]
            .try_into()
            .map_err(|_| Error::format(path, "short part header"))?,
    );
    if fp != fingerprint || v as usize != view {
        return Ok(None);
    }
    from_bytes(&bytes[16..], path).map(Some)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::lafortune::Lobe;
    use crate::math::Pcg32;

    fn model(kind: ModelKind, clusters: usize) -> PlmcModel {
        let mut rng = Pcg32::new(4, 4);
        let views = DirectionSet::from_rings(&[(0.0, 1, 0.0), (45.0, 3, 0.0)]);
        let lights = DirectionSet::from_rings(&[(0.0, 1, 0.0), (30.0, 4, 0.0), (60.0, 4, 0.0)]);
        let (w, h) = (5, 3);
        let lobe = |rng: &mut Pcg32| {
            let l: Lobe = [
                rng.next_f32(),
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
                1.0,
                1.0 + 20.0 * rng.next_f32(),
            ];
            PackedLobe::pack(&l)
        };
        let params = (0..views.len())
            .map(|_| match kind {
                ModelKind::PlmC => {
                    let k = clusters.min(7);
                    ViewParams::Clustered {
                        k,
                        table: (0..3 * k).map(|_| lobe(&mut rng)).collect(),
                        index: (0..w * h * 3)
                            .map(|_| rng.next_below(k as u32) as u16)
                            .collect(),
                    }
                }
                _ => ViewParams::Texel((0..w * h * 3).map(|_| lobe(&mut rng)).collect()),
            })
            .collect();
        let polys = if kind.has_polys() {
            (0..views.len() * lights.len() * 3)
                .map(|_| [rng.next_f32(), 1.0, -0.5, 0.25, 1e-3])
                .collect()
        } else {
            Vec::new()
        };
        PlmcModel {
            kind,
            views,
            lights,
            width: w,
            height: h,
            clusters,
            space: if kind == ModelKind::Plm {
                ValueSpace::Srgb
            } else {
                ValueSpace::Linear
            },
            params,
            polys,
        }
    }

    #[test]
    fn round_trip_is_bit_exact_for_every_kind() {
        let dir = tempfile::tempdir().unwrap();
        for (kind, k) in [
            (ModelKind::Lm, 0),
            (ModelKind::Plm, 0),
            (ModelKind::PlmC, 7),
            (ModelKind::PlmC, 300),
        ] {
            let m = model(kind, k);
            let p = dir.path().join(format!("{}-{k}.plmc", kind.name()));
            write(&p, &m).unwrap();
            let r = read(&p).unwrap();
            assert_eq!(r, m);
            assert_eq!(to_bytes(&r).unwrap(), std::fs::read(&p).unwrap());
        }
    }

    #[test]
    fn version_1_files_are_read_and_snapped_polynomials_take_12_bytes() {
        let mut m = model(ModelKind::PlmC, 7);
        let p = Path::new("old.plmc");
        let v1 = to_bytes_version(&m, None, 1).unwrap();
        assert_eq!(v1[4..8], 1u32.to_le_bytes());
        assert_eq!(from_bytes(&v1, p).unwrap(), m);
        // Arbitrary coefficients have no packed form: f32 records keep them exact.
        let raw = to_bytes(&m).unwrap();
        assert_eq!(from_bytes(&raw, p).unwrap(), m);
        assert!(m.polys.iter().all(|a| polynomial::encode(a).is_none()));
        // Mappings as the fitter leaves them (snapped) are packed, and still exact.
        let mut rng = Pcg32::new(2, 2);
        for a in m.polys.iter_mut() {
            let x: Vec<f32> = (0..100).map(|i| i as f32 / 99.0).collect();
            let g = 0.5 + rng.next_f32();
            let y: Vec<f32> = x.iter().map(|&v| 0.9 * v.powf(g) + 0.02).collect();
            *a = polynomial::fit_pairs_in(&x, &y, 1.0);
        }
        let packed = to_bytes(&m).unwrap();
        assert_eq!(from_bytes(&packed, p).unwrap(), m);
        assert!(m.polys.iter().all(|a| polynomial::encode(a).is_some()));
        assert!(poly_bytes(&m.polys).unwrap() <= 1 + 12 * m.polys.len());
        let mut future = packed.clone();
        future[4] = 3;
        let e = from_bytes(&future, p).unwrap_err().to_string();
        assert!(e.contains("version 3") && e.contains("old.plmc"), "{e}");
    }

    #[test]
    fn tile_sections_round_trip_and_tile_sizes_must_divide_the_planes() {
        let mut m = model(ModelKind::PlmC, 7);
        let t = TileSection {
            tile_w: 5,
            tile_h: 1,
            payload: vec![1, 2, 3],
        };
        let bytes = to_bytes_tiled(&m, Some(&t)).unwrap();
        let p = Path::new("tiled.plmc");
        assert_eq!(from_bytes_tiled(&bytes, p).unwrap(), (m.clone(), Some(t)));
        assert_eq!(from_bytes(&bytes, p).unwrap(), m);
        assert_eq!(from_bytes_tiled(&to_bytes(&m).unwrap(), p).unwrap().1, None);
        let bad = TileSection {
            tile_w: 2,
            tile_h: 3,
            payload: Vec::new(),
        };
        assert!(to_bytes_tiled(&m, Some(&bad)).is_err());
        m.kind = ModelKind::Lm;
        assert!(to_bytes_tiled(&m, Some(&bad)).is_err());
    }

    #[test]
    fn corrupt_and_truncated_files_give_clear_errors() {
        let m = model(ModelKind::PlmC, 7);
        let bytes = to_bytes(&m).unwrap();
        let p = Path::new("mat.plmc");
        // Every single-byte flip after the magic is caught (CRC or structural check).
        for i in 4..bytes.len() {
            let mut b = bytes.clone();
            b[i] ^= 0x41;
            let e = from_bytes(&b, p).expect_err("corruption not detected");
            assert!(e.to_string().contains("mat.plmc"), "{e}");
        }
        for cut in [0, 3, 10, 40, bytes.len() / 2, bytes.len() - 1] {
            let e = from_bytes(&bytes[..cut], p).unwrap_err().to_string();
            assert!(e.contains("mat.plmc"), "{e}");
        }
        let mut b = bytes.clone();
        b[30] ^= 1;
        assert!(from_bytes(&b, p).unwrap_err().to_string().contains("CRC"));
        let e = from_bytes(&bytes[..bytes.len() - 10], p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("truncated") || e.contains("remain"), "{e}");
        assert!(
            read(Path::new("/nonexistent/x.plmc"))
                .unwrap_err()
                .to_string()
                .contains("x.plmc")
        );
    }
}
