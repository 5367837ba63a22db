//! Checkpoints: the exact accumulator state of a render (f64 sums per pixel and per-tile
//! sample counts), written atomically, so a resumed render is bit-identical to an uninterrupted
//! one. Layout (little-endian): magic `BTFPTCK1`, u32 version, u64 fingerprint of the scene and
//! options, the settings, u32 tile count, per tile (x0, y0, w, h, done: u32; rays, invalid: u64;
//! sums and sums of squares: 6·w·h f64), then a CRC32 of everything before it.
//! Renders with a reconstruction filter other than the radius-½ box write version 2: the filter
//! (kind code, radius, two parameters: u32 + 3 f32) after the settings, and per tile the
//! bordered buffers (w + 2b)(h + 2b) of sums, sums of squares, Σ w²L, Σ w and Σ w².
//! A render kept without second moments ([`RenderState::without_moments`]) writes version 3
//! (box) or 4 (filter): the same layouts without the sums of squares, Σ w²L and Σ w².

use super::film::{RenderSettings, RenderState, Tile};
use crate::io::bytes::{Reader, Writer};
use crate::io::write_atomic;
use crate::math::filter::{Filter, FilterKind};
use crate::{Error, Result};
use std::path::Path;

const MAGIC: &[u8; 8] = b"BTFPTCK1";
const VERSION: u32 = 1;
const VERSION_FILTERED: u32 = 2;
/// [`VERSION`] and [`VERSION_FILTERED`] of a render kept without second moments.
const VERSION_NO_MOMENTS: u32 = 3;
const VERSION_FILTERED_NO_MOMENTS: u32 = 4;

/// The layout version of a checkpoint of a render with or without a filter and moments.
fn version_of(filtered: bool, moments: bool) -> u32 {
    match (filtered, moments) {
        (false, true) => VERSION,
        (true, true) => VERSION_FILTERED,
        (false, false) => VERSION_NO_MOMENTS,
        (true, false) => VERSION_FILTERED_NO_MOMENTS,
    }
}

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
    let mut b = Writer::new();
    let filtered = !state.filter.is_box();
    let version = version_of(filtered, state.has_moments());
    b.bytes(MAGIC).u32(version).u64(fingerprint);
    for v in [
        s.width, s.height, s.crop[0], s.crop[1], s.crop[2], s.crop[3],
    ] {
        b.u32(v);
    }
    b.u32(s.spp_begin).u32(s.spp_end).u64(s.seed);
    if filtered {
        let (code, p) = filter_code(&state.filter);
        b.u32(code).f32(p[0]).f32(p[1]).f32(p[2]);
    }
    b.len32(state.tiles.len(), "tile count")?;
    for t in &state.tiles {
        for v in [t.x0, t.y0, t.w, t.h, t.done] {
            b.u32(v);
        }
        b.u64(t.rays).u64(t.invalid);
        for px in t.sum.iter().chain(&t.sum2).chain(&t.sum_w2) {
            for &v in px {
                b.f64(v);
            }
        }
        for &v in t.weight.iter().chain(&t.weight2).chain(&t.extra) {
            b.f64(v);
        }
    }
    let crc = crc32fast::hash(b.as_bytes());
    b.u32(crc);
    let b = b.into_bytes();
    write_atomic(path, |w| w.write_all(&b).map_err(|e| Error::io(path, e)))
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
    load_channels(path, expected, filter, 0, fingerprint)
}

/// [`load_filtered`] of a render that also accumulates `extra` channels per pixel (the
/// scene's `channels.per_sample`; the fingerprint covers the scene that defines them).
pub fn load_channels(
    path: &Path,
    expected: &RenderSettings,
    filter: &Filter,
    extra: usize,
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
    let mut r = Reader::new(body, path, "corrupt checkpoint");
    r.seek(8)?;
    let version = r.u32("version")?;
    let filtered = !filter.is_box();
    let want = version_of(filtered, true);
    let moments = version == want;
    if !moments && version != version_of(filtered, false) {
        return Err(Error::format(
            path,
            format!(
                "checkpoint version {version} does not fit this render (expected {want} or {}: {})",
                version_of(filtered, false),
                if filter.is_box() {
                    "box filter"
                } else {
                    "reconstruction filter"
                }
            ),
        ));
    }
    if r.u64("fingerprint")? != fingerprint {
        return Err(Error::format(
            path,
            "checkpoint was written for a different scene or different options",
        ));
    }
    let (width, height) = (r.u32("width")?, r.u32("height")?);
    let crop = [
        r.u32("crop")?,
        r.u32("crop")?,
        r.u32("crop")?,
        r.u32("crop")?,
    ];
    let (spp_begin, spp_end, seed) = (r.u32("spp begin")?, r.u32("spp end")?, r.u64("seed")?);
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
        let code = r.u32("filter")?;
        let p = [r.f32("filter")?, r.f32("filter")?, r.f32("filter")?];
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
    let mut state = RenderState::with_channels(settings, *filter, extra)?;
    if !moments {
        state = state.without_moments();
    }
    let n = r.len32("tile count")?;
    if n != state.tiles.len() {
        return Err(Error::format(path, "checkpoint tile layout differs"));
    }
    for t in &mut state.tiles {
        let head = [
            r.u32("tile")?,
            r.u32("tile")?,
            r.u32("tile")?,
            r.u32("tile")?,
        ];
        if head != [t.x0, t.y0, t.w, t.h] {
            return Err(Error::format(path, "checkpoint tile layout differs"));
        }
        let done = r.u32("tile samples")?;
        if done > settings.spp() {
            return Err(Error::format(path, "checkpoint sample count out of range"));
        }
        let tile = Tile {
            done,
            rays: r.u64("ray count")?,
            invalid: r.u64("invalid count")?,
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
                *v = r.f64("pixel sums")?;
            }
        }
        for v in t.weight.iter_mut().chain(t.weight2.iter_mut()) {
            *v = r.f64("filter weights")?;
        }
        for v in t.extra.iter_mut() {
            *v = r.f64("extra channel sums")?;
        }
    }
    r.finish()?;
    Ok(state)
}
