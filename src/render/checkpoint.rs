//! Checkpoints: the exact accumulator state of a render (f64 sums per pixel and per-tile
//! sample counts), written atomically, so a resumed render is bit-identical to an uninterrupted
//! one. Layout (little-endian): magic `BTFPTCK1`, u32 version, u64 fingerprint of the scene and
//! options, the settings, u32 tile count, per tile (x0, y0, w, h, done: u32; rays, invalid: u64;
//! sums and sums of squares: 6·w·h f64), then a CRC32 of everything before it.
//! Renders with a reconstruction filter other than the radius-½ box write version 2: the filter
//! (kind code, radius, two parameters: u32 + 3 f32) after the settings, and per tile the
//! bordered buffers (w + 2b)(h + 2b) of sums, sums of squares, Σ w²L, Σ w and Σ w².

use super::film::{RenderSettings, RenderState, Tile};
use super::filter::{Filter, FilterKind};
use crate::io::write_atomic;
use crate::{Error, Result};
use std::path::Path;

const MAGIC: &[u8; 8] = b"BTFPTCK1";
const VERSION: u32 = 1;
const VERSION_FILTERED: u32 = 2;

/// The filter as (kind code, radius, p1, p2) for the checkpoint header.
fn filter_code(f: &Filter) -> (u32, [f32; 3]) {
    match f.kind {
        FilterKind::Box => (0, [f.radius, 0.0, 0.0]),
        FilterKind::Tent => (1, [f.radius, 0.0, 0.0]),
        FilterKind::Gaussian { alpha, bias } => (2, [f.radius, alpha, bias]),
        FilterKind::Mitchell { b, c } => (3, [f.radius, b, c]),
        FilterKind::Lanczos => (4, [f.radius, 0.0, 0.0]),
    }
}

