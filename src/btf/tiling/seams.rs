//! The seam metric: differences across the tiles' wrap-around borders vs between neighbours.

use crate::Result;
use crate::btf::{BtfSource, StoredEncoding};

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
        let s = |t: usize, c: usize| enc.encode(img[3 * t + c]);
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
