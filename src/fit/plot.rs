//! Per-view MAE plot like the paper's Fig. 6, drawn directly into an RGB PNG (no font needed):
//! x = view index, y = MAE from 0 (bottom) to the largest value (top) with grid lines every 0.01;
//! colours: LM blue, PLM green, PLM-C red, PCA grey.

use super::evaluate::EvalReport;
use crate::{Error, Result};
use std::path::Path;

const W: usize = 820;
const H: usize = 420;
const MARGIN: usize = 20;

/// Colours of the model lines, in the order lm, plm, plmc, pca.
pub const COLOURS: [(&str, [u8; 3]); 4] = [
    ("lm", [40, 80, 220]),
    ("plm", [30, 160, 60]),
    ("plmc", [220, 40, 40]),
    ("pca", [120, 120, 120]),
];

/// Writes the plot as an 8-bit PNG.
pub fn per_view_mae(path: &Path, r: &EvalReport) -> Result<()> {
    let mut img = vec![255u8; W * H * 3];
    let max = r
        .models
        .values()
        .flat_map(|m| m.per_view_mae.iter().copied())
        .fold(0.0f64, f64::max)
        .max(1e-6);
    let n = r
        .models
        .values()
        .map(|m| m.per_view_mae.len())
        .max()
        .unwrap_or(0);
    let (pw, ph) = ((W - 2 * MARGIN) as f64, (H - 2 * MARGIN) as f64);
    let to_px = |i: usize, v: f64| {
        let x = MARGIN as f64
            + if n > 1 {
                pw * i as f64 / (n - 1) as f64
            } else {
                0.0
            };
        let y = (H - MARGIN) as f64 - ph * (v / max);
        (x, y)
    };
    let mut put = |x: i64, y: i64, c: [u8; 3]| {
        if (0..W as i64).contains(&x) && (0..H as i64).contains(&y) {
            let o = 3 * (y as usize * W + x as usize);
            img[o..o + 3].copy_from_slice(&c);
        }
    };
    // Grid every 0.01 and the axes.
    let mut g = 0.0;
    while g <= max {
        let (_, y) = to_px(0, g);
        for x in MARGIN..W - MARGIN {
            put(
                x as i64,
                y.round() as i64,
                if g == 0.0 { [0, 0, 0] } else { [225, 225, 225] },
            );
        }
        g += 0.01;
    }
    for y in MARGIN..=H - MARGIN {
        put(MARGIN as i64, y as i64, [0, 0, 0]);
    }
    for (name, colour) in COLOURS {
        let Some(m) = r.models.get(name) else {
            continue;
        };
        for i in 1..m.per_view_mae.len() {
            let (x0, y0) = to_px(i - 1, m.per_view_mae[i - 1]);
            let (x1, y1) = to_px(i, m.per_view_mae[i]);
            let steps = ((x1 - x0).abs().max((y1 - y0).abs()).ceil() as usize).max(1) * 2;
            for s in 0..=steps {
                let t = s as f64 / steps as f64;
                let (x, y) = (x0 + t * (x1 - x0), y0 + t * (y1 - y0));
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    put(x.round() as i64 + dx, y.round() as i64 + dy, colour);
                }
            }
        }
    }
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
