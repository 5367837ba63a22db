//! btfpt: an offline, physically based CPU path tracer whose signature material is the measured BTF,
//! stored raw or as the clustered polynomial Lafortune model (PLM-C) of Filip & Haindl (2005).
//!
//! See docs/conventions.md for the conventions every module follows and docs/architecture.md for the layers.

// `!(x <= max)` is the deliberate NaN-rejecting form of a bound check throughout (a NaN must fail),
// and the hot paths index several fixed-size lane arrays with one loop counter.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

pub mod bsdf;
pub mod btf;
pub mod error;
pub mod fit;
pub mod geometry;
pub mod io;
pub mod light;
pub mod math;
pub mod metrics;
pub mod model;
pub mod plugin;
pub mod render;
pub mod scene;

pub use error::{Error, Result};
