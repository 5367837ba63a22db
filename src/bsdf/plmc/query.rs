//! One query of the batched PLM-C evaluation: what the BSDF hands to
//! [`PlmcMaterial::eval_b_batch`](super::PlmcMaterial::eval_b_batch) and the 16-query AVX-512
//! kernel reads.

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
