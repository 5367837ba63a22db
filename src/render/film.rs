//! Film accumulation in tiles (the samples are traced by the integrators, in passes the
//! driver schedules): each tile receives whole sample indices for all its pixels and
//! keeps f64 per-pixel sums (and sums of squares) in sample order, so the result is a pure
//! function of (scene, seed, sample range, window), whatever the threads, pass sizes or
//! interruptions. Pixel (i, j) covers [i, i+1) × [j, j+1); each sample is uniformly jittered
//! inside its pixel. With the radius-½ box filter it lands in exactly that pixel; with any other
//! reconstruction filter (filter.rs) it is splatted with weights into the pixels within the
//! filter radius: each tile then owns a bordered buffer, tiles lie on a grid fixed in the full
//! film, a window renders the samples of its border pixels too, and the window image adds the
//! tiles' buffers in tile order — so a pixel's value does not depend on threads or windows.

use crate::io::RgbImage;
use crate::math::filter::{FOOTPRINT, Filter};
use crate::{Error, Result};

/// Adds a sample of radiance `l` to one row of buffer pixels with weights `wx[i] · wy` (sums
/// and weights in f64, the weight rounded to f32 first as every other splat does): four
/// pixels at a time, so their twelve channel sums and four weights are whole vector
/// operations instead of one pixel's three channels at a time.
#[inline(always)]
fn splat_row(
    sum: &mut [[f64; 3]],
    weight: &mut [f64],
    wx: &[f32],
    wy: f32,
    l: crate::math::Spectrum,
) {
    let l = [l[0] as f64, l[1] as f64, l[2] as f64];
    let (sum4, sum_rest) = sum.as_chunks_mut::<4>();
    let (weight4, weight_rest) = weight.as_chunks_mut::<4>();
    let (wx4, wx_rest) = wx.as_chunks::<4>();
    for ((acc, wacc), wx) in sum4.iter_mut().zip(weight4).zip(wx4) {
        let w: [f64; 4] = std::array::from_fn(|i| (wx[i] * wy) as f64);
        let wl: [f64; 12] = std::array::from_fn(|k| w[k / 3] * l[k % 3]);
        for (a, v) in acc.as_flattened_mut().iter_mut().zip(wl) {
            *a += v;
        }
        for (a, v) in wacc.iter_mut().zip(w) {
            *a += v;
        }
    }
    for ((acc, wacc), &wx) in sum_rest.iter_mut().zip(weight_rest).zip(wx_rest) {
        let w = (wx * wy) as f64;
        for c in 0..3 {
            acc[c] += w * l[c];
        }
        *wacc += w;
    }
}

/// Side of the square render tiles in pixels.
pub const TILE: u32 = 32;
/// Refuse to allocate film buffers larger than this (bytes).
pub const MAX_FILM_BYTES: u64 = 16 << 30;
/// Largest sample index accepted (the pixel's sample count must stay exact in f32 means).
pub const MAX_SPP: u32 = 1 << 24;

/// What to render: the window of the full film, the sample range and the seed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderSettings {
    /// Full film size in pixels.
    pub width: u32,
    pub height: u32,
    /// Window (x, y, w, h) in pixels of the full film.
    pub crop: [u32; 4],
    /// Sample indices [spp_begin, spp_end) are rendered for every pixel.
    pub spp_begin: u32,
    pub spp_end: u32,
    pub seed: u64,
}

impl RenderSettings {
    /// Validates the window and sample range and estimates the memory the film needs.
    pub fn validate(&self) -> Result<()> {
        let [x, y, w, h] = self.crop;
        if self.width == 0 || self.height == 0 || self.width > 1 << 17 || self.height > 1 << 17 {
            return Err(Error::Invalid(format!(
                "absurd film resolution {}×{} (each side must be in 1..=131072)",
                self.width, self.height
            )));
        }
        if w == 0
            || h == 0
            || x as u64 + w as u64 > self.width as u64
            || y as u64 + h as u64 > self.height as u64
        {
            return Err(Error::Invalid(format!(
                "crop window {x},{y},{w},{h} is empty or outside the {}×{} film",
                self.width, self.height
            )));
        }
        if self.spp_begin >= self.spp_end || self.spp_end > MAX_SPP {
            return Err(Error::Invalid(format!(
                "sample range {}..{} is empty or beyond {MAX_SPP}",
                self.spp_begin, self.spp_end
            )));
        }
        let bytes = w as u64 * h as u64 * (48 + 24);
        if bytes > MAX_FILM_BYTES {
            return Err(Error::Invalid(format!(
                "a {w}×{h} window needs ≈{:.1} GiB of film memory (limit {} GiB)",
                bytes as f64 / (1u64 << 30) as f64,
                MAX_FILM_BYTES >> 30
            )));
        }
        Ok(())
    }

