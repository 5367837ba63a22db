//! The linear-RGB float image every reader returns and every writer takes, and the largest one a
//! reader accepts.

/// Largest image read (pixels): 16384² ≈ 3 GiB of linear RGB; larger headers are corrupt or absurd.
pub const MAX_IMAGE_PIXELS: usize = 1 << 28;

/// A linear RGB image, row-major, row 0 at the top, `data.len() == 3 * width * height`.
#[derive(Clone, Debug, PartialEq)]
pub struct RgbImage {
    pub width: usize,
    pub height: usize,
    pub data: Vec<f32>,
}

impl RgbImage {
    /// Refuses images holding NaN or infinite values (they would poison every sample that sees
    /// them): the message names `path` and the first such pixel.
    pub fn check_finite(&self, path: &std::path::Path) -> Result<(), String> {
        match self.data.iter().position(|v| !v.is_finite()) {
            None => Ok(()),
            Some(i) => {
                let px = i / 3;
                Err(format!(
                    "{}: pixel ({}, {}) is NaN or infinite; images must hold finite values",
                    path.display(),
                    px % self.width.max(1),
                    px / self.width.max(1)
                ))
            }
        }
    }

    /// A black image.
    pub fn new(width: usize, height: usize) -> Self {
        RgbImage {
            width,
            height,
            data: vec![0.0; 3 * width * height],
        }
    }

    /// The RGB triple at column `x`, row `y`.
    #[inline]
    pub fn get(&self, x: usize, y: usize) -> [f32; 3] {
        let i = 3 * (y * self.width + x);
        [self.data[i], self.data[i + 1], self.data[i + 2]]
    }

    /// Sets the RGB triple at column `x`, row `y`.
    #[inline]
    pub fn set(&mut self, x: usize, y: usize, v: [f32; 3]) {
        let i = 3 * (y * self.width + x);
        self.data[i..i + 3].copy_from_slice(&v);
    }
}
