//! `.btfc`, our fast binary BTF cache: a small checked header, the f16 payload in
//! `[view][light][row][col][rgb]` order (memory-mapped on open, never copied), and a trailer with
//! one CRC32 per view.
//!
//! Layout (all little-endian):
//! ```text
//! 0   magic "BTFC"          4   u32 version (1)       8   u32 encoding (0 = sRGB8, 1 = linear)
//! 12  u32 width             16  u32 height            20  u32 views   24 u32 lights
//! 28  u32 flags (0)         32  u64 payload offset (multiple of 64)
//! 40  views × (f32 θ°, f32 φ°), lights × (f32 θ°, f32 φ°), u32 CRC32 of bytes 0..here
//!     zero padding up to the payload offset
//! payload: views·lights·height·width·3 × f16
//! trailer: views × u32 CRC32 of each view's payload bytes, u32 CRC32 of that table
//! ```
//! The file length must match exactly. Files are written atomically ([`crate::io::write_atomic`]).

use super::{BtfSource, DirectionSet, RawBtf, StoredEncoding};
use crate::io::bytes::{Reader, Writer};
use crate::io::write_atomic;
use crate::{Error, Result};
use half::f16;
use rayon::prelude::*;
use std::path::Path;

/// File signature of a `.btfc` cache.
pub const MAGIC: &[u8; 4] = b"BTFC";
/// Current format version.
pub const VERSION: u32 = 1;
/// Upper bound on direction counts accepted from a header (UBO2014 has 151).
const MAX_DIRECTIONS: u64 = 1 << 16;
const FIXED_HEADER: usize = 40;
const ALIGN: usize = 64;

fn encoding_code(e: StoredEncoding) -> u32 {
    match e {
        StoredEncoding::Srgb8 => 0,
        StoredEncoding::Linear => 1,
    }
}

fn header_len(views: usize, lights: usize) -> usize {
    FIXED_HEADER + 8 * (views + lights) + 4
}

fn payload_offset(views: usize, lights: usize) -> usize {
    header_len(views, lights).div_ceil(ALIGN) * ALIGN
}

fn f16_bytes(values: &[f16]) -> std::borrow::Cow<'_, [u8]> {
    if cfg!(target_endian = "little") {
        std::borrow::Cow::Borrowed(bytemuck::cast_slice(values))
    } else {
        std::borrow::Cow::Owned(values.iter().flat_map(|v| v.to_le_bytes()).collect())
    }
}

