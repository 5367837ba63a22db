//! BTF enlargement (paper §3, DESIGN §4): seamless tiles cut out of the measured sample with
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

use crate::btf::format::TileSection;
use crate::btf::{BtfSource, DirectionSet, StoredEncoding};
use crate::fit::report::stored;
use crate::math::Vec3;
use crate::math::rng::mix64;
use crate::{Error, Result};
use std::io::{Read, Write};
use std::path::Path;

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

type Mix = Vec<(u32, f32)>;

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
    fn from_mixes(
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
        let mut p = Vec::new();
        let mut u = |v: usize| p.extend_from_slice(&(v as u32).to_le_bytes());
        u(1); // payload version
        for v in [
            self.sample_w,
            self.sample_h,
            self.tile_w,
            self.tile_h,
            self.count,
            self.overlap,
            self.origin.0,
            self.origin.1,
        ] {
            u(v);
        }
        for &(x, y) in &self.patches {
            u(x);
            u(y);
        }
        u(self.entries.len());
        p.extend_from_slice(&self.cut_error.to_le_bytes());
        let mut csr = Vec::with_capacity(4 * self.offsets.len() + 8 * self.entries.len());
        for o in &self.offsets {
            csr.extend_from_slice(&o.to_le_bytes());
        }
        for (s, w) in &self.entries {
            csr.extend_from_slice(&s.to_le_bytes());
            csr.extend_from_slice(&w.to_le_bytes());
        }
        let mut enc = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::best());
        enc.write_all(&csr)
            .map_err(|e| Error::Invalid(format!("deflating the stitch: {e}")))?;
        let z = enc
            .finish()
            .map_err(|e| Error::Invalid(format!("deflating the stitch: {e}")))?;
        p.extend_from_slice(&z);
        Ok(p)
    }

    /// The `.plmc` TILE section holding this stitch.
    pub fn section(&self) -> Result<TileSection> {
        Ok(TileSection {
            tile_w: self.tile_w,
            tile_h: self.tile_h,
            payload: self.to_bytes()?,
        })
    }

    /// The stitch stored in a TILE section of the file `path`, checked against its tile size.
    pub fn from_section(t: &TileSection, path: &Path) -> Result<Self> {
        let s = Self::from_bytes(&t.payload, path)?;
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
        let err = |m: String| Error::format(path, format!("corrupt TILE section: {m}"));
        let mut pos = 0usize;
        let mut u = || -> Result<usize> {
            let s = b
                .get(pos..pos + 4)
                .ok_or_else(|| err("truncated header".into()))?;
            pos += 4;
            Ok(u32::from_le_bytes([s[0], s[1], s[2], s[3]]) as usize)
        };
        if u()? != 1 {
            return Err(err("unknown stitch version".into()));
        }
        let [sw, sh, tw, th, count, overlap, ox, oy] =
            [u()?, u()?, u()?, u()?, u()?, u()?, u()?, u()?];
        let texels = tw
            .checked_mul(th)
            .and_then(|t| t.checked_mul(count))
            .filter(|&t| t > 0 && t <= 1 << 28)
            .ok_or_else(|| err(format!("bad tile size {tw}×{th}×{count}")))?;
        if sw == 0 || sh == 0 || sw.checked_mul(sh).is_none_or(|s| s > 1 << 30) {
            return Err(err(format!("bad sample size {sw}×{sh}")));
        }
        if count > 1 << 16 {
            return Err(err(format!("{count} tiles")));
        }
        let mut patches = Vec::with_capacity(count - 1);
        for _ in 1..count {
            patches.push((u()?, u()?));
        }
        let n = u()?;
        let ce = b
            .get(pos..pos + 8)
            .ok_or_else(|| err("truncated header".into()))?;
        let cut_error = f64::from_le_bytes(ce.try_into().map_err(|_| err("cut error".into()))?);
        pos += 8;
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

/// Minimum-error path through an error map `err[i · band + j]` (i along the path, j across the
/// band): one j per i with |j(i+1) − j(i)| ≤ 1; `cyclic` also requires |j(len−1) − j(0)| ≤ 1 so
/// the path closes on itself (a wrapping seam). Returns the path and its summed error. Exact DP.
pub fn min_error_cut(err: &[f32], len: usize, band: usize, cyclic: bool) -> (Vec<usize>, f64) {
    assert!(band > 0 && len > 0 && err.len() == len * band);
    let mut cost = vec![f64::INFINITY; len * band];
    let mut from = vec![0u32; len * band];
    let solve = |start: Option<usize>, cost: &mut [f64], from: &mut [u32]| -> (usize, f64) {
        for j in 0..band {
            cost[j] = if start.is_none_or(|s| s == j) {
                err[j] as f64
            } else {
                f64::INFINITY
            };
        }
        for i in 1..len {
            for j in 0..band {
                let (mut best, mut arg) = (cost[(i - 1) * band + j], j);
                for k in [j.wrapping_sub(1), j + 1] {
                    if k < band && cost[(i - 1) * band + k] < best {
                        best = cost[(i - 1) * band + k];
                        arg = k;
                    }
                }
                cost[i * band + j] = best + err[i * band + j] as f64;
                from[i * band + j] = arg as u32;
            }
        }
        let mut end = (0, f64::INFINITY);
        for j in 0..band {
            let ok = start.is_none_or(|s| j.abs_diff(s) <= 1);
            let c = cost[(len - 1) * band + j];
            if ok && c < end.1 {
                end = (j, c);
            }
        }
        end
    };
    let backtrack = |end: usize, from: &[u32]| {
        let mut path = vec![0usize; len];
        path[len - 1] = end;
        for i in (1..len).rev() {
            path[i - 1] = from[i * band + path[i]] as usize;
        }
        path
    };
    if !cyclic || len < 3 {
        let (end, c) = solve(None, &mut cost, &mut from);
        return (backtrack(end, &from), c);
    }
    let mut best: Option<(Vec<usize>, f64)> = None;
    for s in 0..band {
        let (end, c) = solve(Some(s), &mut cost, &mut from);
        if c.is_finite() && best.as_ref().is_none_or(|b| c < b.1) {
            best = Some((backtrack(end, &from), c));
        }
    }
    best.unwrap_or_else(|| (vec![0; len], f64::INFINITY))
}

/// Weight of the "second" source at `pos` for a cut whose first second-side cell is `c`, blended
/// over `[c − r, c + r)`; r = 0 is a hard cut.
#[inline]
fn ramp(pos: isize, c: usize, r: usize) -> f32 {
    let (c, r) = (c as isize, r as isize);
    ((pos - (c - r) + 1) as f32 / (2 * r + 1) as f32).clamp(0.0, 1.0)
}

/// Adaptive blend half-widths along a path: proportional to the local RMS cut error relative to
/// the band's mean, up to half the band, smoothed over 3 cells and kept inside the band.
fn blend_radii(err: &[f32], band: usize, path: &[usize]) -> Vec<usize> {
    let mean = err.iter().map(|&e| e as f64).sum::<f64>() / err.len().max(1) as f64;
    let rmax = (band / 2) as f64;
    let raw: Vec<f64> = path
        .iter()
        .enumerate()
        .map(|(i, &c)| {
            if mean > 0.0 {
                rmax * (2.0 * (err[i * band + c] as f64 / mean).sqrt()).min(1.0)
            } else {
                0.0
            }
        })
        .collect();
    (0..path.len())
        .map(|i| {
            let lo = i.saturating_sub(1);
            let hi = (i + 2).min(path.len());
            let r = (raw[lo..hi].iter().sum::<f64>() / (hi - lo) as f64).round() as usize;
            r.min(path[i]).min(band - path[i])
        })
        .collect()
}

/// Feature images of the representative pictures: `[texel][feature]`, stored encoding.
struct Features {
    w: usize,
    d: usize,
    f: Vec<f32>,
}

impl Features {
    #[inline]
    fn at(&self, x: usize, y: usize) -> &[f32] {
        let i = (y * self.w + x) * self.d;
        &self.f[i..i + self.d]
    }
}

#[inline]
fn dist(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

fn mix_into(out: &mut [f32], a: &[f32], wa: f32, b: &[f32]) {
    for ((o, &x), &y) in out.iter_mut().zip(a).zip(b) {
        *o = wa * x + (1.0 - wa) * y;
    }
}

/// A two-way blend of mixes, weights scaled; zero weights are dropped.
fn blend(a: &Mix, wa: f32, b: &Mix) -> Mix {
    let mut m: Mix = Vec::with_capacity(a.len() + b.len());
    if wa > 0.0 {
        m.extend(a.iter().map(|&(s, w)| (s, w * wa)));
    }
    if wa < 1.0 {
        for &(s, w) in b {
            let w = w * (1.0 - wa);
            match m.iter_mut().find(|e| e.0 == s) {
                Some(e) => e.1 += w,
                None => m.push((s, w)),
            }
        }
    }
    m
}

/// One cut: its path, blend radii and mean error per path cell.
struct Cut {
    path: Vec<usize>,
    radii: Vec<usize>,
    cost: f64,
}

fn cut(err: &[f32], len: usize, band: usize, cyclic: bool) -> Cut {
    let (path, c) = min_error_cut(err, len, band, cyclic);
    let radii = blend_radii(err, band, &path);
    Cut {
        path,
        radii,
        cost: c / len as f64,
    }
}

/// The template's two wrap cuts for source origin (x0, y0).
struct Template {
    horiz: Cut,
    vert: Cut,
    cost: f64,
}

fn template_cuts(f: &Features, x0: usize, y0: usize, w: usize, h: usize, o: usize) -> Template {
    let d = f.d;
    let wo = w + o;
    // Horizontal cut over the band rows 0..o, along all w + o columns: A = S(x, y) continues into
    // row o, B = S(x, h + y) continues from row h − 1.
    let mut err = vec![0.0f32; wo * o];
    for x in 0..wo {
        for j in 0..o {
            err[x * o + j] = dist(f.at(x0 + x, y0 + j), f.at(x0 + x, y0 + h + j));
        }
    }
    let horiz = cut(&err, wo, o, false);
    // Intermediate image I (w + o) × h, wrapping in y; only the band columns are needed.
    let mut fi_a = vec![0.0f32; h * o * d];
    let mut fi_b = vec![0.0f32; h * o * d];
    let fill = |x: usize, y: usize, out: &mut [f32]| {
        if y < o {
            let a = ramp(y as isize, horiz.path[x], horiz.radii[x]);
            mix_into(out, f.at(x0 + x, y0 + y), a, f.at(x0 + x, y0 + h + y));
        } else {
            out.copy_from_slice(f.at(x0 + x, y0 + y));
        }
    };
    for y in 0..h {
        for j in 0..o {
            let i = (y * o + j) * d;
            fill(j, y, &mut fi_a[i..i + d]);
            fill(w + j, y, &mut fi_b[i..i + d]);
        }
    }
    // Vertical cut over the band columns 0..o, along all h rows, cyclic (I wraps in y).
    let mut err = vec![0.0f32; h * o];
    for (e, (a, b)) in err
        .iter_mut()
        .zip(fi_a.chunks_exact(d).zip(fi_b.chunks_exact(d)))
    {
        *e = dist(a, b);
    }
    let vert = cut(&err, h, o, true);
    let cost = (horiz.cost * wo as f64 + vert.cost * h as f64) / (wo + h) as f64;
    Template { horiz, vert, cost }
}

fn template_mixes(
    sw: usize,
    x0: usize,
    y0: usize,
    w: usize,
    h: usize,
    o: usize,
    t: &Template,
) -> Vec<Mix> {
    let s = |x: usize, y: usize| -> Mix { vec![(((y0 + y) * sw + x0 + x) as u32, 1.0)] };
    let i_mix = |x: usize, y: usize| -> Mix {
        if y < o {
            let a = ramp(y as isize, t.horiz.path[x], t.horiz.radii[x]);
            blend(&s(x, y), a, &s(x, h + y))
        } else {
            s(x, y)
        }
    };
    let mut out = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            out.push(if x < o {
                let a = ramp(x as isize, t.vert.path[y], t.vert.radii[y]);
                blend(&i_mix(x, y), a, &i_mix(w + x, y))
            } else {
                i_mix(x, y)
            });
        }
    }
    out
}

