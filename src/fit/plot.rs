//! Per-view MAE plot like the paper's Fig. 6, drawn directly into an RGB PNG with a built-in 5×7
//! bitmap font (no font files, no system fonts): x = view index (ticks every 10), y = MAE from 0
//! with "nice" ticks (1, 2 or 5 × 10^k), axis labels and a legend; colours: LM blue, PLM green,
//! PLM-C red, PCA grey.

use super::evaluate::EvalReport;
use crate::io::glyph::glyph;
use crate::{Error, Result};
use std::path::Path;

const W: usize = 860;
const H: usize = 460;
/// Plot area margins in pixels (left holds the tick labels, bottom the x label, top the legend).
const LEFT: usize = 78;
const RIGHT: usize = 20;
const TOP: usize = 44;
const BOTTOM: usize = 52;
/// Font scale: each font pixel is a SCALE × SCALE block.
const SCALE: usize = 2;

/// Colours of the model lines, in the order lm, plm, plmc, pca.
pub const COLOURS: [(&str, [u8; 3]); 4] = [
    ("lm", [40, 80, 220]),
    ("plm", [30, 160, 60]),
    ("plmc", [220, 40, 40]),
    ("pca", [120, 120, 120]),
];

/// Width in pixels of `text` drawn by [`Canvas::text`].
fn text_width(text: &str) -> usize {
    text.chars().count() * 6 * SCALE
}

/// An RGB8 image with clipped pixel writes.
struct Canvas {
    img: Vec<u8>,
}

impl Canvas {
    fn put(&mut self, x: i64, y: i64, c: [u8; 3]) {
        if (0..W as i64).contains(&x) && (0..H as i64).contains(&y) {
            let o = 3 * (y as usize * W + x as usize);
            self.img[o..o + 3].copy_from_slice(&c);
        }
    }
    /// Draws `text` (upper case, digits, '.', '-') with its top-left corner at (x, y).
    fn text(&mut self, x: i64, y: i64, text: &str, c: [u8; 3]) {
        for (i, ch) in text.chars().enumerate() {
            let g = glyph(ch.to_ascii_uppercase());
            for (row, bits) in g.iter().enumerate() {
                for col in 0..5 {
                    if bits & (0x10 >> col) != 0 {
                        for (dx, dy) in (0..SCALE * SCALE).map(|k| (k % SCALE, k / SCALE)) {
                            let px = x + ((i * 6 + col) * SCALE + dx) as i64;
                            self.put(px, y + (row * SCALE + dy) as i64, c);
                        }
                    }
                }
            }
        }
    }
}

/// Tick step 1, 2 or 5 × 10^k giving at most 8 intervals up to `max`, and its decimals.
fn tick_step(max: f64) -> (f64, usize) {
    let raw = max / 8.0;
    let p = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|&s| s >= raw)
        .unwrap_or(10.0 * p);
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    (step, decimals)
}

/// Writes the plot as an 8-bit PNG.
pub fn per_view_mae(path: &Path, r: &EvalReport) -> Result<()> {
    let img = render(r);
    let buf = image::RgbImage::from_raw(W as u32, H as u32, img)
        .ok_or_else(|| Error::Invalid("plot buffer has the wrong size".into()))?;
    let mut bytes = Vec::new();
    buf.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .map_err(|e| Error::format(path, format!("encoding PNG: {e}")))?;
    crate::io::write_atomic(path, |w| {
        w.write_all(&bytes).map_err(|e| Error::io(path, e))
    })
}

