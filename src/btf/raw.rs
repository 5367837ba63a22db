//! The raw measured BTF in memory, and the per-view streaming interface the fitter reads through.

use super::DirectionSet;
use crate::{Error, Result};
use half::f16;

/// How the data were stored at the source; the paper's MAE is computed in this encoding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StoredEncoding {
    /// 8-bit sRGB (UBO2003 JPEG/PNG): MAE on value/255 of the sRGB code.
    Srgb8,
    /// Linear floats (EXR, UBO2014, our simulator): MAE on the linear values.
    Linear,
}

/// Anything that can hand out a BTF one view at a time (a folder on disk, a cache, memory).
/// Values are linear RGB, cosine-baked (DESIGN §2).
pub trait BtfSource: Sync {
    fn views(&self) -> &DirectionSet;
    fn lights(&self) -> &DirectionSet;
    /// Texels per row.
    fn width(&self) -> usize;
    /// Rows.
    fn height(&self) -> usize;
    fn encoding(&self) -> StoredEncoding;
    /// All images of one view as `[light][row][column][rgb]`, `len = lights·height·width·3`.
    fn load_view(&self, view: usize) -> Result<Vec<f32>>;
}

/// A whole BTF in memory as f16, laid out `[view][light][row][column][rgb]`.
#[derive(Clone, Debug)]
pub struct RawBtf {
    views: DirectionSet,
    lights: DirectionSet,
    width: usize,
    height: usize,
    encoding: StoredEncoding,
    data: Vec<f16>,
}

impl RawBtf {
    /// Builds a BTF from f16 values in `[view][light][row][column][rgb]` order.
    pub fn from_f16(
        views: DirectionSet,
        lights: DirectionSet,
        width: usize,
        height: usize,
        encoding: StoredEncoding,
        data: Vec<f16>,
    ) -> Result<Self> {
        let expected = views.len() * lights.len() * width * height * 3;
        if data.len() != expected || width == 0 || height == 0 {
            return Err(Error::Invalid(format!(
                "BTF data has {} values, expected {} ({} views × {} lights × {}×{} texels × 3)",
                data.len(),
                expected,
                views.len(),
                lights.len(),
                width,
                height
            )));
        }
        Ok(RawBtf {
            views,
            lights,
            width,
            height,
            encoding,
            data,
        })
    }

    /// Builds a BTF from f32 values (converted to f16) in `[view][light][row][column][rgb]` order.
    pub fn from_f32(
        views: DirectionSet,
        lights: DirectionSet,
        width: usize,
        height: usize,
        encoding: StoredEncoding,
        data: &[f32],
    ) -> Result<Self> {
        let data = data.iter().map(|&v| f16::from_f32(v)).collect();
        Self::from_f16(views, lights, width, height, encoding, data)
    }

    /// Linear RGB at (view, light, column x, row y).
    #[inline]
    pub fn texel(&self, view: usize, light: usize, x: usize, y: usize) -> [f32; 3] {
        let i = 3 * (((view * self.lights.len() + light) * self.height + y) * self.width + x);
        [
            self.data[i].to_f32(),
            self.data[i + 1].to_f32(),
            self.data[i + 2].to_f32(),
        ]
    }

    /// The raw f16 values, `[view][light][row][column][rgb]`.
    pub fn data(&self) -> &[f16] {
        &self.data
    }
}

impl BtfSource for RawBtf {
    fn views(&self) -> &DirectionSet {
        &self.views
    }
    fn lights(&self) -> &DirectionSet {
        &self.lights
    }
    fn width(&self) -> usize {
        self.width
    }
    fn height(&self) -> usize {
        self.height
    }
    fn encoding(&self) -> StoredEncoding {
        self.encoding
    }
    fn load_view(&self, view: usize) -> Result<Vec<f32>> {
        if view >= self.views.len() {
            return Err(Error::Invalid(format!(
                "view {view} out of range ({} views)",
                self.views.len()
            )));
        }
        let n = self.lights.len() * self.height * self.width * 3;
        Ok(self.data[view * n..(view + 1) * n]
            .iter()
            .map(|v| v.to_f32())
            .collect())
    }
}