/// Candidate positions 0..=range with a step chosen so a 2-D search over `range × other` offsets
/// stays within ~`budget` candidates (every position when it does), always including both ends.
fn candidates(range: usize, other: usize, budget: usize) -> Vec<usize> {
    let n = ((range + 1) * (other + 1)) as f64 / budget as f64;
    let step = (n.sqrt().ceil() as usize).max(1);
    let mut v: Vec<usize> = (0..=range).step_by(step).collect();
    if v.last() != Some(&range) {
        v.push(range);
    }
    v
}

/// The four cuts that stitch a `pw × ph` patch from sample (px, py) into the template at (m, m).
struct PatchCuts {
    cuts: [Cut; 4],
    cost: f64,
}

#[allow(clippy::too_many_arguments)]
fn patch_cuts(
    f: &Features,
    ft: &[f32],
    w: usize,
    m: usize,
    px: usize,
    py: usize,
    pw: usize,
    ph: usize,
    op: usize,
) -> PatchCuts {
    let d = f.d;
    let t_at = |x: usize, y: usize| &ft[((m + y) * w + m + x) * d..((m + y) * w + m + x + 1) * d];
    let e = |x: usize, y: usize| dist(t_at(x, y), f.at(px + x, py + y));
    let mut maps: [Vec<f32>; 4] = Default::default();
    // left / right: along rows, across columns; top / bottom: along columns, across rows.
    maps[0] = (0..ph)
        .flat_map(|i| (0..op).map(move |j| (j, i)))
        .map(|(x, y)| e(x, y))
        .collect();
    maps[1] = (0..ph)
        .flat_map(|i| (0..op).map(move |j| (pw - op + j, i)))
        .map(|(x, y)| e(x, y))
        .collect();
    maps[2] = (0..pw)
        .flat_map(|i| (0..op).map(move |j| (i, j)))
        .map(|(x, y)| e(x, y))
        .collect();
    maps[3] = (0..pw)
        .flat_map(|i| (0..op).map(move |j| (i, ph - op + j)))
        .map(|(x, y)| e(x, y))
        .collect();
    let cuts = [
        cut(&maps[0], ph, op, false),
        cut(&maps[1], ph, op, false),
        cut(&maps[2], pw, op, false),
        cut(&maps[3], pw, op, false),
    ];
    let cost =
        (cuts[0].cost + cuts[1].cost) * ph as f64 + (cuts[2].cost + cuts[3].cost) * pw as f64;
    PatchCuts {
        cuts,
        cost: cost / (2 * (pw + ph)) as f64,
    }
}

