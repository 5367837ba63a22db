//! Linear-RGB float images: read EXR (linear) and PNG/JPEG (sRGB-decoded), write EXR and sRGB PNG.

use super::rgb_image::{MAX_IMAGE_PIXELS, RgbImage};
use crate::math::color::{linear_to_srgb, srgb_to_linear, srgb8_to_linear_table};
use crate::{Error, Result};
use std::path::Path;

fn extension(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase()
}

/// Reads an image as linear RGB: EXR, Radiance `.hdr` and `.pfm` as stored; 8- and 16-bit
/// PNG/JPEG decoded with the sRGB EOTF (Mitsuba's default for integer formats). Errors name the file.
pub fn read_image(path: &Path) -> Result<RgbImage> {
    read_image_as(path, true)
}

/// [`read_image`], with `srgb_decode = false` keeping 8- and 16-bit PNG/JPEG values as stored
/// (scaled to [0, 1]: Mitsuba's `raw` bitmaps); float formats are read as stored either way.
pub fn read_image_as(path: &Path, srgb_decode: bool) -> Result<RgbImage> {
    if !path.exists() {
        return Err(Error::format(path, "file not found"));
    }
    match extension(path).as_str() {
        "exr" => read_exr(path),
        "png" | "jpg" | "jpeg" | "bmp" => read_ldr(path, srgb_decode),
        "hdr" => read_hdr(path),
        "pfm" => super::pfm::read_pfm(path),
        other => Err(Error::format(
            path,
            format!(
                "unsupported image format '.{other}' (expected .exr, .hdr, .pfm, .png, .jpg, .bmp)"
            ),
        )),
    }
}

fn read_exr(path: &Path) -> Result<RgbImage> {
    use exr::prelude::*;
    // Check the header's data window before the pixel buffer is allocated from it.
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| crate::Error::format(path, format!("cannot read EXR: {e}")))?;
    for h in &meta.headers {
        let (w, hgt) = (h.layer_size.width(), h.layer_size.height());
        if w.checked_mul(hgt).is_none_or(|n| n > MAX_IMAGE_PIXELS) {
            return Err(crate::Error::format(
                path,
                format!(
                    "EXR data window {w}×{hgt} is corrupt or larger than {MAX_IMAGE_PIXELS} pixels"
                ),
            ));
        }
    }
    let img = read_first_rgba_layer_from_file(
        path,
        |res: Vec2<usize>, _| RgbImage::new(res.width(), res.height()),
        |img: &mut RgbImage, pos: Vec2<usize>, (r, g, b, _a): (f32, f32, f32, f32)| {
            img.set(pos.x(), pos.y(), [r, g, b]);
        },
    )
    .map_err(|e| crate::Error::format(path, format!("cannot read EXR: {e}")))?;
    Ok(img.layer_data.channel_data.pixels)
}

/// Radiance RGBE through the `image` crate's HDR decoder (linear, as Mitsuba reads it).
fn read_hdr(path: &Path) -> Result<RgbImage> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let dec = image::codecs::hdr::HdrDecoder::new(std::io::BufReader::new(file))
        .map_err(|e| Error::format(path, format!("cannot read Radiance HDR: {e}")))?;
    let meta = dec.metadata();
    let (w, h) = (meta.width as usize, meta.height as usize);
    if w.checked_mul(h).is_none_or(|n| n > MAX_IMAGE_PIXELS) {
        return Err(Error::format(
            path,
            format!("Radiance HDR size {w}×{h} is larger than {MAX_IMAGE_PIXELS} pixels"),
        ));
    }
    let img = image::DynamicImage::from_decoder(dec)
        .map_err(|e| Error::format(path, format!("cannot decode Radiance HDR: {e}")))?;
    Ok(RgbImage {
        width: w,
        height: h,
        data: img.to_rgb32f().into_raw(),
    })
}

fn read_ldr(path: &Path, srgb_decode: bool) -> Result<RgbImage> {
    let dynimg = image::ImageReader::open(path)
        .map_err(|e| Error::io(path, e))?
        .with_guessed_format()
        .map_err(|e| Error::io(path, e))?
        .decode()
        .map_err(|e| Error::format(path, format!("cannot decode image: {e}")))?;
    let (w, h) = (dynimg.width() as usize, dynimg.height() as usize);
    let data = match dynimg {
        image::DynamicImage::ImageLuma16(_)
        | image::DynamicImage::ImageLumaA16(_)
        | image::DynamicImage::ImageRgb16(_)
        | image::DynamicImage::ImageRgba16(_) => dynimg
            .to_rgb16()
            .into_raw()
            .into_iter()
            .map(|v| {
                let v = v as f32 / 65535.0;
                if srgb_decode { srgb_to_linear(v) } else { v }
            })
            .collect(),
        _ => {
            let lut = srgb8_to_linear_table();
            dynimg
                .to_rgb8()
                .into_raw()
                .into_iter()
                .map(|v| {
                    if srgb_decode {
                        lut[v as usize]
                    } else {
                        v as f32 / 255.0
                    }
                })
                .collect()
        }
    };
    Ok(RgbImage {
        width: w,
        height: h,
        data,
    })
}