/// Writes `state` to `path` atomically; `fingerprint` identifies the scene and options.
pub fn save(path: &Path, state: &RenderState, fingerprint: u64) -> Result<()> {
    let s = &state.settings;
    let mut b = Vec::with_capacity(
        64 + state
            .tiles
            .iter()
            .map(|t| 40 + 48 * t.sum.len())
            .sum::<usize>(),
    );
    let filtered = !state.filter.is_box();
    b.extend_from_slice(MAGIC);
    let version = if filtered { VERSION_FILTERED } else { VERSION };
    b.extend_from_slice(&version.to_le_bytes());
    b.extend_from_slice(&fingerprint.to_le_bytes());
    for v in [
        s.width, s.height, s.crop[0], s.crop[1], s.crop[2], s.crop[3],
    ] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b.extend_from_slice(&s.spp_begin.to_le_bytes());
    b.extend_from_slice(&s.spp_end.to_le_bytes());
    b.extend_from_slice(&s.seed.to_le_bytes());
    if filtered {
        let (code, p) = filter_code(&state.filter);
        b.extend_from_slice(&code.to_le_bytes());
        for v in p {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    b.extend_from_slice(&(state.tiles.len() as u32).to_le_bytes());
    for t in &state.tiles {
        for v in [t.x0, t.y0, t.w, t.h, t.done] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b.extend_from_slice(&t.rays.to_le_bytes());
        b.extend_from_slice(&t.invalid.to_le_bytes());
        for px in t.sum.iter().chain(&t.sum2).chain(&t.sum_w2) {
            for v in px {
                b.extend_from_slice(&v.to_le_bytes());
            }
        }
        for v in t.weight.iter().chain(&t.weight2) {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    let crc = crc32fast::hash(&b);
    b.extend_from_slice(&crc.to_le_bytes());
    write_atomic(path, |w| w.write_all(&b).map_err(|e| Error::io(path, e)))
}

struct Reader<'a> {
    b: &'a [u8],
    pos: usize,
    path: &'a Path,
}

impl Reader<'_> {
    fn take<const N: usize>(&mut self) -> Result<[u8; N]> {
        let end = self.pos + N;
        let s = self
            .b
            .get(self.pos..end)
            .ok_or_else(|| Error::format(self.path, "checkpoint is truncated"))?;
        self.pos = end;
        let mut a = [0u8; N];
        a.copy_from_slice(s);
        Ok(a)
    }
    fn u32(&mut self) -> Result<u32> {
        Ok(u32::from_le_bytes(self.take()?))
    }
    fn u64(&mut self) -> Result<u64> {
        Ok(u64::from_le_bytes(self.take()?))
    }
    fn f32(&mut self) -> Result<f32> {
        Ok(f32::from_le_bytes(self.take()?))
    }
    fn f64(&mut self) -> Result<f64> {
        Ok(f64::from_le_bytes(self.take()?))
    }
}

/// Reads a box-filtered checkpoint and checks that it belongs to `expected` settings and
/// `fingerprint`.
pub fn load(path: &Path, expected: &RenderSettings, fingerprint: u64) -> Result<RenderState> {
    load_filtered(path, expected, &Filter::BOX, fingerprint)
}

/// Reads a checkpoint and checks that it belongs to `expected` settings, `filter` and
/// `fingerprint`.
pub fn load_filtered(
    path: &Path,
    expected: &RenderSettings,
    filter: &Filter,
    fingerprint: u64,
) -> Result<RenderState> {
    let b = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    if b.len() < 12 || &b[..8] != MAGIC {
        return Err(Error::format(path, "not a btfpt checkpoint"));
    }
    let (body, crc) = b.split_at(b.len() - 4);
    let crc = u32::from_le_bytes([crc[0], crc[1], crc[2], crc[3]]);
    if crc32fast::hash(body) != crc {
        return Err(Error::format(path, "checkpoint is corrupt (CRC mismatch)"));
    }
    let mut r = Reader {
        b: body,
        pos: 8,
        path,
    };
    let version = r.u32()?;
    let want = if filter.is_box() {
        VERSION
    } else {
        VERSION_FILTERED
    };
    if version != want {
        return Err(Error::format(
            path,
            format!(
                "checkpoint version {version} does not fit this render (expected {want}: {})",
                if filter.is_box() {
                    "box filter"
                } else {
                    "reconstruction filter"
                }
            ),
        ));
    }
    if r.u64()? != fingerprint {
        return Err(Error::format(
            path,
            "checkpoint was written for a different scene or different options",
        ));
    }
    let (width, height) = (r.u32()?, r.u32()?);
    let crop = [r.u32()?, r.u32()?, r.u32()?, r.u32()?];
    let (spp_begin, spp_end, seed) = (r.u32()?, r.u32()?, r.u64()?);
    let settings = RenderSettings {
        width,
        height,
        crop,
        spp_begin,
        spp_end,
        seed,
    };
    if settings != *expected {
        return Err(Error::format(
            path,
            format!("checkpoint settings {settings:?} differ from the requested {expected:?}"),
        ));
    }
    if !filter.is_box() {
        let code = r.u32()?;
        let p = [r.f32()?, r.f32()?, r.f32()?];
        let (want_code, want_p) = filter_code(filter);
        if code != want_code || p.map(f32::to_bits) != want_p.map(f32::to_bits) {
            return Err(Error::format(
                path,
                format!(
                    "checkpoint was written with another reconstruction filter than {filter:?}"
                ),
            ));
        }
    }
    let mut state = RenderState::with_filter(settings, *filter)?;
    let n = r.u32()? as usize;
    if n != state.tiles.len() {
        return Err(Error::format(path, "checkpoint tile layout differs"));
    }
    for t in &mut state.tiles {
        let head = [r.u32()?, r.u32()?, r.u32()?, r.u32()?];
        if head != [t.x0, t.y0, t.w, t.h] {
            return Err(Error::format(path, "checkpoint tile layout differs"));
        }
        let done = r.u32()?;
        if done > settings.spp() {
            return Err(Error::format(path, "checkpoint sample count out of range"));
        }
        let tile = Tile {
            done,
            rays: r.u64()?,
            invalid: r.u64()?,
            ..t.clone()
        };
        *t = tile;
        for px in t
            .sum
            .iter_mut()
            .chain(t.sum2.iter_mut())
            .chain(t.sum_w2.iter_mut())
        {
            for v in px.iter_mut() {
                *v = r.f64()?;
            }
        }
        for v in t.weight.iter_mut().chain(t.weight2.iter_mut()) {
            *v = r.f64()?;
        }
    }
    if r.pos != body.len() {
        return Err(Error::format(path, "checkpoint has trailing bytes"));
    }
    Ok(state)
}
