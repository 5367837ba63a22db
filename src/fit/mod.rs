//! Fitting a measured BTF to the one-lobe Lafortune model (LM), its polynomial extension (PLM) and
//! the clustered PLM-C of Filip & Haindl (2005), plus the per-view PCA baseline.
//!
//! The numeric kernels index several arrays with one loop variable; iterator rewrites obscure them.
#![allow(clippy::needless_range_loop)]

pub mod eval_file;
pub mod evaluate;
pub mod lafortune;
pub mod mapping;
pub mod options;
pub mod parts;
pub mod pca;
pub mod pipeline;
pub mod plot;
pub mod refine;
pub mod report;
pub mod select;
pub mod view_fit;
pub mod view_selection;
