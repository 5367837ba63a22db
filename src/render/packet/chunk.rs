//! A packet render's unit of work: a rectangle of pixels for a run of sample indices, and what
//! each traced work item leaves for the film.

use crate::math::Spectrum;

/// The work of one call: `samples` consecutive sample indices from `sample0` for every pixel
/// of the `w`×`h` rectangle at (`x0`, `y0`); work item j = sample-offset · w·h + pixel.
#[derive(Clone, Copy, Debug)]
pub struct Chunk {
    pub x0: u32,
    pub y0: u32,
    pub w: u32,
    pub h: u32,
    pub sample0: u32,
    pub samples: u32,
    /// Full film width (pixel index = y · width + x) and the render's seed.
    pub film_width: u32,
    pub seed: u64,
}

/// One traced work item: the path's radiance and the film position its camera ray went
/// through (what the film's reconstruction filter weighs it by).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FilmSample {
    pub l: Spectrum,
    pub pos: [f32; 2],
}
