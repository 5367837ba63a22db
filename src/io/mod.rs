//! File input/output shared by all subsystems: images (EXR, Radiance HDR, PFM, PNG, JPEG) and
//! atomic writes.

pub mod atomic;
pub mod bytes;
pub mod glyph;
pub mod image;
pub mod pfm;
pub mod rgb_image;
pub mod shared;

pub use atomic::write_atomic;
pub use image::{read_image, read_image_as, write_exr, write_png_srgb};
pub use rgb_image::RgbImage;
