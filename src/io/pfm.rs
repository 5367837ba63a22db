//! Portable Float Map (`.pfm`) images: a text header `PF` (RGB) or `Pf` (grey), the size, and a
//! scale whose sign gives the byte order (negative = little endian), then 32-bit floats in rows
//! from the bottom of the image up. Read as linear RGB, top row first (as Mitsuba shows them).

use super::rgb_image::{MAX_IMAGE_PIXELS, RgbImage};
use crate::{Error, Result};
use std::path::Path;

/// Reads a PFM file; errors name the file.
pub fn read_pfm(path: &Path) -> Result<RgbImage> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    parse(&bytes).map_err(|m| Error::format(path, m))
}

fn parse(b: &[u8]) -> std::result::Result<RgbImage, String> {
    // Three whitespace-separated header tokens after the magic, then one whitespace byte.
    let mut pos = 0;
    let mut token = || -> std::result::Result<String, String> {
        while pos < b.len() && b[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while pos < b.len() && !b[pos].is_ascii_whitespace() {
            pos += 1;
        }
        if start == pos || pos - start > 32 {
            return Err("malformed PFM header".into());
        }
        Ok(String::from_utf8_lossy(&b[start..pos]).into_owned())
    };
    let channels = match token()?.as_str() {
        "PF" => 3,
        "Pf" => 1,
        m => return Err(format!("not a PFM file (magic {m:?}, expected PF or Pf)")),
    };
    let w: usize = token()?.parse().map_err(|_| "malformed PFM width")?;
    let h: usize = token()?.parse().map_err(|_| "malformed PFM height")?;
    let scale: f32 = token()?.parse().map_err(|_| "malformed PFM scale")?;
    let data_start = pos + 1;
    if w == 0 || h == 0 || w.checked_mul(h).is_none_or(|n| n > MAX_IMAGE_PIXELS) {
        return Err(format!("PFM size {w}×{h} is empty or too large"));
    }
    if scale == 0.0 || !scale.is_finite() {
        return Err(format!("PFM scale {scale} must be finite and non-zero"));
    }
    let n = w * h * channels;
    let data = b
        .get(data_start..)
        .filter(|d| d.len() >= 4 * n)
        .ok_or_else(|| format!("PFM data is truncated (expected {} bytes)", 4 * n))?;
    let little = scale < 0.0;
    let value = |i: usize| {
        let a = [
            data[4 * i],
            data[4 * i + 1],
            data[4 * i + 2],
            data[4 * i + 3],
        ];
        if little {
            f32::from_le_bytes(a)
        } else {
            f32::from_be_bytes(a)
        }
    };
    let mut img = RgbImage::new(w, h);
    for y in 0..h {
        let row = h - 1 - y;
        for x in 0..w {
            let i = (row * w + x) * channels;
            let v = if channels == 3 {
                [value(i), value(i + 1), value(i + 2)]
            } else {
                [value(i); 3]
            };
            img.set(x, y, v);
        }
    }
    Ok(img)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pfm(magic: &str, w: usize, h: usize, scale: f32, vals: &[f32]) -> Vec<u8> {
        let mut b = format!("{magic}\n{w} {h}\n{scale}\n").into_bytes();
        for v in vals {
            if scale < 0.0 {
                b.extend_from_slice(&v.to_le_bytes());
            } else {
                b.extend_from_slice(&v.to_be_bytes());
            }
        }
        b
    }

    #[test]
    fn rows_are_bottom_up_and_both_byte_orders_read() {
        // 1×2 RGB: the first row in the file is the bottom of the image.
        let vals = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        for scale in [-1.0, 1.0] {
            let img = parse(&pfm("PF", 1, 2, scale, &vals)).unwrap();
            assert_eq!(img.get(0, 1), [1.0, 2.0, 3.0]);
            assert_eq!(img.get(0, 0), [4.0, 5.0, 6.0]);
        }
        let grey = parse(&pfm("Pf", 2, 1, -1.0, &[0.5, 0.25])).unwrap();
        assert_eq!(grey.get(1, 0), [0.25; 3]);
    }

    #[test]
    fn bad_files_are_clear_errors() {
        assert!(parse(b"P6\n1 1\n255\n").unwrap_err().contains("not a PFM"));
        let short = pfm("PF", 2, 2, -1.0, &[1.0; 5]);
        assert!(parse(&short).unwrap_err().contains("truncated"));
        assert!(parse(b"PF\n0 3\n-1\n").unwrap_err().contains("empty"));
        assert!(parse(b"PF\nx 3\n-1\n").unwrap_err().contains("width"));
    }
}
