//! Stage 2: a BTF source whose images are the stitched tiles of another source.

use super::Stitch;
use crate::btf::{BtfSource, DirectionSet, StoredEncoding};
use crate::{Error, Result};

/// A BTF source whose images are the stitched tiles of another source (stage 2): width = tile
/// width, height = count · tile height.
pub struct TiledSource<'a> {
    inner: &'a dyn BtfSource,
    stitch: &'a Stitch,
}

impl<'a> TiledSource<'a> {
    /// Wraps `inner`; fails unless the stitch was made for a sample of its size.
    pub fn new(inner: &'a dyn BtfSource, stitch: &'a Stitch) -> Result<Self> {
        if (inner.width(), inner.height()) != (stitch.sample_w, stitch.sample_h) {
            return Err(Error::Invalid(format!(
                "the tiles were cut from a {}×{} sample, the data are {}×{}",
                stitch.sample_w,
                stitch.sample_h,
                inner.width(),
                inner.height()
            )));
        }
        Ok(TiledSource { inner, stitch })
    }
}

impl BtfSource for TiledSource<'_> {
    fn views(&self) -> &DirectionSet {
        self.inner.views()
    }
    fn lights(&self) -> &DirectionSet {
        self.inner.lights()
    }
    fn width(&self) -> usize {
        self.stitch.tile_w
    }
    fn height(&self) -> usize {
        self.stitch.tile_h * self.stitch.count
    }
    fn encoding(&self) -> StoredEncoding {
        self.inner.encoding()
    }
    fn load_view(&self, view: usize) -> Result<Vec<f32>> {
        let data = self.inner.load_view(view)?;
        let (n_in, n_out) = (
            self.stitch.sample_w * self.stitch.sample_h * 3,
            self.stitch.texels() * 3,
        );
        let nl = self.inner.lights().len();
        let mut out = vec![0.0f32; nl * n_out];
        for (src, dst) in data.chunks_exact(n_in).zip(out.chunks_exact_mut(n_out)) {
            self.stitch.apply(src, dst);
        }
        Ok(out)
    }
}
