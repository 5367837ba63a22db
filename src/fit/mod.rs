//! Fitting a measured BTF to the one-lobe Lafortune model (LM), its polynomial extension (PLM) and
//! the clustered PLM-C of Filip & Haindl (2005), plus the per-view PCA baseline.

pub mod evaluate;
pub mod kmeans;
pub mod lafortune;
pub mod model;
pub mod pca;
pub mod pipeline;
pub mod plot;
pub mod polynomial;
pub mod report;
pub mod select;