/// Writes any BTF source as a `.btfc` cache, one view at a time (memory use: one view).
pub fn write_cache(src: &(dyn BtfSource + '_), path: &Path) -> Result<()> {
    let (nv, nl) = (src.views().len(), src.lights().len());
    let (w, h) = (src.width(), src.height());
    let per_view = nl * w * h * 3;
    let dims_u32 = [w, h, nv, nl].map(|d| u32::try_from(d).ok());
    if dims_u32.iter().any(|d| d.is_none()) || nv == 0 || nl == 0 || w == 0 || h == 0 {
        return Err(Error::format(
            path,
            "BTF dimensions cannot be stored in a .btfc cache",
        ));
    }
    let offset = payload_offset(nv, nl);
    let mut w8 = Writer::new();
    w8.bytes(MAGIC);
    for v in [
        VERSION,
        encoding_code(src.encoding()),
        w as u32,
        h as u32,
        nv as u32,
        nl as u32,
        0,
    ] {
        w8.u32(v);
    }
    w8.u64(offset as u64);
    for set in [src.views(), src.lights()] {
        for &(t, p) in &set.angles_deg {
            w8.f32(t).f32(p);
        }
    }
    let crc = crc32fast::hash(w8.as_bytes());
    w8.u32(crc);
    let mut head = w8.into_bytes();
    head.resize(offset, 0);
    write_atomic(path, |out| {
        out.write_all(&head).map_err(|e| Error::io(path, e))?;
        let mut crcs = Vec::with_capacity(nv);
        let mut buf = vec![f16::ZERO; per_view];
        for view in 0..nv {
            let vals = src.load_view(view)?;
            if vals.len() != per_view {
                return Err(Error::Invalid(format!(
                    "view {view} has {} values, expected {per_view}",
                    vals.len()
                )));
            }
            buf.par_iter_mut()
                .zip(vals.par_iter())
                .for_each(|(o, v)| *o = f16::from_f32(*v));
            let bytes = f16_bytes(&buf);
            crcs.push(crc32fast::hash(&bytes));
            out.write_all(&bytes).map_err(|e| Error::io(path, e))?;
        }
        let mut table = Writer::new();
        crcs.iter().for_each(|&c| {
            table.u32(c);
        });
        let crc = crc32fast::hash(table.as_bytes());
        table.u32(crc);
        out.write_all(table.as_bytes())
            .map_err(|e| Error::io(path, e))
    })
}

/// Parsed, validated `.btfc` header.
#[derive(Clone, Debug)]
pub struct CacheHeader {
    /// View directions.
    pub views: DirectionSet,
    /// Light directions.
    pub lights: DirectionSet,
    /// Texels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Encoding of the source data.
    pub encoding: StoredEncoding,
    /// Byte offset of the f16 payload.
    pub payload_offset: usize,
}

impl CacheHeader {
    /// Number of f16 values in the payload.
    pub fn values(&self) -> usize {
        self.views.len() * self.lights.len() * self.width * self.height * 3
    }
}

/// The little-endian u32 at `at` of `b`, a range the caller checked against the file length.
fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

/// Parses and checks the header and overall file length of a `.btfc` image in `bytes`.
pub fn parse_header(path: &Path, bytes: &[u8]) -> Result<CacheHeader> {
    let bad = |msg: String| Error::format(path, msg);
    if bytes.len() < FIXED_HEADER || &bytes[0..4] != MAGIC {
        return Err(bad("not a .btfc cache (bad signature or too short)".into()));
    }
    let mut r = Reader::new(bytes, path, "corrupt .btfc cache");
    r.set_part("header");
    r.seek(4)?;
    let version = r.u32("version")?;
    if version != VERSION {
        return Err(bad(format!(
            "unsupported .btfc version {version} (expected {VERSION})"
        )));
    }
    let encoding = match r.u32("encoding")? {
        0 => StoredEncoding::Srgb8,
        1 => StoredEncoding::Linear,
        e => return Err(bad(format!("unknown encoding code {e}"))),
    };
    let (w, h, nv, nl) = (
        r.u32("width")? as u64,
        r.u32("height")? as u64,
        r.u32("view count")? as u64,
        r.u32("light count")? as u64,
    );
    if nv == 0 || nl == 0 || nv > MAX_DIRECTIONS || nl > MAX_DIRECTIONS || w == 0 || h == 0 {
        return Err(bad(format!(
            "implausible dimensions: {nv} views, {nl} lights, {w}×{h} texels"
        )));
    }
    let hl = header_len(nv as usize, nl as usize);
    if bytes.len() < hl {
        return Err(bad(format!(
            "truncated header ({} of {hl} bytes)",
            bytes.len()
        )));
    }
    let stored_crc = u32_at(bytes, hl - 4);
    if crc32fast::hash(&bytes[..hl - 4]) != stored_crc {
        return Err(bad("header checksum mismatch (corrupt file)".into()));
    }
    r.u32("reserved")?;
    let offset = r.u64("payload offset")?;
    if offset != payload_offset(nv as usize, nl as usize) as u64 {
        return Err(bad(format!("unexpected payload offset {offset}")));
    }
    // Checked: the four u32 dimensions of a corrupt header can overflow u64 (fuzz finding).
    let sizes = [nv, nl, w, h, 3]
        .iter()
        .try_fold(1u64, |a, &b| a.checked_mul(b))
        .and_then(|values| values.checked_mul(2)?.checked_add(offset + 4 * nv + 4));
    let Some(expected) = sizes.filter(|&e| e <= isize::MAX as u64) else {
        return Err(bad(format!(
            "implausible dimensions: {nv} views × {nl} lights × {w}×{h} texels overflow the file size"
        )));
    };
    if bytes.len() as u64 != expected {
        return Err(bad(format!(
            "file is {} bytes, expected {expected} for {nv} views × {nl} lights × {w}×{h} texels (truncated or trailing data)",
            bytes.len()
        )));
    }
    r.seek(FIXED_HEADER)?;
    let mut read_set = |n: u64, field: &str| -> Result<DirectionSet> {
        let angles = (0..n)
            .map(|_| Ok((r.f32(field)?, r.f32(field)?)))
            .collect::<Result<Vec<_>>>()?;
        Ok(DirectionSet::from_angles_deg(angles))
    };
    let views = read_set(nv, "view directions")?;
    let lights = read_set(nl, "light directions")?;
    Ok(CacheHeader {
        views,
        lights,
        width: w as usize,
        height: h as usize,
        encoding,
        payload_offset: offset as usize,
    })
}

/// Checks the trailer and every view's CRC (in parallel); errors name the first corrupt view.
fn verify_payload(path: &Path, bytes: &[u8], hdr: &CacheHeader) -> Result<()> {
    let nv = hdr.views.len();
    let per_view = 2 * hdr.values() / nv;
    let trailer = hdr.payload_offset + 2 * hdr.values();
    let table = &bytes[trailer..trailer + 4 * nv];
    if crc32fast::hash(table) != u32_at(bytes, trailer + 4 * nv) {
        return Err(Error::format(path, "checksum table is corrupt"));
    }
    let bad = (0..nv).into_par_iter().find_first(|&v| {
        let start = hdr.payload_offset + v * per_view;
        crc32fast::hash(&bytes[start..start + per_view]) != u32_at(table, 4 * v)
    });
    match bad {
        Some(v) => Err(Error::format(
            path,
            format!("checksum mismatch in the data of view {v} (corrupt file)"),
        )),
        None => Ok(()),
    }
}

/// Opens a `.btfc` cache as a [`RawBtf`] backed by a read-only memory map, after checking the
/// header, the exact file length and every view's CRC32. The file must not be modified while open.
pub fn load_cache(path: &Path) -> Result<RawBtf> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    // SAFETY: the map is read-only and private to this process; as for any mmap, another process
    // truncating the file while it is mapped would fault (documented above).
    let map = unsafe { memmap2::Mmap::map(&file) }.map_err(|e| Error::io(path, e))?;
    let hdr = parse_header(path, &map)?;
    verify_payload(path, &map, &hdr)?;
    #[cfg(target_endian = "little")]
    {
        RawBtf::from_mapped(
            hdr.views,
            hdr.lights,
            hdr.width,
            hdr.height,
            hdr.encoding,
            std::sync::Arc::new(map),
            hdr.payload_offset,
        )
    }
    #[cfg(target_endian = "big")]
    {
        let bytes = &map[hdr.payload_offset..hdr.payload_offset + 2 * hdr.values()];
        let data = bytes
            .chunks_exact(2)
            .map(|c| f16::from_le_bytes([c[0], c[1]]))
            .collect();
        RawBtf::from_f16(
            hdr.views,
            hdr.lights,
            hdr.width,
            hdr.height,
            hdr.encoding,
            data,
        )
    }
}

