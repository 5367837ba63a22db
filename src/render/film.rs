//! Film accumulation in tiles: each tile renders whole sample indices for all its pixels and
//! keeps f64 per-pixel sums (and sums of squares) in sample order, so the result is a pure
//! function of (scene, seed, sample range, window), whatever the threads, pass sizes or
//! interruptions. Box filter: pixel (i, j) covers [i, i+1) × [j, j+1); each sample lands in
//! exactly one pixel, uniformly jittered inside it.

use super::RenderScene;
use super::integrator::TraceStats;
use crate::io::RgbImage;
use crate::math::Pcg32;
use crate::{Error, Result};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

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
    /// Tile rectangle in full-film pixels.
    pub x0: u32,
    pub y0: u32,
    pub w: u32,
    pub h: u32,
    /// Samples per pixel completed (relative to spp_begin).
    pub done: u32,
    /// Per pixel, row-major in the tile: Σ L and Σ L² (RGB).
    pub sum: Vec<[f64; 3]>,
    pub sum2: Vec<[f64; 3]>,
    /// Rays traced and sample values discarded as NaN/Inf.
    pub rays: u64,
    pub invalid: u64,
}

/// A render in progress: the settings and the tiles.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderState {
    pub settings: RenderSettings,
    pub tiles: Vec<Tile>,
}

impl RenderState {
    /// A fresh render (nothing accumulated).
    pub fn new(settings: RenderSettings) -> Result<RenderState> {
        settings.validate()?;
        let [cx, cy, cw, ch] = settings.crop;
        let mut tiles = Vec::new();
        let mut y = cy;
        while y < cy + ch {
            let h = TILE.min(cy + ch - y);
            let mut x = cx;
            while x < cx + cw {
                let w = TILE.min(cx + cw - x);
                let n = (w * h) as usize;
                tiles.push(Tile {
                    x0: x,
                    y0: y,
                    w,
                    h,
                    done: 0,
                    sum: vec![[0.0; 3]; n],
                    sum2: vec![[0.0; 3]; n],
                    rays: 0,
                    invalid: 0,
                });
                x += w;
            }
            y += h;
        }
        Ok(RenderState { settings, tiles })
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

    /// Pixel-samples of the whole render.
    pub fn samples_total(&self) -> u64 {
        let [_, _, w, h] = self.settings.crop;
        w as u64 * h as u64 * self.settings.spp() as u64
    }

    /// Rays traced so far.
    pub fn rays(&self) -> u64 {
        self.tiles.iter().map(|t| t.rays).sum()
    }

    /// Sample values discarded because they were NaN or infinite.
    pub fn invalid_samples(&self) -> u64 {
        self.tiles.iter().map(|t| t.invalid).sum()
    }

    /// Adds up to `k` more samples per pixel to every unfinished tile, in parallel over tiles
    /// (on the current rayon pool). Stops early, at a sample boundary of each tile, once
    /// `interrupt` is set. `progress` receives completed pixel-samples and rays as they finish.
    pub fn run_pass(
        &mut self,
        rs: &RenderScene,
        k: u32,
        interrupt: &AtomicBool,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) {
        let s = self.settings;
        self.tiles.par_iter_mut().for_each(|tile| {
            let end = s.spp().min(tile.done.saturating_add(k));
            if let super::IntegratorKind::Packet(opts) = rs.kind {
                super::packet::render_tile(rs, opts, &s, tile, end, interrupt, progress);
                return;
            }
            while tile.done < end {
                if interrupt.load(Ordering::Relaxed) {
                    return;
                }
                let mut stats = TraceStats::default();
                let mut invalid = 0;
                let sample = (s.spp_begin + tile.done) as u64;
                for ty in 0..tile.h {
                    for tx in 0..tile.w {
                        let (px, py) = (tile.x0 + tx, tile.y0 + ty);
                        let pixel = py as u64 * s.width as u64 + px as u64;
                        let mut rng = Pcg32::for_sample(s.seed, pixel, sample);
                        let fx = px as f32 + rng.next_f32();
                        let fy = py as f32 + rng.next_f32();
                        let (o, d, tmax) = rs.camera.ray(fx, fy);
                        let l = rs.integrator.li(rs, o, d, tmax, &mut rng, &mut stats);
                        let i = (ty * tile.w + tx) as usize;
                        if l.is_finite() {
                            let acc = &mut tile.sum[i];
                            let acc2 = &mut tile.sum2[i];
                            for c in 0..3 {
                                let v = l[c] as f64;
                                acc[c] += v;
                                acc2[c] += v * v;
                            }
                        } else {
                            // Counted as a zero-valued sample, as Mitsuba's film does.
                            invalid += 1;
                        }
                    }
                }
                tile.done += 1;
                tile.rays += stats.rays;
                tile.invalid += invalid;
                progress((tile.w * tile.h) as u64, stats.rays);
            }
        });
    }

    /// The per-pixel mean (the image) of the window; requires a complete render.
    pub fn mean_image(&self) -> RgbImage {
        self.image_from(|sum, _sum2, n| sum / n)
    }

    /// Per-pixel variance of the mean, s²/n with the unbiased sample variance s² (needs n ≥ 2).
    pub fn variance_image(&self) -> Result<RgbImage> {
        if self.settings.spp() < 2 {
            return Err(Error::Invalid(
                "the variance image needs at least 2 samples per pixel".into(),
            ));
        }
        Ok(self.image_from(|sum, sum2, n| {
            let mean = sum / n;
            ((sum2 - n * mean * mean) / (n - 1.0)).max(0.0) / n
        }))
    }

    fn image_from(&self, f: impl Fn(f64, f64, f64) -> f64) -> RgbImage {
        let [cx, cy, cw, ch] = self.settings.crop;
        let mut img = RgbImage::new(cw as usize, ch as usize);
        for t in &self.tiles {
            let n = t.done.max(1) as f64;
            for ty in 0..t.h {
                for tx in 0..t.w {
                    let i = (ty * t.w + tx) as usize;
                    let v = std::array::from_fn(|c| f(t.sum[i][c], t.sum2[i][c], n) as f32);
                    img.set((t.x0 - cx + tx) as usize, (t.y0 - cy + ty) as usize, v);
                }
            }
        }
        img
    }
}
