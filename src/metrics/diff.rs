//! False-colour difference images (for a PNG): a diverging blue–white–red map, blue where the
//! test image is darker than the reference, red where it is brighter; cells beyond the failure
//! threshold are drawn saturated cyan / magenta so failures stand out.

use super::{check_same_size, ztest::ZTest};
use crate::Result;
use crate::io::RgbImage;
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
}