/// Weight of the patch at patch texel (x, y).
fn patch_weight(c: &PatchCuts, x: usize, y: usize, pw: usize, ph: usize, op: usize) -> f32 {
    let [l, r, t, b] = &c.cuts;
    let (xi, yi) = (x as isize, y as isize);
    ramp(xi, l.path[y], l.radii[y])
        * (1.0 - ramp(xi - (pw - op) as isize, r.path[y], r.radii[y]))
        * ramp(yi, t.path[x], t.radii[x])
        * (1.0 - ramp(yi - (ph - op) as isize, b.path[x], b.radii[x]))
}

/// Stage 1 on given representative images (linear `[texel][rgb]`, sample `sw × sh`): finds the
/// template (and patches) and returns the stitch.
pub fn find_stitch_in(
    images: &[&[f32]],
    sw: usize,
    sh: usize,
    enc: StoredEncoding,
    spec: &TileSpec,
) -> Result<Stitch> {
    let (w, h) = (spec.width, spec.height);
    if w > sw || h > sh {
        return Err(Error::Invalid(format!(
            "the {w}×{h} tile is larger than the {sw}×{sh} sample"
        )));
    }
    if w < 4 || h < 4 {
        return Err(Error::Invalid(format!(
            "the {w}×{h} tile is too small (at least 4×4)"
        )));
    }
    let room = (sw - w).min(sh - h);
    let o = spec
        .overlap
        .unwrap_or_else(|| (w.min(h) / 4).clamp(2, 16).min(room));
    if o < 2 || o > room || o > w.min(h) / 2 {
        return Err(Error::Invalid(format!(
            "the {w}×{h} tile needs an overlap band of 2..={} texels inside the {sw}×{sh} sample \
             (overlap {o}): use a smaller tile",
            (w.min(h) / 2).min(room).max(2)
        )));
    }
    if spec.count == 0 {
        return Err(Error::Invalid("--tiles must be at least 1".into()));
    }
    if images.is_empty() || images.iter().any(|i| i.len() != sw * sh * 3) {
        return Err(Error::Invalid(format!(
            "stitching needs representative images of {sw}×{sh} texels"
        )));
    }
    let d = 3 * images.len();
    let mut feat = vec![0.0f32; sw * sh * d];
    for (r, img) in images.iter().enumerate() {
        for t in 0..sw * sh {
            for c in 0..3 {
                feat[t * d + 3 * r + c] = stored(img[3 * t + c], enc);
            }
        }
    }
    let f = Features { w: sw, d, f: feat };
    // Stage 1a: the template origin with the cheapest wrap cuts.
    let mut best: Option<((usize, usize), Template)> = None;
    // Every offset while ≲ 50k candidates and 4·10⁸ feature differences, a grid beyond (each
    // candidate costs O((w + h) · overlap · features)).
    let budget = (400_000_000 / ((w + h) * o * d).max(1)).clamp(1_000, 50_000);
    for &y0 in &candidates(sh - h - o, sw - w - o, budget) {
        for &x0 in &candidates(sw - w - o, sh - h - o, budget) {
            let t = template_cuts(&f, x0, y0, w, h, o);
            if best.as_ref().is_none_or(|b| t.cost < b.1.cost) {
                best = Some(((x0, y0), t));
            }
        }
    }
    let ((x0, y0), tpl) = best.ok_or_else(|| Error::Invalid("no template position".into()))?;
    let mut mixes = template_mixes(sw, x0, y0, w, h, o, &tpl);
    let cut_error = (tpl.cost / d as f64).sqrt();
    let mut patches = Vec::new();
    if spec.count > 1 {
        let m = o;
        let (pw, ph) = (w - 2 * m, h - 2 * m);
        let op = o.min(pw / 4).min(ph / 4);
        if op < 2 {
            return Err(Error::Invalid(format!(
                "{} tiles need inner patches: the {w}×{h} tile is too small for a {o}-texel \
                 overlap (needs at least {}×{})",
                spec.count,
                2 * m + 8,
                2 * m + 8
            )));
        }
        // Template features, for the patch cut error maps.
        let mut ft = vec![0.0f32; w * h * d];
        for (t, mix) in mixes.iter().enumerate() {
            for &(s, wt) in mix {
                let src = &f.f[s as usize * d..(s as usize + 1) * d];
                for (o, &v) in ft[t * d..(t + 1) * d].iter_mut().zip(src) {
                    *o += wt * v;
                }
            }
        }
        let template_mixes = mixes.clone();
        // Positions already used: the template's own inner area, then each patch.
        let mut used = vec![(x0 + m, y0 + m)];
        let min_sep = pw.max(ph) / 2;
        for _ in 1..spec.count {
            let mut bestp: Option<((usize, usize), PatchCuts)> = None;
            for &py in &candidates(sh - ph, sw - pw, budget) {
                for &px in &candidates(sw - pw, sh - ph, budget) {
                    if used
                        .iter()
                        .any(|&(ux, uy)| ux.abs_diff(px).max(uy.abs_diff(py)) < min_sep)
                    {
                        continue;
                    }
                    let c = patch_cuts(&f, &ft, w, m, px, py, pw, ph, op);
                    if bestp.as_ref().is_none_or(|b| c.cost < b.1.cost) {
                        bestp = Some(((px, py), c));
                    }
                }
            }
            let ((px, py), pc) = bestp.ok_or_else(|| {
                Error::Invalid(format!(
                    "the {sw}×{sh} sample is too small for {} different {w}×{h} tiles",
                    spec.count
                ))
            })?;
            used.push((px, py));
            patches.push((px, py));
            for y in 0..h {
                for x in 0..w {
                    let t = y * w + x;
                    let inside = (m..m + pw).contains(&x) && (m..m + ph).contains(&y);
                    mixes.push(if inside {
                        let (u, v) = (x - m, y - m);
                        let a = patch_weight(&pc, u, v, pw, ph, op);
                        let p: Mix = vec![(((py + v) * sw + px + u) as u32, 1.0)];
                        blend(&p, a, &template_mixes[t])
                    } else {
                        template_mixes[t].clone()
                    });
                }
            }
        }
    }
    Ok(Stitch::from_mixes(
        sw,
        sh,
        w,
        h,
        spec.count,
        o,
        (x0, y0),
        patches,
        cut_error,
        &mixes,
    ))
}