    /// Samples per pixel this render produces.
    pub fn spp(&self) -> u32 {
        self.spp_end - self.spp_begin
    }
}

/// One tile of the window and its accumulators.
#[derive(Clone, Debug, PartialEq)]
pub struct Tile {
    /// Tile rectangle in full-film pixels: the pixels whose samples this tile renders.
    pub x0: u32,
    pub y0: u32,
    pub w: u32,
    pub h: u32,
    /// Pixels the accumulators extend beyond the rectangle on each side (the filter's border;
    /// 0 for the box filter). Buffer pixel (bx, by) is film pixel (x0 − border + bx, y0 − border + by).
    pub border: u32,
    /// Samples per pixel completed (relative to spp_begin).
    pub done: u32,
    /// Per buffer pixel, row-major: Σ w·L and Σ (w·L)² (RGB); w = 1 for the box filter.
    /// `sum2` is empty in a render kept without second moments
    /// ([`RenderState::without_moments`]).
    pub sum: Vec<[f64; 3]>,
    pub sum2: Vec<[f64; 3]>,
    /// Filtered tiles only (empty for the box filter, whose weights are all 1): Σ w²·L (RGB),
    /// Σ w and Σ w² per buffer pixel (`sum_w2` and `weight2` empty without second moments).
    pub sum_w2: Vec<[f64; 3]>,
    pub weight: Vec<f64>,
    pub weight2: Vec<f64>,
    /// Extra channels (Mitsuba's `aov`, `moment`) per buffer pixel, `extra_channels` at a
    /// time: Σ w·v of each channel's sample values v (w = 1 for the box filter).
    pub extra: Vec<f64>,
    pub extra_channels: usize,
    /// Rays traced and sample values discarded as NaN/Inf.
    pub rays: u64,
    pub invalid: u64,
}

impl Tile {
    /// Adds one box-filtered sample `l` to buffer pixel `i` (Σ L and Σ L², in f64). A NaN or
    /// infinite sample adds nothing and returns false: it counts as a zero-valued sample, as
    /// Mitsuba's film does (the caller books it as invalid).
    #[inline]
    pub fn add_box_sample(&mut self, i: usize, l: crate::math::Spectrum) -> bool {
        if !l.is_finite() {
            return false;
        }
        let acc = &mut self.sum[i];
        for c in 0..3 {
            acc[c] += l[c] as f64;
        }
        if let Some(acc2) = self.sum2.get_mut(i) {
            for c in 0..3 {
                let v = l[c] as f64;
                acc2[c] += v * v;
            }
        }
        true
    }

    /// True if the tile keeps the second moments the variance image is made of.
    pub fn has_moments(&self) -> bool {
        !self.sum2.is_empty()
    }

