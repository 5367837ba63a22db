//! The stitch: for every tile texel, the sample texels it is made of and their weights, and its
//! byte codec (stored in a model file's TILE section).

use crate::io::bytes::{Reader, Writer};
use crate::math::rng::mix64;
use crate::{Error, Result};
use std::io::{Read, Write};
use std::path::Path;

/// A weighted gather: every texel of the stacked tiles as a convex combination of sample texels.
#[derive(Clone, Debug, PartialEq)]
pub struct Stitch {
    /// Sample width in texels.
    pub sample_w: usize,
    /// Sample height in texels.
    pub sample_h: usize,
    /// Tile width in texels.
    pub tile_w: usize,
    /// Tile height in texels.
    pub tile_h: usize,
    /// Number of tiles, stacked vertically.
    pub count: usize,
    /// Overlap band of the template's wrap cuts, texels.
    pub overlap: usize,
    /// Sample position of the template's top-left texel.
    pub origin: (usize, usize),
    /// Sample position of the inner patch of tiles 1..count (the template has none).
    pub patches: Vec<(usize, usize)>,
    /// RMS feature difference along the template's cut paths (stored encoding, per channel).
    pub cut_error: f64,
    /// CSR row starts into `entries`, `tile_w · tile_h · count + 1` values.
    offsets: Vec<u32>,
    /// (sample texel = row · sample_w + column, weight).
    entries: Vec<(u32, f32)>,
}

pub(super) type Mix = Vec<(u32, f32)>;

impl Stitch {
    /// Texels of all stacked tiles.
    pub fn texels(&self) -> usize {
        self.tile_w * self.tile_h * self.count
    }

    /// The sample texels and weights making up stacked-tile texel `t`.
    #[inline]
    pub fn sources(&self, t: usize) -> &[(u32, f32)] {
        &self.entries[self.offsets[t] as usize..self.offsets[t + 1] as usize]
    }