/// Representative (view, light) pairs spread over the hemisphere: up to `n` (3..=5 sensible) of
/// (θv, φv, θl, φl) = (0,0,45,0), (30,90,30,270), (60,0,15,180), (45,200,60,20), (75,120,45,300),
/// each snapped to the nearest measured direction, duplicates dropped.
pub fn representative_pairs(
    views: &DirectionSet,
    lights: &DirectionSet,
    n: usize,
) -> Vec<(usize, usize)> {
    const TARGETS: [(f32, f32, f32, f32); 5] = [
        (0.0, 0.0, 45.0, 0.0),
        (30.0, 90.0, 30.0, 270.0),
        (60.0, 0.0, 15.0, 180.0),
        (45.0, 200.0, 60.0, 20.0),
        (75.0, 120.0, 45.0, 300.0),
    ];
    let dir = |t: f32, p: f32| {
        let (t, p) = (t.to_radians(), p.to_radians());
        Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
    };
    let nearest = |set: &DirectionSet, d: Vec3| {
        (0..set.len())
            .max_by(|&a, &b| set.dirs[a].dot(d).total_cmp(&set.dirs[b].dot(d)))
            .unwrap_or(0)
    };
    let mut out: Vec<(usize, usize)> = Vec::new();
    for &(tv, pv, tl, pl) in TARGETS.iter().take(n.max(1)) {
        let p = (nearest(views, dir(tv, pv)), nearest(lights, dir(tl, pl)));
        if !out.contains(&p) {
            out.push(p);
        }
    }
    out
}

