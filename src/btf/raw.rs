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

impl StoredEncoding {
    /// A linear value in this encoding, normalised to [0, 1] for 8-bit data (sRGB data are
    /// clamped to [0, 1], what an 8-bit store can hold): the space of the paper's error measure.
    #[inline]
    pub fn encode(self, v: f32) -> f32 {
        match self {
            StoredEncoding::Srgb8 => crate::math::color::linear_to_srgb(v.clamp(0.0, 1.0)),
            StoredEncoding::Linear => v,
        }
    }
}

/// Anything that can hand out a BTF one view at a time (a folder on disk, a cache, memory).
/// Values are linear RGB, cosine-baked (docs/conventions.md).
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

/// Where the f16 values of a [`RawBtf`] live: owned memory, or a read-only memory map of a
/// `.btfc` cache (so a multi-GB material opens without copying).
#[derive(Clone, Debug)]
enum Storage {
    Owned(Vec<f16>),
    Mapped {
        map: std::sync::Arc<memmap2::Mmap>,
        /// Byte offset of the first value in the map (even, so the cast to f16 is aligned).
        offset: usize,
        /// Number of f16 values.
        len: usize,
    },
}

impl Storage {
    #[inline]
    fn as_slice(&self) -> &[f16] {
        match self {
            Storage::Owned(v) => v,
            Storage::Mapped { map, offset, len } => {
                bytemuck::cast_slice(&map[*offset..*offset + 2 * *len])
            }
        }
    }
}

/// A whole BTF as f16, laid out `[view][light][row][column][rgb]` (in memory or memory-mapped).
#[derive(Clone, Debug)]
pub struct RawBtf {
    views: DirectionSet,
    lights: DirectionSet,
    width: usize,
    height: usize,
    encoding: StoredEncoding,
    data: Storage,
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
            data: Storage::Owned(data),
        })
    }

    /// Wraps `len` little-endian f16 values starting at byte `offset` of a memory map (used by the
    /// `.btfc` cache). Fails unless the range lies inside the map, is 2-byte aligned, and `len`
    /// matches the dimensions. Only available on little-endian hosts (the file is little-endian).
    #[cfg(target_endian = "little")]
    pub(crate) fn from_mapped(
        views: DirectionSet,
        lights: DirectionSet,
        width: usize,
        height: usize,
        encoding: StoredEncoding,
        map: std::sync::Arc<memmap2::Mmap>,
        offset: usize,
    ) -> Result<Self> {
        let len = views.len() * lights.len() * width * height * 3;
        let end = len.checked_mul(2).and_then(|b| b.checked_add(offset));
        let aligned = (map.as_ptr() as usize + offset).is_multiple_of(std::mem::align_of::<f16>());
        if width == 0 || height == 0 || !aligned || end.is_none_or(|e| e > map.len()) {
            return Err(Error::Invalid(format!(
                "mapped BTF data of {len} values at byte {offset} does not fit a map of {} bytes",
                map.len()
            )));
        }
        Ok(RawBtf {
            views,
            lights,
            width,
            height,
            encoding,
            data: Storage::Mapped { map, offset, len },
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
        let d = self.data.as_slice();
        [d[i].to_f32(), d[i + 1].to_f32(), d[i + 2].to_f32()]
    }

    /// The raw f16 values, `[view][light][row][column][rgb]`.
    pub fn data(&self) -> &[f16] {
        self.data.as_slice()
    }

    /// True if the values are memory-mapped from a `.btfc` cache rather than owned.
    pub fn is_mapped(&self) -> bool {
        matches!(self.data, Storage::Mapped { .. })
    }

    /// The f16 values of one view, `[light][row][column][rgb]`.
    pub fn view_data(&self, view: usize) -> &[f16] {
        let n = self.lights.len() * self.height * self.width * 3;
        &self.data()[view * n..(view + 1) * n]
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
        Ok(self.view_data(view).iter().map(|v| v.to_f32()).collect())
    }
}