    /// A plain crop of `w × h` at `origin` (no cut: what a naive tile would be).
    pub fn crop(
        sample_w: usize,
        sample_h: usize,
        origin: (usize, usize),
        w: usize,
        h: usize,
    ) -> Self {
        let mixes: Vec<Mix> = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| vec![(((origin.1 + y) * sample_w + origin.0 + x) as u32, 1.0)])
            .collect();
        Self::from_mixes(
            sample_w,
            sample_h,
            w,
            h,
            1,
            0,
            origin,
            Vec::new(),
            0.0,
            &mixes,
        )
    }

    #[allow(clippy::too_many_arguments)]
    pub(super) fn from_mixes(
        sample_w: usize,
        sample_h: usize,
        tile_w: usize,
        tile_h: usize,
        count: usize,
        overlap: usize,
        origin: (usize, usize),
        patches: Vec<(usize, usize)>,
        cut_error: f64,
        mixes: &[Mix],
    ) -> Self {
        let mut offsets = Vec::with_capacity(mixes.len() + 1);
        let mut entries = Vec::new();
        offsets.push(0);
        for m in mixes {
            entries.extend(m.iter().copied());
            offsets.push(entries.len() as u32);
        }
        Stitch {
            sample_w,
            sample_h,
            tile_w,
            tile_h,
            count,
            overlap,
            origin,
            patches,
            cut_error,
            offsets,
            entries,
        }
    }

    /// Gathers one image: `sample` = `[texel][rgb]` of the sample, `out` = `[texel][rgb]` of the
    /// stacked tiles.
    pub fn apply(&self, sample: &[f32], out: &mut [f32]) {
        for (t, o) in out.chunks_exact_mut(3).enumerate() {
            let mut acc = [0.0f32; 3];
            for &(s, w) in self.sources(t) {
                let s = 3 * s as usize;
                acc[0] += w * sample[s];
                acc[1] += w * sample[s + 1];
                acc[2] += w * sample[s + 2];
            }
            o.copy_from_slice(&acc);
        }
    }

    /// Serialises the stitch (payload of the `.plmc` TILE section).
    pub fn to_bytes(&self) -> Result<Vec<u8>> {
        let mut p = Writer::new();
        p.u32(1); // payload version
        for (v, field) in [
            (self.sample_w, "sample width"),
            (self.sample_h, "sample height"),
            (self.tile_w, "tile width"),
            (self.tile_h, "tile height"),
            (self.count, "tile count"),
            (self.overlap, "overlap"),
            (self.origin.0, "template column"),
            (self.origin.1, "template row"),
        ] {
            p.len32(v, field)?;
        }
        for &(x, y) in &self.patches {
            p.len32(x, "patch column")?.len32(y, "patch row")?;
        }
        p.len32(self.entries.len(), "entry count")?
            .f64(self.cut_error);
        let mut csr = Writer::new();
        for &o in &self.offsets {
            csr.u32(o);
        }
        for &(s, w) in &self.entries {
            csr.u32(s).f32(w);
        }
        let mut enc = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
        enc.write_all(csr.as_bytes())
            .map_err(|e| Error::Invalid(format!("deflating the stitch: {e}")))?;
        let z = enc
            .finish()
            .map_err(|e| Error::Invalid(format!("deflating the stitch: {e}")))?;
        p.bytes(&z);
        Ok(p.into_bytes())
    }

    /// A nonzero hash of the stitch (keys the fit's part files).
    pub fn key(&self) -> u64 {
        let mut h = 0x7469_6c65u64;
        let mut add = |v: u64| h = mix64(h ^ v);
        for v in [
            self.sample_w,
            self.sample_h,
            self.tile_w,
            self.tile_h,
            self.count,
        ] {
            add(v as u64);
        }
        for &o in &self.offsets {
            add(o as u64);
        }
        for &(s, w) in &self.entries {
            add(((s as u64) << 32) | w.to_bits() as u64);
        }
        h.max(1)
    }

    /// Parses [`Stitch::to_bytes`]; errors name `path`.
    pub fn from_bytes(b: &[u8], path: &Path) -> Result<Self> {
        let mut r = Reader::new(b, path, "corrupt TILE section");
        r.set_part("stitch header");
        let err = |r: &Reader, m: String| r.err(m);
        if r.u32("stitch version")? != 1 {
            return Err(err(&r, "unknown stitch version".into()));
        }
        let mut u = |field: &str| r.len32(field);
        let [sw, sh, tw, th, count, overlap, ox, oy] = [
            u("sample width")?,
            u("sample height")?,
            u("tile width")?,
            u("tile height")?,
            u("tile count")?,
            u("overlap")?,
            u("template column")?,
            u("template row")?,
        ];
        let texels = tw
            .checked_mul(th)
            .and_then(|t| t.checked_mul(count))
            .filter(|&t| t > 0 && t <= 1 << 28)
            .ok_or_else(|| err(&r, format!("bad tile size {tw}×{th}×{count}")))?;
        if sw == 0 || sh == 0 || sw.checked_mul(sh).is_none_or(|s| s > 1 << 30) {
            return Err(err(&r, format!("bad sample size {sw}×{sh}")));
        }
        if count > 1 << 16 {
            return Err(err(&r, format!("{count} tiles")));
        }
        let mut patches = Vec::with_capacity(count - 1);
        for _ in 1..count {
            patches.push((r.len32("patch column")?, r.len32("patch row")?));
        }
        let n = r.len32("entry count")?;
        let cut_error = r.f64("cut error")?;
        let pos = r.pos();
        let err = |m: String| Error::format(path, format!("corrupt TILE section: {m}"));
        let want = 4 * (texels + 1) + 8 * n;
        if n > 64 * texels {
            return Err(err(format!("{n} entries for {texels} texels")));
        }
        let mut csr = Vec::with_capacity(want);
        flate2::read::ZlibDecoder::new(&b[pos..])
            .take(want as u64 + 1)
            .read_to_end(&mut csr)
            .map_err(|e| err(format!("does not inflate: {e}")))?;
        if csr.len() != want {
            return Err(err(format!("{} table bytes, expected {want}", csr.len())));
        }
        let rd = |i: usize| u32::from_le_bytes([csr[i], csr[i + 1], csr[i + 2], csr[i + 3]]);
        let offsets: Vec<u32> = (0..=texels).map(|i| rd(4 * i)).collect();
        let base = 4 * (texels + 1);
        let entries: Vec<(u32, f32)> = (0..n)
            .map(|i| (rd(base + 8 * i), f32::from_bits(rd(base + 8 * i + 4))))
            .collect();
        if offsets[0] != 0
            || offsets[texels] as usize != n
            || offsets.windows(2).any(|w| w[0] > w[1])
        {
            return Err(err("entry offsets are not monotone".into()));
        }
        if entries
            .iter()
            .any(|&(s, w)| s as usize >= sw * sh || !w.is_finite())
        {
            return Err(err("entry outside the sample or non-finite weight".into()));
        }
        Ok(Stitch {
            sample_w: sw,
            sample_h: sh,
            tile_w: tw,
            tile_h: th,
            count,
            overlap,
            origin: (ox, oy),
            patches,
            cut_error,
            offsets,
            entries,
        })
    }
}