    /// Adds the sample of film pixel (`px`, `py`), taken at film position (`fx`, `fy`), with
    /// radiance `l`: into that pixel with the box filter, else splatted with the filter's
    /// weights into every buffer pixel of the film within its radius, in row-major order, so
    /// the sums do not depend on who adds the samples. Returns false for a NaN or infinite `l`
    /// (booked as invalid by the caller): the box filter then adds nothing, a wider filter a
    /// zero-valued sample that keeps its weight, as Mitsuba's film does.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn add_sample(
        &mut self,
        s: &RenderSettings,
        filter: &Filter,
        px: u32,
        py: u32,
        fx: f32,
        fy: f32,
        l: crate::math::Spectrum,
    ) -> bool {
        self.add_sample_with(s, filter, px, py, fx, fy, l, &[])
    }

    /// [`Tile::add_sample`] that also adds the sample's values of the extra channels
    /// (`extra_channels` of them, or none), with the same filter weights; a NaN or infinite
    /// value counts as 0.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn add_sample_with(
        &mut self,
        s: &RenderSettings,
        filter: &Filter,
        px: u32,
        py: u32,
        fx: f32,
        fy: f32,
        l: crate::math::Spectrum,
        extra: &[f32],
    ) -> bool {
        let n = self.extra_channels;
        let extra = &extra[..extra.len().min(n)];
        if filter.is_box() {
            let i = ((py - self.y0) * self.w + (px - self.x0)) as usize;
            for (k, &v) in extra.iter().enumerate() {
                if v.is_finite() {
                    self.extra[i * n + k] += v as f64;
                }
            }
            return self.add_box_sample(i, l);
        }
        let finite = l.is_finite();
        let l = if finite {
            l
        } else {
            crate::math::Spectrum::ZERO
        };
        let b = self.border as i64;
        let (bx0, by0) = (self.x0 as i64 - b, self.y0 as i64 - b);
        let bw = (self.w + 2 * self.border) as i64;
        let bh = (self.h + 2 * self.border) as i64;
        let (fw, fh) = (s.width as i64, s.height as i64);
        let mut wx = [0f32; FOOTPRINT];
        let mut wy = [0f32; FOOTPRINT];
        let ((lx, nx), (ly, ny)) = filter.weights_2d(fx, fy, &mut wx, &mut wy);
        // The footprint clipped to the film and to the tile with its border, once per axis.
        let span = |l: i64, n: usize, full: i64, b0: i64, bn: i64| {
            let first = 0.max(-l).max(b0 - l);
            let end = (n as i64).min(full - l).min(b0 + bn - l);
            first as usize..end.max(first) as usize
        };
        let (xs, ys) = (span(lx, nx, fw, bx0, bw), span(ly, ny, fh, by0, bh));
        // Σ w·L and Σ w row by row, four pixels at a time; second moments and extra channels
        // (when the render keeps them) pixel by pixel after. Each buffer still receives its
        // additions in pixel order, so the bits do not depend on which of them a render keeps.
        for j in ys.clone() {
            let q = ((ly + j as i64 - by0) * bw + (lx + xs.start as i64 - bx0)) as usize;
            splat_row(
                &mut self.sum[q..q + xs.len()],
                &mut self.weight[q..q + xs.len()],
                &wx[xs.clone()],
                wy[j],
                l,
            );
        }
        let moments = self.has_moments();
        if !moments && extra.is_empty() {
            return finite;
        }
        for j in ys {
            let (y, wyj) = (ly + j as i64, wy[j]);
            for i in xs.clone() {
                let x = lx + i as i64;
                let w = (wx[i] * wyj) as f64;
                let q = ((y - by0) * bw + (x - bx0)) as usize;
                if moments {
                    let w2 = w * w;
                    for c in 0..3 {
                        let v = l[c] as f64;
                        self.sum2[q][c] += w2 * v * v;
                        self.sum_w2[q][c] += w2 * v;
                    }
                    self.weight2[q] += w2;
                }
                for (k, &v) in extra.iter().enumerate() {
                    if v.is_finite() {
                        self.extra[q * n + k] += w * v as f64;
                    }
                }
            }
        }
        finite
    }

    /// Books one more completed sample index of every pixel of the tile.
    #[inline]
    pub fn sample_done(&mut self, rays: u64, invalid: u64) {
        self.done += 1;
        self.rays += rays;
        self.invalid += invalid;
    }
}

/// A render in progress: the settings, the reconstruction filter and the tiles.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderState {
    pub settings: RenderSettings,
    pub filter: Filter,
    pub tiles: Vec<Tile>,
}

/// Tile edges along one axis covering `lo..hi`: from `lo` in TILE steps (`grid` false), or cut at
/// multiples of TILE of the full film (`grid` true, so every window tiles alike).
fn tile_spans(lo: u32, hi: u32, grid: bool) -> Vec<(u32, u32)> {
    let mut v = Vec::new();
    let mut a = lo;
    while a < hi {
        let next = if grid {
            (a / TILE + 1) * TILE
        } else {
            a + TILE
        };
        let b = next.min(hi);
        v.push((a, b - a));
        a = b;
    }
    v
}

impl RenderState {
    /// A fresh render with the box filter (nothing accumulated).
    pub fn new(settings: RenderSettings) -> Result<RenderState> {
        RenderState::with_filter(settings, Filter::BOX)
    }

    /// A fresh render with reconstruction filter `filter`. A filtered window also renders the
    /// samples of the `filter.border()` pixels around it (within the film).
    pub fn with_filter(settings: RenderSettings, filter: Filter) -> Result<RenderState> {
        RenderState::with_channels(settings, filter, 0)
    }