/// Writes linear RGB as 32-bit float EXR, atomically.
pub fn write_exr(path: &Path, img: &RgbImage) -> Result<()> {
    use exr::prelude::*;
    super::atomic::write_atomic(path, |w| {
        let channels = SpecificChannels::rgb(|pos: Vec2<usize>| {
            let p = img.get(pos.x(), pos.y());
            (p[0], p[1], p[2])
        });
        let image = Image::from_channels((img.width, img.height), channels);
        let mut buf = std::io::Cursor::new(Vec::new());
        image
            .write()
            .to_buffered(&mut buf)
            .map_err(|e| crate::Error::format(path, format!("cannot encode EXR: {e}")))?;
        w.write_all(buf.get_ref())
            .map_err(|e| crate::Error::io(path, e))
    })
}

/// Writes an sRGB-encoded 8-bit PNG preview of linear RGB (clamped to [0, 1]), atomically.
pub fn write_png_srgb(path: &Path, img: &RgbImage) -> Result<()> {
    let bytes: Vec<u8> = img
        .data
        .iter()
        .map(|&v| {
            let v = if v.is_finite() {
                v.clamp(0.0, 1.0)
            } else {
                0.0
            };
            (linear_to_srgb(v) * 255.0 + 0.5) as u8
        })
        .collect();
    super::atomic::write_atomic(path, |w| {
        let mut buf = std::io::Cursor::new(Vec::new());
        image::write_buffer_with_format(
            &mut buf,
            &bytes,
            img.width as u32,
            img.height as u32,
            image::ExtendedColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(|e| Error::format(path, format!("cannot encode PNG: {e}")))?;
        w.write_all(buf.get_ref()).map_err(|e| Error::io(path, e))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radiance_hdr_reads_linear_top_row_first() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.hdr");
        // Powers of two are exact in RGBE; row 0 is the top of the image.
        let px = [
            image::Rgb([1.0f32, 0.5, 0.25]),
            image::Rgb([2.0, 4.0, 8.0]),
            image::Rgb([0.125, 0.0, 1.0]),
            image::Rgb([16.0, 1.0, 0.5]),
        ];
        let f = std::fs::File::create(&p).unwrap();
        image::codecs::hdr::HdrEncoder::new(f)
            .encode(&px, 2, 2)
            .unwrap();
        let img = read_image(&p).unwrap();
        assert_eq!((img.width, img.height), (2, 2));
        assert_eq!(img.get(1, 0), [2.0, 4.0, 8.0]);
        assert_eq!(img.get(0, 1), [0.125, 0.0, 1.0]);
        std::fs::write(&p, b"#?RADIANCE\ngarbage").unwrap();
        let e = read_image(&p).unwrap_err().to_string();
        assert!(e.contains("t.hdr"), "{e}");
    }

    fn test_image() -> RgbImage {
        let mut img = RgbImage::new(5, 3);
        for y in 0..3 {
            for x in 0..5 {
                img.set(x, y, [x as f32 * 0.25, y as f32 * 0.5, 0.125 + x as f32]);
            }
        }
        img
    }

    #[test]
    fn exr_round_trip_is_exact() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.exr");
        let img = test_image();
        write_exr(&p, &img).unwrap();
        assert_eq!(read_image(&p).unwrap(), img);
    }

    #[test]
    fn png_round_trip_within_quantisation() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.png");
        let mut img = test_image();
        img.data.iter_mut().for_each(|v| *v = v.min(1.0));
        write_png_srgb(&p, &img).unwrap();
        let back = read_image(&p).unwrap();
        for (a, b) in img.data.iter().zip(&back.data) {
            assert!((linear_to_srgb(*a) - linear_to_srgb(*b)).abs() <= 0.5 / 255.0 + 1e-6);
        }
    }

    #[test]
    fn corrupt_and_missing_files_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bad.exr");
        std::fs::write(&p, b"not an exr").unwrap();
        assert!(read_image(&p).unwrap_err().to_string().contains("bad.exr"));
        let q = dir.path().join("missing.png");
        assert!(
            read_image(&q)
                .unwrap_err()
                .to_string()
                .contains("missing.png")
        );
    }
}