/// Stage 1 on a BTF: loads the representative images and finds the stitch.
pub fn find_stitch(source: &dyn BtfSource, spec: &TileSpec) -> Result<Stitch> {
    let (sw, sh) = (source.width(), source.height());
    if spec.width > sw || spec.height > sh {
        return Err(Error::Invalid(format!(
            "the {}×{} tile is larger than the {sw}×{sh} sample",
            spec.width, spec.height
        )));
    }
    let pairs = representative_pairs(source.views(), source.lights(), 5);
    let n = sw * sh * 3;
    let mut images: Vec<Vec<f32>> = Vec::with_capacity(pairs.len());
    let mut views: Vec<usize> = pairs.iter().map(|p| p.0).collect();
    views.dedup();
    for v in views {
        let data = source.load_view(v)?;
        for &(pv, l) in &pairs {
            if pv == v {
                images.push(data[l * n..(l + 1) * n].to_vec());
            }
        }
    }
    let refs: Vec<&[f32]> = images.iter().map(|i| i.as_slice()).collect();
    find_stitch_in(&refs, sw, sh, source.encoding(), spec)
}

/// A BTF source whose images are the stitched tiles of another source (stage 2): width = tile
/// width, height = count · tile height.
pub struct TiledSource<'a> {
    inner: &'a dyn BtfSource,
    stitch: &'a Stitch,
}

impl<'a> TiledSource<'a> {
    /// Wraps `inner`; fails unless the stitch was made for a sample of its size.
    pub fn new(inner: &'a dyn BtfSource, stitch: &'a Stitch) -> Result<Self> {
        if (inner.width(), inner.height()) != (stitch.sample_w, stitch.sample_h) {
            return Err(Error::Invalid(format!(
                "the tiles were cut from a {}×{} sample, the data are {}×{}",
                stitch.sample_w,
                stitch.sample_h,
                inner.width(),
                inner.height()
            )));
        }
        Ok(TiledSource { inner, stitch })
    }
}