    /// A fresh render with reconstruction filter `filter` that also accumulates `extra`
    /// channels per pixel (the scene's `channels.per_sample`).
    pub fn with_channels(
        settings: RenderSettings,
        filter: Filter,
        extra: usize,
    ) -> Result<RenderState> {
        settings.validate()?;
        let [cx, cy, cw, ch] = settings.crop;
        let b = filter.border();
        let (x0, y0) = (cx.saturating_sub(b), cy.saturating_sub(b));
        let x1 = (cx + cw).saturating_add(b).min(settings.width);
        let y1 = (cy + ch).saturating_add(b).min(settings.height);
        let filtered = !filter.is_box();
        let (xs, ys) = (tile_spans(x0, x1, filtered), tile_spans(y0, y1, filtered));
        if filtered {
            let side = (TILE + 2 * b) as u64;
            let bytes = (xs.len() * ys.len()) as u64 * side * side * 88;
            if bytes > MAX_FILM_BYTES {
                return Err(Error::Invalid(format!(
                    "a {cw}×{ch} window with a filter of radius {} needs ≈{:.1} GiB of film memory (limit {} GiB)",
                    filter.radius,
                    bytes as f64 / (1u64 << 30) as f64,
                    MAX_FILM_BYTES >> 30
                )));
            }
        }
        let mut tiles = Vec::with_capacity(xs.len() * ys.len());
        for &(y, h) in &ys {
            for &(x, w) in &xs {
                let n = ((w + 2 * b) * (h + 2 * b)) as usize;
                let m = if filtered { n } else { 0 };
                tiles.push(Tile {
                    x0: x,
                    y0: y,
                    w,
                    h,
                    border: b,
                    done: 0,
                    sum: vec![[0.0; 3]; n],
                    sum2: vec![[0.0; 3]; n],
                    sum_w2: vec![[0.0; 3]; m],
                    weight: vec![0.0; m],
                    weight2: vec![0.0; m],
                    extra: vec![0.0; n * extra],
                    extra_channels: extra,
                    rays: 0,
                    invalid: 0,
                });
            }
        }
        Ok(RenderState {
            settings,
            filter,
            tiles,
        })
    }

    /// The same render without the second moments (Σ (w·L)², Σ w²·L, Σ w²) that only the
    /// variance image reads: each sample then adds to half the sums, and the film holds less.
    pub fn without_moments(mut self) -> RenderState {
        for t in &mut self.tiles {
            t.sum2 = Vec::new();
            t.sum_w2 = Vec::new();
            t.weight2 = Vec::new();
        }
        self
    }

    /// True if the render keeps the second moments ([`RenderState::variance_image`] needs them).
    pub fn has_moments(&self) -> bool {
        self.tiles.iter().all(Tile::has_moments)
    }

    /// True once every tile has all its samples.
    pub fn is_complete(&self) -> bool {
        let spp = self.settings.spp();
        self.tiles.iter().all(|t| t.done >= spp)
    }

    /// Pixel-samples completed so far.
    pub fn samples_done(&self) -> u64 {
        self.tiles
            .iter()
            .map(|t| t.done as u64 * (t.w * t.h) as u64)
            .sum()
    }

    /// Pixel-samples of the whole render (a filtered window's border pixels included).
    pub fn samples_total(&self) -> u64 {
        let px: u64 = self.tiles.iter().map(|t| (t.w * t.h) as u64).sum();
        px * self.settings.spp() as u64
    }

    /// Rays traced so far.
    pub fn rays(&self) -> u64 {
        self.tiles.iter().map(|t| t.rays).sum()
    }

    /// Sample values discarded because they were NaN or infinite.
    pub fn invalid_samples(&self) -> u64 {
        self.tiles.iter().map(|t| t.invalid).sum()
    }

    /// The per-pixel mean (the image) of the window, Σ w·L / Σ w; requires a complete render.
    pub fn mean_image(&self) -> RgbImage {
        if !self.filter.is_box() {
            return self.filtered_image(false);
        }
        self.image_from(|sum, _sum2, n| sum / n)
    }

    /// Per-pixel variance of the mean, s²/n with the unbiased sample variance s² (needs n ≥ 2).
    /// With a filter: the delta-method variance of Σ w·L / Σ w, Σ w²(L − m)² / (Σ w)², scaled
    /// by n_eff / (n_eff − 1) with n_eff = (Σ w)² / Σ w² (which is s²/n again for equal weights).
    pub fn variance_image(&self) -> Result<RgbImage> {
        if self.settings.spp() < 2 {
            return Err(Error::Invalid(
                "the variance image needs at least 2 samples per pixel".into(),
            ));
        }
        if !self.has_moments() {
            return Err(Error::Invalid(
                "the variance image needs the render's second moments, and this render was \
                 kept without them"
                    .into(),
            ));
        }
        if !self.filter.is_box() {
            return Ok(self.filtered_image(true));
        }
        Ok(self.image_from(|sum, sum2, n| {
            let mean = sum / n;
            ((sum2 - n * mean * mean) / (n - 1.0)).max(0.0) / n
        }))
    }

