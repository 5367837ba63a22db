//! False-colour difference images (for a PNG): a diverging blue–white–red map, blue where the
//! test image is darker than the reference, red where it is brighter; cells beyond the failure
//! threshold are drawn saturated cyan / magenta so failures stand out. [`with_legend`] adds the
//! scale under the image.

use super::{check_same_size, ztest::ZTest};
use crate::Result;
use crate::io::RgbImage;
use crate::io::glyph::{draw_text, text_width};
use crate::math::Vec3;
use crate::math::color::{luminance, srgb_to_linear};

/// Colour (linear RGB, ready for [`crate::io::write_png_srgb`]) of a signed value `v` scaled so
/// that ±1 is full strength; |v| > 1 is a failure colour, NaN is yellow.
pub fn diverging(v: f64) -> [f32; 3] {
    let srgb: [f32; 3] = if v.is_nan() {
        [1.0, 1.0, 0.0]
    } else if v > 1.0 {
        [1.0, 0.0, 1.0]
    } else if v < -1.0 {
        [0.0, 1.0, 1.0]
    } else {
        let a = v.abs() as f32;
        if v >= 0.0 {
            [1.0, 1.0 - 0.85 * a, 1.0 - 0.85 * a]
        } else {
            [1.0 - 0.85 * a, 1.0 - 0.85 * a, 1.0]
        }
    };
    srgb.map(srgb_to_linear)
}

/// Per-pixel false colour of a z-test: each cell shows its channel of largest |z|, scaled by the
/// test's threshold (white = 0, full blue/red = at the threshold, cyan/magenta = failing). Block
/// tests are drawn at pixel resolution (each block a b×b square).
pub fn z_diff_image(z: &ZTest) -> RgbImage {
    let b = z.block;
    let mut img = RgbImage::new(z.cells_x * b, z.cells_y * b);
    for cy in 0..z.cells_y {
        for cx in 0..z.cells_x {
            let i = 3 * (cy * z.cells_x + cx);
            let zz = &z.z[i..i + 3];
            let m = zz
                .iter()
                .copied()
                .fold(0.0f32, |a, v| if v.abs() > a.abs() { v } else { a });
            let col = diverging(m as f64 / z.threshold);
            for y in cy * b..(cy + 1) * b {
                for x in cx * b..(cx + 1) * b {
                    img.set(x, y, col);
                }
            }
        }
    }
    // Cells that failed without a finite z (zero-variance mismatch, NaN) are not in `z`: mark
    // the listed ones.
    for o in &z.worst {
        if !o.z.is_finite() {
            let col = diverging(if o.z.is_nan() { f64::NAN } else { o.z });
            for y in o.y * b..(o.y + 1) * b {
                for x in o.x * b..(o.x + 1) * b {
                    img.set(x, y, col);
                }
            }
        }
    }
    img
}

/// Per-pixel false colour of the relative luminance difference (Y_t − Y_r) / (Y_r + 0.01),
/// full colour at ±`scale` (e.g. 0.1 = 10 %), failure colours beyond; for use without a variance.
pub fn relative_diff_image(test: &RgbImage, reference: &RgbImage, scale: f64) -> Result<RgbImage> {
    check_same_size(test, reference, "difference image")?;
    let mut img = RgbImage::new(test.width, test.height);
    for y in 0..test.height {
        for x in 0..test.width {
            let lum = |p: [f32; 3]| luminance(Vec3::from_array(p)) as f64;
            let (t, r) = (lum(test.get(x, y)), lum(reference.get(x, y)));
            img.set(x, y, diverging((t - r) / (r + 0.01) / scale));
        }
    }
    Ok(img)
}

/// Rows the legend adds under the image.
pub const LEGEND_ROWS: usize = 18;