impl BtfSource for TiledSource<'_> {
    fn views(&self) -> &DirectionSet {
        self.inner.views()
    }
    fn lights(&self) -> &DirectionSet {
        self.inner.lights()
    }
    fn width(&self) -> usize {
        self.stitch.tile_w
    }
    fn height(&self) -> usize {
        self.stitch.tile_h * self.stitch.count
    }
    fn encoding(&self) -> StoredEncoding {
        self.inner.encoding()
    }
    fn load_view(&self, view: usize) -> Result<Vec<f32>> {
        let data = self.inner.load_view(view)?;
        let (n_in, n_out) = (
            self.stitch.sample_w * self.stitch.sample_h * 3,
            self.stitch.texels() * 3,
        );
        let nl = self.inner.lights().len();
        let mut out = vec![0.0f32; nl * n_out];
        for (src, dst) in data.chunks_exact(n_in).zip(out.chunks_exact_mut(n_out)) {
            self.stitch.apply(src, dst);
        }
        Ok(out)
    }
}

/// Sums for the seam metric: absolute differences (stored encoding) across the wrap-around borders
/// of every tile vs between neighbours inside it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SeamStats {
    /// Σ |difference| over wrap pairs (left↔right, top↔bottom).
    pub wrap: f64,
    /// Number of wrap pairs × channels.
    pub wrap_n: u64,
    /// Σ |difference| over neighbour pairs inside the tiles.
    pub inner: f64,
    /// Number of inner pairs × channels.
    pub inner_n: u64,
}

impl SeamStats {
    /// Adds one image `[texel][rgb]` (linear) of `count` stacked `w × tile_h` tiles.
    pub fn add_image(&mut self, img: &[f32], w: usize, tile_h: usize, enc: StoredEncoding) {
        let s = |t: usize, c: usize| stored(img[3 * t + c], enc);
        let count = img.len() / (3 * w * tile_h).max(1);
        for k in 0..count {
            let base = k * w * tile_h;
            for y in 0..tile_h {
                for x in 0..w {
                    let t = base + y * w + x;
                    let right = base + y * w + (x + 1) % w;
                    let down = base + ((y + 1) % tile_h) * w + x;
                    for c in 0..3 {
                        let v = s(t, c);
                        let (dr, dd) = ((v - s(right, c)).abs(), (v - s(down, c)).abs());
                        if x + 1 == w {
                            self.wrap += dr as f64;
                            self.wrap_n += 1;
                        } else {
                            self.inner += dr as f64;
                            self.inner_n += 1;
                        }
                        if y + 1 == tile_h {
                            self.wrap += dd as f64;
                            self.wrap_n += 1;
                        } else {
                            self.inner += dd as f64;
                            self.inner_n += 1;
                        }
                    }
                }
            }
        }
    }

    /// Adds another set of sums.
    pub fn merge(&mut self, o: &SeamStats) {
        self.wrap += o.wrap;
        self.wrap_n += o.wrap_n;
        self.inner += o.inner;
        self.inner_n += o.inner_n;
    }

    /// Mean wrap difference / mean inner difference (1 = the seams look like the inside; 0/0 = 1).
    pub fn ratio(&self) -> f64 {
        let wrap = self.wrap / self.wrap_n.max(1) as f64;
        let inner = self.inner / self.inner_n.max(1) as f64;
        if inner > 0.0 {
            wrap / inner
        } else if wrap > 0.0 {
            f64::INFINITY
        } else {
            1.0
        }
    }
}

