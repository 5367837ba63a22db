//! One query of the batched PLM-C evaluation: what the BSDF hands to
//! [`PlmcMaterial::eval_b_batch`](super::PlmcMaterial::eval_b_batch), and the material tables
//! the 16-query kernels (AVX-512 in `batch.rs`, AVX2 in `batch_avx2.rs`) read.

use super::{LobeRec, PolyRow};

/// Most queries of one [`PlmcMaterial::eval_b_batch`](super::PlmcMaterial::eval_b_batch) call (one per AVX-512 lane).
pub const BATCH: usize = 16;

/// One evaluation of a batch: the texel, the 3 measured views and lights around ω_v, ω_l with
/// their interpolation weights, and ω_l (local frame). 64 bytes in this field order (repr(C)):
/// the 16-lane kernel reads 16 queries as rows of a 16 × 16 transpose.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C)]
pub struct BatchQuery {
    pub texel: u32,
    pub vi: [u32; 3],
    pub vw: [f32; 3],
    pub li: [u32; 3],
    pub lw: [f32; 3],
    pub wo: [f32; 3],
}

/// The tables of a PLM-C material with u8 indices, as the AVX kernels read them (see `Params::Clustered8` and the
/// `PlmcMaterial` fields of the same names).
pub(super) struct Tables<'a> {
    pub k: usize,
    pub n_views: usize,
    pub n_lights: usize,
    pub records: &'a [LobeRec],
    pub index: &'a [[u8; 4]],
    pub polys: &'a [PolyRow],
    pub y_max: &'a [[f32; 4]],
    pub out_max: &'a [[f32; 4]],
    /// The model was fitted on sRGB-encoded values (decode after the polynomial).
    pub srgb: bool,
}