    /// The window's mean of each extra channel, Σ w·v / Σ w (the box filter: Σ v / n), pixels
    /// row-major with the channels of a pixel together; requires a complete render.
    pub fn extra_means(&self) -> Vec<f32> {
        let [cx, cy, cw, ch] = self.settings.crop;
        let (cw, ch) = (cw as usize, ch as usize);
        let n = self.tiles.first().map_or(0, |t| t.extra_channels);
        let mut acc = vec![0f64; cw * ch * n];
        let mut wsum = vec![0f64; cw * ch];
        for t in &self.tiles {
            let b = t.border as i64;
            let bw = (t.w + 2 * t.border) as usize;
            let pixels = t.extra.len() / n.max(1);
            for i in 0..pixels {
                let x = t.x0 as i64 - b + (i % bw) as i64 - cx as i64;
                let y = t.y0 as i64 - b + (i / bw) as i64 - cy as i64;
                if x < 0 || y < 0 || x >= cw as i64 || y >= ch as i64 {
                    continue;
                }
                let j = y as usize * cw + x as usize;
                for k in 0..n {
                    acc[j * n + k] += t.extra[i * n + k];
                }
                wsum[j] += if self.filter.is_box() {
                    t.done as f64
                } else {
                    t.weight[i]
                };
            }
        }
        acc.iter()
            .enumerate()
            .map(|(i, &a)| {
                let w = wsum[i / n.max(1)];
                if w == 0.0 { 0.0 } else { (a / w) as f32 }
            })
            .collect()
    }

    /// Adds the tiles' buffers over the window in tile order, then the mean or its variance.
    fn filtered_image(&self, variance: bool) -> RgbImage {
        let [cx, cy, cw, ch] = self.settings.crop;
        let (cw, ch) = (cw as usize, ch as usize);
        let mut a = vec![[0f64; 3]; cw * ch];
        let moments = if variance { cw * ch } else { 0 };
        let mut a2 = vec![[0f64; 3]; moments];
        let mut aw2 = vec![[0f64; 3]; moments];
        let mut wsum = vec![0f64; cw * ch];
        let mut w2sum = vec![0f64; moments];
        for t in &self.tiles {
            let b = t.border as i64;
            let bw = (t.w + 2 * t.border) as usize;
            for (i, &wt) in t.weight.iter().enumerate() {
                let x = t.x0 as i64 - b + (i % bw) as i64 - cx as i64;
                let y = t.y0 as i64 - b + (i / bw) as i64 - cy as i64;
                if x < 0 || y < 0 || x >= cw as i64 || y >= ch as i64 {
                    continue;
                }
                let j = y as usize * cw + x as usize;
                for c in 0..3 {
                    a[j][c] += t.sum[i][c];
                }
                wsum[j] += wt;
                if variance {
                    for c in 0..3 {
                        a2[j][c] += t.sum2[i][c];
                        aw2[j][c] += t.sum_w2[i][c];
                    }
                    w2sum[j] += t.weight2[i];
                }
            }
        }
        let mut img = RgbImage::new(cw, ch);
        for j in 0..cw * ch {
            let w = wsum[j];
            let v = std::array::from_fn(|c| {
                if w == 0.0 {
                    return 0.0;
                }
                let m = a[j][c] / w;
                if !variance {
                    return m as f32;
                }
                let q = w2sum[j];
                let dev = (a2[j][c] - 2.0 * m * aw2[j][c] + m * m * q).max(0.0) / (w * w);
                let n_eff = w * w / q;
                if n_eff > 1.0 {
                    (dev * n_eff / (n_eff - 1.0)) as f32
                } else {
                    f32::INFINITY
                }
            });
            img.set(j % cw, j / cw, v);
        }
        img
    }

    fn image_from(&self, f: impl Fn(f64, f64, f64) -> f64) -> RgbImage {
        let [cx, cy, cw, ch] = self.settings.crop;
        let mut img = RgbImage::new(cw as usize, ch as usize);
        for t in &self.tiles {
            let n = t.done.max(1) as f64;
            for ty in 0..t.h {
                for tx in 0..t.w {
                    let i = (ty * t.w + tx) as usize;
                    let sum2 = t.sum2.get(i).copied().unwrap_or_default();
                    let v = std::array::from_fn(|c| f(t.sum[i][c], sum2[c], n) as f32);
                    img.set((t.x0 - cx + tx) as usize, (t.y0 - cy + ty) as usize, v);
                }
            }
        }
        img
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Pcg32, Spectrum};