/// The plot's pixels, RGB8 row-major W × H.
fn render(r: &EvalReport) -> Vec<u8> {
    let mut cv = Canvas {
        img: vec![255u8; W * H * 3],
    };
    let data_max = r
        .models
        .values()
        .flat_map(|m| m.per_view_mae.iter().copied())
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max)
        .max(1e-6);
    let (step, decimals) = tick_step(data_max);
    let max = (data_max / step).ceil().max(1.0) * step;
    let n = r
        .models
        .values()
        .map(|m| m.per_view_mae.len())
        .max()
        .unwrap_or(0);
    let (pw, ph) = ((W - LEFT - RIGHT) as f64, (H - TOP - BOTTOM) as f64);
    let to_px = |i: f64, v: f64| {
        let x = LEFT as f64 + if n > 1 { pw * i / (n - 1) as f64 } else { 0.0 };
        let y = (H - BOTTOM) as f64 - ph * (v / max);
        (x, y)
    };
    let black = [0, 0, 0];
    // Horizontal grid and y tick labels.
    let ticks = (max / step).round() as usize;
    for k in 0..=ticks {
        let v = k as f64 * step;
        let (_, y) = to_px(0.0, v);
        let y = y.round() as i64;
        for x in LEFT..W - RIGHT {
            cv.put(x as i64, y, if k == 0 { black } else { [225, 225, 225] });
        }
        for x in LEFT - 5..LEFT {
            cv.put(x as i64, y, black);
        }
        let label = format!("{v:.decimals$}");
        let x = LEFT as i64 - 8 - text_width(&label) as i64;
        cv.text(x, y - 7, &label, black);
    }
    // Vertical axis, x ticks every 10 views and their labels.
    for y in TOP..=H - BOTTOM {
        cv.put(LEFT as i64, y as i64, black);
    }
    for i in (0..n).step_by(10) {
        let (x, _) = to_px(i as f64, 0.0);
        let x = x.round() as i64;
        for y in H - BOTTOM..H - BOTTOM + 5 {
            cv.put(x, y as i64, black);
        }
        let label = i.to_string();
        cv.text(
            x - text_width(&label) as i64 / 2,
            (H - BOTTOM + 8) as i64,
            &label,
            black,
        );
    }
    let xl = "VIEW INDEX";
    cv.text(
        (LEFT + (W - LEFT - RIGHT) / 2 - text_width(xl) / 2) as i64,
        (H - 20) as i64,
        xl,
        black,
    );
    cv.text(8, 12, "MAE", black);
    // Legend (models present only) along the top, then the lines.
    let mut lx = LEFT as i64 + 60;
    for (name, colour) in COLOURS {
        let Some(m) = r.models.get(name) else {
            continue;
        };
        let label = if name == "plmc" {
            "PLM-C".to_string()
        } else {
            name.to_uppercase()
        };
        for dx in 0..24 {
            for dy in 0..3 {
                cv.put(lx + dx, 19 + dy, colour);
            }
        }
        cv.text(lx + 30, 13, &label, colour);
        lx += 30 + text_width(&label) as i64 + 28;
        for i in 1..m.per_view_mae.len() {
            let (x0, y0) = to_px((i - 1) as f64, m.per_view_mae[i - 1]);
            let (x1, y1) = to_px(i as f64, m.per_view_mae[i]);
            if !(y0.is_finite() && y1.is_finite()) {
                continue;
            }
            let steps = ((x1 - x0).abs().max((y1 - y0).abs()).ceil() as usize).max(1) * 2;
            for s in 0..=steps {
                let t = s as f64 / steps as f64;
                let (x, y) = (x0 + t * (x1 - x0), y0 + t * (y1 - y0));
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    cv.put(x.round() as i64 + dx, y.round() as i64 + dy, colour);
                }
            }
        }
    }
    cv.img
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_nice_numbers() {
        assert_eq!(tick_step(0.037), (0.005, 3));
        assert_eq!(tick_step(0.16), (0.02, 2));
        assert_eq!(tick_step(0.8), (0.1, 1));
        assert_eq!(tick_step(3.0), (0.5, 1));
    }

    #[test]
    fn text_draws_the_glyph_pixels() {
        let mut cv = Canvas {
            img: vec![255u8; W * H * 3],
        };
        cv.text(0, 0, "1", [0, 0, 0]);
        // '1' row 0 = 0x04: only column 2 set, drawn as a SCALE × SCALE block.
        let px = |x: usize, y: usize| cv.img[3 * (y * W + x)];
        assert_eq!(px(2 * SCALE, 0), 0);
        assert_eq!(px(0, 0), 255);
        assert_eq!(px(4 * SCALE, 0), 255);
        let dark = cv.img.chunks(3).filter(|p| p[0] == 0).count();
        assert_eq!(dark, 10 * SCALE * SCALE, "'1' has 10 set pixels");
        assert!(
            "0123456789.-ACDEILMNPSVWXY"
                .chars()
                .all(|c| glyph(c) != [0; 7] || c == ' ')
        );
    }
}
