//! Spatially varying parameters: a constant or a bitmap looked up by uv.

use crate::io::RgbImage;
use crate::math::{Spectrum, Vec2};
use std::sync::Arc;

/// A reflectance-like parameter (linear RGB).
#[derive(Clone, Debug)]
pub enum Texture {
    Constant(Spectrum),
    /// Mitsuba `bitmap`: bilinear filtering, repeat wrap, row 0 of the image at v = 0.
    Bitmap(Arc<RgbImage>),
}

impl Texture {
    /// The value at `uv`.
    pub fn eval(&self, uv: Vec2) -> Spectrum {
        match self {
            Texture::Constant(c) => *c,
            Texture::Bitmap(img) => bilinear_repeat(img, uv),
        }
    }

    /// Mean over the texture and the RGB channels (Mitsuba `Texture::mean`, used to steer
    /// lobe selection).
    pub fn mean(&self) -> f32 {
        match self {
            Texture::Constant(c) => (c.x + c.y + c.z) / 3.0,
            Texture::Bitmap(img) => {
                let s: f64 = img.data.iter().map(|&v| v as f64).sum();
                (s / img.data.len().max(1) as f64) as f32
            }
        }
    }

    /// True if the value depends on uv.
    pub fn is_spatially_varying(&self) -> bool {
        matches!(self, Texture::Bitmap(_))
    }
}

fn bilinear_repeat(img: &RgbImage, uv: Vec2) -> Spectrum {
    let (w, h) = (img.width as i64, img.height as i64);
    let x = uv.x * w as f32 - 0.5;
    let y = uv.y * h as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let wrap = |i: i64, n: i64| i.rem_euclid(n) as usize;
    let (x0, y0) = (x0 as i64, y0 as i64);
    let px = |xi: i64, yi: i64| Spectrum::from(img.get(wrap(xi, w), wrap(yi, h)));
    let top = px(x0, y0) * (1.0 - fx) + px(x0 + 1, y0) * fx;
    let bottom = px(x0, y0 + 1) * (1.0 - fx) + px(x0 + 1, y0 + 1) * fx;
    top * (1.0 - fy) + bottom * fy
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bitmap_is_exact_at_pixel_centres_and_wraps() {
        let mut img = RgbImage::new(2, 2);
        img.set(0, 0, [1.0, 0.0, 0.0]);
        img.set(1, 0, [0.0, 1.0, 0.0]);
        img.set(0, 1, [0.0, 0.0, 1.0]);
        img.set(1, 1, [1.0, 1.0, 1.0]);
        let t = Texture::Bitmap(Arc::new(img));
        assert_eq!(t.eval(Vec2::new(0.25, 0.25)), Spectrum::new(1.0, 0.0, 0.0));
        assert_eq!(t.eval(Vec2::new(1.75, 0.75)), Spectrum::ONE);
        let mid = t.eval(Vec2::new(0.5, 0.25));
        assert!((mid - Spectrum::new(0.5, 0.5, 0.0)).length() < 1e-6);
    }
}