/// `img` with its colour scale drawn underneath on a dark strip: cyan (below the scale), the
/// blue–white–red ramp from −`label` to +`label`, magenta (beyond), and the labels "-label",
/// "0", "+label" under the ramp's ends and middle. The strip is at least wide enough for the
/// labels (the image is then padded on the right with the strip's colour).
pub fn with_legend(img: &RgbImage, label: &str) -> RgbImage {
    let (lo, hi) = (format!("-{label}"), format!("+{label}"));
    let end = 6; // width of the cyan / magenta end patches
    let width = img
        .width
        .max(2 * end + text_width(&lo) + text_width(&hi) + 24);
    let bg = [0.02f32; 3];
    let mut out = RgbImage::new(width, img.height + LEGEND_ROWS);
    out.data
        .chunks_exact_mut(3)
        .for_each(|p| p.copy_from_slice(&bg));
    for y in 0..img.height {
        for x in 0..img.width {
            out.set(x, y, img.get(x, y));
        }
    }
    let y0 = img.height + 2;
    let ramp = width - 2 * end;
    for x in 0..width {
        let col = if x < end {
            diverging(-2.0)
        } else if x >= width - end {
            diverging(2.0)
        } else {
            let t = (x - end) as f64 / (ramp - 1).max(1) as f64;
            diverging(2.0 * t - 1.0)
        };
        for y in y0..y0 + 6 {
            out.set(x, y, col);
        }
    }
    let white = [1.0f32; 3];
    let ty = y0 + 8;
    draw_text(&mut out, end, ty, &lo, white);
    draw_text(&mut out, width / 2 - 2, ty, "0", white);
    draw_text(&mut out, width - end - text_width(&hi) + 1, ty, &hi, white);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::z_test;

    #[test]
    fn colours_of_the_map() {
        assert_eq!(diverging(0.0), [1.0, 1.0, 1.0]);
        let red = diverging(1.0);
        assert!(red[0] == 1.0 && red[1] < 0.05 && red[1] == red[2]);
        let blue = diverging(-1.0);
        assert!(blue[2] == 1.0 && blue[0] < 0.05);
        assert_eq!(diverging(3.0), [1.0, 0.0, 1.0]);
        assert_eq!(diverging(-3.0), [0.0, 1.0, 1.0]);
        assert_eq!(diverging(f64::NAN), [1.0, 1.0, 0.0]);
        // Monotone: stronger deviation = less white.
        assert!(diverging(0.5)[1] > diverging(0.9)[1]);
    }

    #[test]
    fn z_image_marks_failures_where_they_are() {
        let (w, h) = (8, 4);
        let r = RgbImage {
            width: w,
            height: h,
            data: vec![0.5; 3 * w * h],
        };
        let mut t = r.clone();
        let v = RgbImage {
            width: w,
            height: h,
            data: vec![1e-4; 3 * w * h],
        };
        t.set(6, 1, [0.5, 0.6, 0.5]); // z = +10
        t.set(1, 2, [0.49, 0.5, 0.5]); // z = −1
        let z = z_test(&t, &r, &v, 1, 0.01).unwrap();
        let img = z_diff_image(&z);
        assert_eq!((img.width, img.height), (w, h));
        assert_eq!(img.get(6, 1), [1.0, 0.0, 1.0]);
        assert_eq!(img.get(0, 0), [1.0, 1.0, 1.0]);
        let p = img.get(1, 2);
        assert!(p[2] == 1.0 && p[0] < 1.0, "{p:?}");
        // Block test: the 4×4 block holding (6, 1) is coloured, at pixel resolution.
        let zb = z_test(&t, &r, &v, 4, 0.01).unwrap();
        let ib = z_diff_image(&zb);
        assert_eq!((ib.width, ib.height), (8, 4));
        assert_eq!(ib.get(4, 0), ib.get(7, 3));
        assert_ne!(ib.get(4, 0), [1.0, 1.0, 1.0]);
    }

    #[test]
    fn relative_image() {
        let r = RgbImage {
            width: 2,
            height: 1,
            data: vec![1.0; 6],
        };
        let mut t = r.clone();
        t.set(1, 0, [1.2; 3]);
        let img = relative_diff_image(&t, &r, 0.1).unwrap();
        assert_eq!(img.get(0, 0), [1.0; 3]);
        assert_eq!(img.get(1, 0), [1.0, 0.0, 1.0]);
        let small = RgbImage::new(1, 1);
        assert!(relative_diff_image(&small, &r, 0.1).is_err());
    }

    #[test]
    fn legend_shows_the_scale_under_the_image() {
        let r = RgbImage {
            width: 200,
            height: 3,
            data: vec![0.5; 3 * 200 * 3],
        };
        let l = with_legend(&r, "10%");
        assert_eq!((l.width, l.height), (200, 3 + LEGEND_ROWS));
        assert_eq!(l.get(10, 1), [0.5; 3]);
        let bar = 3 + 4;
        // Cyan left end, magenta right end, white in the middle, blue and red halfway.
        assert_eq!(l.get(0, bar), [0.0, 1.0, 1.0]);
        assert_eq!(l.get(199, bar), [1.0, 0.0, 1.0]);
        let mid = l.get(100, bar);
        assert!(mid.iter().all(|&c| c > 0.95), "{mid:?}");
        assert!(l.get(50, bar)[2] > l.get(50, bar)[0]);
        assert!(l.get(150, bar)[0] > l.get(150, bar)[2]);
        // Labels: white pixels in the text row, at both ends and the middle.
        let lit = |x0: usize, x1: usize| {
            (x0..x1).any(|x| (3 + 10..3 + LEGEND_ROWS).any(|y| l.get(x, y) == [1.0; 3]))
        };
        assert!(lit(0, 30) && lit(95, 105) && lit(170, 200));
        // A narrow image gets a strip wide enough for its labels.
        let n = with_legend(&RgbImage::new(8, 8), "4.89Z");
        assert!(n.width >= 2 * 6 + 2 * 36, "{}", n.width);
    }
}
