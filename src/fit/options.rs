//! What `btfpt fit` can be asked: the model, cluster and feature counts, the fitting space and
//! the refinement switches; and the space the model's values then live in.

use crate::btf::StoredEncoding;
use crate::model::{ModelKind, ValueSpace};

/// Fitting settings (the `btfpt fit` options).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitOptions {
    pub kind: ModelKind,
    /// K of K-means per view and channel (PLM-C).
    pub clusters: usize,
    /// Images chosen by KL selection as K-means features (PLM-C).
    pub features: usize,
    /// Seed of the k-means++ initialisation.
    pub seed: u64,
    /// Cap on Lloyd iterations.
    pub kmeans_iters: usize,
    /// Fit in the data's stored encoding (sRGB for 8-bit data) instead of linear values.
    pub fit_stored: bool,
    /// What K-means clusters the texels on (PLM-C).
    pub cluster_on: ClusterOn,
    /// Rounds of model-space refinement after K-means (PLM-C; 0 = the paper's method, see
    /// [`refine`]).
    pub refine_iters: usize,
}

/// Reweighting rounds of the least-absolute-error mapping regression (see [`fit_polys`]).
pub const L1_ROUNDS: usize = 4;

/// Rounds of the second refinement, through the PLM-C mappings (see [`fit_view`]).
pub const SECOND_REFINE_ITERS: usize = 2;

/// Clusters a texel may move to per refinement round (the nearest to its own, by lobe curve).
pub const REFINE_CANDIDATES: usize = 16;

/// The K-means features of PLM-C: each texel's values in the KL-selected images, either measured
/// or as its own LM lobe predicts them.
///
/// The paper clusters the original values. Measured values carry per-texel noise and detail the
/// one-lobe model cannot represent, so K-means on them partly groups texels by that residual, and
/// the lobe refitted on a cluster then sits farther from its members' own lobes. Clustering the
/// LM values groups texels by what a cluster lobe can represent, which lowers PLM-C's error on
/// most synthetic materials (docs/model.md, "Clustering on LM values", has the figures and the
/// command). KL selection is on the original images, as in the paper; the refinement and the L1
/// polynomials are departures, stated in `fit`'s output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ClusterOn {
    /// The original (measured) values, as in the paper.
    Original,
    /// The texel's LM-model values (the default).
    #[default]
    LmModel,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            kind: ModelKind::PlmC,
            clusters: 256,
            features: 20,
            seed: 0,
            kmeans_iters: 40,
            fit_stored: true,
            cluster_on: ClusterOn::LmModel,
            refine_iters: 6,
        }
    }
}

/// Pipeline stages reported to the progress callback (once per view each).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Per-texel Lafortune fits done.
    Lm,
    /// Per-image polynomials done.
    Plm,
    /// Clustering and cluster refits done.
    PlmC,
    /// View finished (fitted now or taken from a part file).
    Done,
}

/// The space a fit with `opts` works in for data stored with `encoding`.
pub fn value_space(encoding: StoredEncoding, opts: &FitOptions) -> ValueSpace {
    if opts.fit_stored && encoding == StoredEncoding::Srgb8 {
        ValueSpace::Srgb
    } else {
        ValueSpace::Linear
    }
}