    /// Adds one filtered sample to a tile's buffers the plain way: every buffer pixel of the
    /// tile asks whether it lies in the footprint and inside the film, and adds its weight.
    #[allow(clippy::too_many_arguments)]
    fn reference_splat(
        t: &Tile,
        s: &RenderSettings,
        filter: &Filter,
        fx: f32,
        fy: f32,
        l: Spectrum,
        sum: &mut [[f64; 3]],
        weight: &mut [f64],
        sum2: &mut [[f64; 3]],
    ) {
        let mut wx = [0f32; FOOTPRINT];
        let mut wy = [0f32; FOOTPRINT];
        let ((lx, nx), (ly, ny)) = filter.weights_2d(fx, fy, &mut wx, &mut wy);
        let b = t.border as i64;
        let bw = (t.w + 2 * t.border) as i64;
        let bh = (t.h + 2 * t.border) as i64;
        for by in 0..bh {
            for bx in 0..bw {
                let (x, y) = (t.x0 as i64 - b + bx, t.y0 as i64 - b + by);
                let inside = (0..s.width as i64).contains(&x) && (0..s.height as i64).contains(&y);
                let (i, j) = (x - lx, y - ly);
                if !inside || !(0..nx as i64).contains(&i) || !(0..ny as i64).contains(&j) {
                    continue;
                }
                let w = (wx[i as usize] * wy[j as usize]) as f64;
                let q = (by * bw + bx) as usize;
                for c in 0..3 {
                    sum[q][c] += w * l[c] as f64;
                    sum2[q][c] += w * w * l[c] as f64 * l[c] as f64;
                }
                weight[q] += w;
            }
        }
    }

    /// A filtered sample's Σ w·L, Σ w and second moments are the same bits as the plain
    /// per-pixel sums, for every filter, with and without moments kept, on tiles cut by the
    /// film's edges (rows shorter than four, remainders) as well as inner ones.
    #[test]
    fn filtered_splats_match_plain_per_pixel_sums() {
        let filters = [
            Filter::default(),
            Filter::gaussian(0.8).unwrap(),
            Filter::tent(1.5).unwrap(),
            Filter::mitchell(1.0 / 3.0, 1.0 / 3.0, 2.0).unwrap(),
            Filter::lanczos(3).unwrap(),
        ];
        let bits = |v: &[[f64; 3]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
        let wbits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for filter in filters {
            let settings = RenderSettings {
                width: 70,
                height: 45,
                crop: [0, 0, 70, 45],
                spp_begin: 0,
                spp_end: 1,
                seed: 0,
            };
            let mut with = RenderState::with_filter(settings, filter).unwrap();
            let mut without = with.clone().without_moments();
            let mut rng = Pcg32::new(3, 7);
            for (a, b) in with.tiles.iter_mut().zip(&mut without.tiles) {
                let n = a.sum.len();
                let (mut sum, mut weight, mut sum2) =
                    (vec![[0.0; 3]; n], vec![0.0; n], vec![[0.0; 3]; n]);
                for _ in 0..400 {
                    let px = a.x0 + (rng.next_f32() * a.w as f32) as u32 % a.w;
                    let py = a.y0 + (rng.next_f32() * a.h as f32) as u32 % a.h;
                    let (fx, fy) = (px as f32 + rng.next_f32(), py as f32 + rng.next_f32());
                    let l = Spectrum::new(rng.next_f32(), 3.0 * rng.next_f32(), 0.1);
                    assert!(a.add_sample(&settings, &filter, px, py, fx, fy, l));
                    assert!(b.add_sample(&settings, &filter, px, py, fx, fy, l));
                    reference_splat(
                        a,
                        &settings,
                        &filter,
                        fx,
                        fy,
                        l,
                        &mut sum,
                        &mut weight,
                        &mut sum2,
                    );
                }
                for t in [&*a, &*b] {
                    assert_eq!(bits(&t.sum), bits(&sum), "{filter:?}");
                    assert_eq!(wbits(&t.weight), wbits(&weight), "{filter:?}");
                }
                assert_eq!(bits(&a.sum2), bits(&sum2), "{filter:?}");
                assert!(b.sum2.is_empty());
                assert!(weight.iter().any(|&w| w > 0.0));
            }
        }
    }
}