/// Seam statistics of all images of all views of a source (tiles of `tile_h` rows stacked).
pub fn source_seams(source: &dyn BtfSource, tile_h: usize) -> Result<SeamStats> {
    use rayon::prelude::*;
    let (w, h) = (source.width(), source.height());
    let n = w * h * 3;
    let per_view: Vec<SeamStats> = (0..source.views().len())
        .into_par_iter()
        .map(|v| -> Result<SeamStats> {
            let data = source.load_view(v)?;
            let mut s = SeamStats::default();
            for img in data.chunks_exact(n) {
                s.add_image(img, w, tile_h, source.encoding());
            }
            Ok(s)
        })
        .collect::<Result<_>>()?;
    let mut s = SeamStats::default();
    per_view.iter().for_each(|p| s.merge(p));
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::btf::RawBtf;
    use crate::math::Pcg32;

    /// A random texture `[texel][rgb]`.
    fn noise(w: usize, h: usize, seed: u64) -> Vec<f32> {
        let mut r = Pcg32::new(seed, 3);
        (0..w * h * 3).map(|_| r.next_f32()).collect()
    }

    /// A smooth-ish texture: blurred noise (neighbours correlated like a real material).
    fn blurred(w: usize, h: usize, seed: u64) -> Vec<f32> {
        let n = noise(w, h, seed);
        let mut out = vec![0.0; n.len()];
        for y in 0..h {
            for x in 0..w {
                for c in 0..3 {
                    let mut s = 0.0;
                    let mut k = 0.0;
                    for dy in 0..3 {
                        for dx in 0..3 {
                            let (xx, yy) = ((x + dx).min(w - 1), (y + dy).min(h - 1));
                            s += n[3 * (yy * w + xx) + c];
                            k += 1.0;
                        }
                    }
                    out[3 * (y * w + x) + c] = s / k;
                }
            }
        }
        out
    }

    fn tile_of(st: &Stitch, img: &[f32]) -> Vec<f32> {
        let mut out = vec![0.0; st.texels() * 3];
        st.apply(img, &mut out);
        out
    }

    #[test]
    fn the_cut_between_two_identical_images_has_zero_error() {
        let img = noise(20, 12, 1);
        let (len, band) = (20, 6);
        // Error map of the band between the image and itself.
        let err: Vec<f32> = (0..len)
            .flat_map(|x| (0..band).map(move |j| (x, j)))
            .map(|(x, j)| {
                let t = 3 * (j * 20 + x);
                dist(&img[t..t + 3], &img[t..t + 3])
            })
            .collect();
        for cyclic in [false, true] {
            let (path, cost) = min_error_cut(&err, len, band, cyclic);
            assert_eq!(cost, 0.0);
            assert_eq!(path.len(), len);
            assert!(path.windows(2).all(|w| w[0].abs_diff(w[1]) <= 1));
        }
        // And a zero-error band gives hard cuts (no blending).
        assert!(
            blend_radii(&err, band, &vec![3; len])
                .iter()
                .all(|&r| r == 0)
        );
    }

    #[test]
    fn the_cut_is_the_optimal_path_and_cyclic_paths_close() {
        // A cheap corridor that moves one cell per step: the DP must follow it exactly.
        let (len, band) = (9, 5);
        let corridor = [0, 1, 2, 3, 4, 3, 2, 1, 0];
        let mut err = vec![1.0f32; len * band];
        for (i, &j) in corridor.iter().enumerate() {
            err[i * band + j] = 0.0;
        }
        let (p, c) = min_error_cut(&err, len, band, false);
        assert_eq!(p, corridor);
        assert_eq!(c, 0.0);
        // Cyclic: a path ending far from its start is not allowed.
        let mut err = vec![1.0f32; 6 * 4];
        for (i, &j) in [0usize, 1, 2, 3, 3, 3].iter().enumerate() {
            err[i * 4 + j] = 0.0;
        }
        let (open, c_open) = min_error_cut(&err, 6, 4, false);
        assert_eq!(c_open, 0.0);
        assert_eq!(open, [0, 1, 2, 3, 3, 3]);
        let (closed, c_closed) = min_error_cut(&err, 6, 4, true);
        assert!(closed[0].abs_diff(closed[5]) <= 1);
        assert!(c_closed > 0.0);
        // Brute force over all cyclic paths agrees.
        let mut best = f64::INFINITY;
        for code in 0..4usize.pow(6) {
            let p: Vec<usize> = (0..6).map(|i| code / 4usize.pow(i) % 4).collect();
            let ok = p.windows(2).all(|w| w[0].abs_diff(w[1]) <= 1) && p[0].abs_diff(p[5]) <= 1;
            if ok {
                best = best.min((0..6).map(|i| err[i * 4 + p[i]] as f64).sum());
            }
        }
        assert_eq!(c_closed, best);
    }

    #[test]
    fn a_tile_of_a_periodic_texture_wraps_exactly() {
        // Period 16 × 12; the sample holds 3 × 3 periods.
        let (pw, ph) = (16, 12);
        let base = blurred(pw, ph, 5);
        let (sw, sh) = (3 * pw, 3 * ph);
        let img: Vec<f32> = (0..sw * sh)
            .flat_map(|t| {
                let (x, y) = (t % sw % pw, t / sw % ph);
                base[3 * (y * pw + x)..3 * (y * pw + x) + 3].to_vec()
            })
            .collect();
        let st = find_stitch_in(
            &[&img],
            sw,
            sh,
            StoredEncoding::Linear,
            &TileSpec::new(pw, ph),
        )
        .unwrap();
        assert_eq!(st.cut_error, 0.0);
        let tile = tile_of(&st, &img);
        let (x0, y0) = st.origin;
        for y in 0..ph {
            for x in 0..pw {
                let s = 3 * (((y0 + y) % ph) * pw + (x0 + x) % pw);
                let t = 3 * (y * pw + x);
                assert_eq!(&tile[t..t + 3], &base[s..s + 3], "texel ({x}, {y})");
            }
        }
        // So its wrap-around neighbours are exactly the texture's neighbours.
        let mut seams = SeamStats::default();
        seams.add_image(&tile, pw, ph, StoredEncoding::Linear);
        let mut periodic = SeamStats::default();
        periodic.add_image(&base, pw, ph, StoredEncoding::Linear);
        assert_eq!(seams.wrap, periodic.wrap);
    }

    #[test]
    fn stitched_tiles_wrap_better_than_crops_and_share_borders() {
        let (sw, sh) = (72, 64);
        let imgs = [blurred(sw, sh, 7), blurred(sw, sh, 8)];
        let refs: Vec<&[f32]> = imgs.iter().map(|i| i.as_slice()).collect();
        let spec = TileSpec {
            width: 32,
            height: 24,
            count: 3,
            overlap: None,
        };
        let st = find_stitch_in(&refs, sw, sh, StoredEncoding::Linear, &spec).unwrap();
        assert_eq!((st.texels(), st.patches.len()), (32 * 24 * 3, 2));
        // Every texel is a convex combination of sample texels.
        for t in 0..st.texels() {
            let s: f32 = st.sources(t).iter().map(|e| e.1).sum();
            assert!((s - 1.0).abs() < 1e-5 && st.sources(t).iter().all(|e| e.1 > 0.0));
        }
        let crop = Stitch::crop(sw, sh, st.origin, 32, 24);
        let (mut a, mut b) = (SeamStats::default(), SeamStats::default());
        for img in &imgs {
            a.add_image(&tile_of(&st, img), 32, 24, StoredEncoding::Linear);
            b.add_image(&tile_of(&crop, img), 32, 24, StoredEncoding::Linear);
        }
        assert!(a.ratio() < 1.25, "stitched {}", a.ratio());
        assert!(
            b.ratio() > 1.5 * a.ratio(),
            "crop {} stitched {}",
            b.ratio(),
            a.ratio()
        );
        // Tiles 1 and 2 differ inside but keep the template's border ring, so they are
        // interchangeable; the patches come from elsewhere.
        let t = tile_of(&st, &imgs[0]);
        let n = 32 * 24 * 3;
        let (m, o) = (st.overlap, st.overlap);
        for k in 1..3 {
            let tk = &t[k * n..(k + 1) * n];
            let mut inner_diff = 0.0;
            for y in 0..24 {
                for x in 0..32 {
                    let i = 3 * (y * 32 + x);
                    let ring = x < m || y < m || x >= 32 - m || y >= 24 - m;
                    if ring {
                        assert_eq!(&tk[i..i + 3], &t[i..i + 3], "tile {k} ({x}, {y})");
                    } else {
                        inner_diff += (tk[i] - t[i]).abs();
                    }
                }
            }
            assert!(inner_diff > 1.0, "tile {k} has no variety");
            let _ = o;
        }
        // Serialisation round trip.
        let bytes = st.to_bytes().unwrap();
        assert_eq!(Stitch::from_bytes(&bytes, Path::new("t.plmc")).unwrap(), st);
        let e = Stitch::from_bytes(&bytes[..20], Path::new("t.plmc")).unwrap_err();
        assert!(e.to_string().contains("t.plmc"), "{e}");
    }

    #[test]
    fn tiles_larger_than_the_sample_are_an_error() {
        let img = noise(16, 16, 2);
        for (w, h) in [(17, 8), (8, 20), (16, 16), (15, 15)] {
            let e = find_stitch_in(
                &[&img],
                16,
                16,
                StoredEncoding::Linear,
                &TileSpec::new(w, h),
            )
            .unwrap_err()
            .to_string();
            assert!(e.contains(&format!("{w}×{h}")), "{e}");
        }
        assert!(parse_size("64x32").unwrap() == (64, 32) && parse_size("8").unwrap() == (8, 8));
        assert!(parse_size("0x4").is_err() && parse_size("ax4").is_err());
        // Through a BTF source as well.
        let d = DirectionSet::from_angles_deg(vec![(0.0, 0.0)]);
        let btf = RawBtf::from_f32(d.clone(), d, 4, 4, StoredEncoding::Linear, &[0.5; 48]).unwrap();
        let e = find_stitch(&btf, &TileSpec::new(8, 8))
            .unwrap_err()
            .to_string();
        assert!(e.contains("larger than the 4×4 sample"), "{e}");
    }

    #[test]
    fn the_tiled_source_gathers_every_image_with_the_same_stitch() {
        let views = DirectionSet::from_angles_deg(vec![(0.0, 0.0), (30.0, 0.0)]);
        let lights = DirectionSet::from_angles_deg(vec![(0.0, 0.0), (45.0, 90.0), (60.0, 0.0)]);
        let (sw, sh) = (40, 36);
        // Every image is the same structure under another light: one texture, scaled.
        let base = blurred(sw, sh, 20);
        let data: Vec<f32> = (0..6)
            .flat_map(|k| base.iter().map(move |&v| v * (0.4 + 0.1 * k as f32)))
            .collect();
        let btf = RawBtf::from_f32(views, lights, sw, sh, StoredEncoding::Linear, &data).unwrap();
        let st = find_stitch(&btf, &TileSpec::new(16, 16)).unwrap();
        let ts = TiledSource::new(&btf, &st).unwrap();
        assert_eq!((ts.width(), ts.height()), (16, 16));
        let full = btf.load_view(1).unwrap();
        let tiled = ts.load_view(1).unwrap();
        let n_in = sw * sh * 3;
        for l in 0..3 {
            assert_eq!(
                &tiled[l * 768..(l + 1) * 768],
                &tile_of(&st, &full[l * n_in..(l + 1) * n_in])[..]
            );
        }
        let seams = source_seams(&ts, 16).unwrap();
        assert!(seams.ratio() < 1.25, "{}", seams.ratio());
        let other = Stitch::crop(8, 8, (0, 0), 4, 4);
        assert!(TiledSource::new(&btf, &other).is_err());
    }
}