/// Writes an in-memory BTF as a `.btfc` cache (values are already f16, so this is lossless).
pub fn write_raw(btf: &RawBtf, path: &Path) -> Result<()> {
    write_cache(btf, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> RawBtf {
        let views = DirectionSet::from_angles_deg(vec![(0.0, 0.0), (30.0, 90.0), (60.0, 200.0)]);
        let lights = DirectionSet::from_angles_deg(vec![(0.0, 0.0), (45.0, 10.0)]);
        let n = 3 * 2 * 4 * 5 * 3;
        let data: Vec<f32> = (0..n)
            .map(|i| (i as f32 * 0.37).sin().abs() * 3.0)
            .collect();
        RawBtf::from_f32(views, lights, 4, 5, StoredEncoding::Srgb8, &data).unwrap()
    }

    #[test]
    fn round_trip_is_exact_and_mapped() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.btfc");
        let btf = sample();
        write_raw(&btf, &p).unwrap();
        let back = load_cache(&p).unwrap();
        assert!(back.is_mapped() || cfg!(target_endian = "big"));
        assert_eq!(back.data(), btf.data());
        assert_eq!(back.views(), btf.views());
        assert_eq!(back.lights(), btf.lights());
        assert_eq!((back.width(), back.height()), (4, 5));
        assert_eq!(back.encoding(), StoredEncoding::Srgb8);
        assert_eq!(back.load_view(2).unwrap(), btf.load_view(2).unwrap());
        assert_eq!(back.texel(1, 1, 3, 4), btf.texel(1, 1, 3, 4));
    }

    #[test]
    fn truncated_corrupt_and_foreign_files_are_clear_errors() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.btfc");
        write_raw(&sample(), &p).unwrap();
        let good = std::fs::read(&p).unwrap();
        let q = dir.path().join("bad.btfc");
        let check = |bytes: &[u8], needle: &str| {
            std::fs::write(&q, bytes).unwrap();
            let e = load_cache(&q).unwrap_err().to_string();
            assert!(e.contains("bad.btfc") && e.contains(needle), "{e}");
        };
        check(&good[..good.len() - 1], "expected");
        check(&good[..20], "too short");
        check(
            b"PLMC and more bytes than the fixed header of forty bytes",
            "signature",
        );
        let mut flipped = good.clone();
        flipped[12] ^= 1; // width
        check(&flipped, "checksum");
        let mut payload = good.clone();
        let off = payload_offset(3, 2);
        let per_view = 2 * 2 * 4 * 5 * 3;
        payload[off + per_view + 7] ^= 0x40; // inside view 1
        check(&payload, "view 1");
        let mut huge = good.clone();
        huge[20..24].copy_from_slice(&u32::MAX.to_le_bytes());
        check(&huge, "implausible");
        let mut long = good.clone();
        long.push(0);
        check(&long, "trailing");
    }
}
