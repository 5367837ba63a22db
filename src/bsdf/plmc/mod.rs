//! The fitted models (LM, PLM, PLM-C; docs/conventions.md) evaluated at every shading hit, and
//! their BSDF.
//!
//! For a hit (texel, ω_v, ω_l): the 3 measured views around ω_v with barycentric weights; per view
//! and channel the texel's lobe (PLM-C: its cluster's lobe via the u8 index planes) is evaluated
//! at the actual ω_l, mapped by the degree-4 polynomial whose coefficients are interpolated over
//! the 3 measured lights around ω_l (LM: identity), decoded to linear if the model was fitted in
//! sRGB (`srgb_to_linear(max(0, ·))`), and the 3 views are blended.
//!
//! Layout (data-oriented, nothing allocated per evaluation, no branch on data in the inner loop):
//! - the 3 views × 3 channels are 9 of [`LANES`] = 12 lanes (three 4-wide or 8+4 vectors); lobe
//!   parameters are gathered into structure-of-arrays lanes `[ρ; 12] [Dx; 12] …` and the
//!   Lafortune power, polynomial and sRGB decode run lane-wise with a branch-free exp2/log2;
//! - PLM-C cluster tables: per (view, channel) K records `{ρ, Dx, Dy, Dz, n}` padded to 8 f32
//!   (32-byte aligned, one record never straddles a cache line: a gather is one line, not five
//!   as with a table per parameter);
//! - index planes: per view `[texel][R, G, B, pad]` u8 (u16 above 256 clusters), so one texel of
//!   one view is one 4-byte load and neighbouring texels share cache lines;
//! - polynomial coefficients: dense `[view][light]` rows of 16 f32 (a_0..a_4 for R, G, B + pad),
//!   64-byte aligned: light interpolation is three 16-wide multiply-adds on three cache lines.
//!
//! Kernels: on AVX-512 CPUs the PLM-C case of the renderer (u8 indices, nearest texel) runs
//! `avx512.rs`, the 9 lanes in one 16-lane register (about a third of the 4-wide build's
//! instructions); everything else runs the generic 4-wide kernel below, built for AVX2+FMA where
//! the CPU has it, else SSE2. A shading hit's view lookup and texel addressing are done once by
//! [`PlmcBsdf::prepare`] and shared by its `eval_pdf` and `sample` ([`PlmcHit`]).
//!
//! Sampling: a one-sample mixture of the hit's own sharp fitted lobes (`lobes.rs`) and the
//! tabulated light sampler of measured BTFs ([`BtfLightSampler`](crate::bsdf::btf_sampler::BtfLightSampler)), built at
//! load from the model's texel-averaged values at the measured directions, exactly as for raw
//! data.
//!
//! Files, one concept each: `material.rs` ([`PlmcMaterial`]: the evaluation layout built from a
//! model, loading, lookups, prefetches, the lobe albedos stored at load and a hit's lobes),
//! `kernel.rs` (every evaluation of it: the generic 4-wide kernel on `math::simd::f4::F4`, and
//! the dispatch by the one `math::simd::Isa`), `avx512.rs` (the 16-lane kernel), `batch.rs` (16
//! queries per pass, one per lane: the packet integrator's batched emitter evaluations),
//! `query.rs` (one query of a batch), `bsdf.rs` (the BSDF: texel addressing, per-hit state),
//! `lobes.rs` (the lobe mixture of a hit: selection weights, density, sampling, a lobe's
//! albedo), `prepare16.rs` (the per-hit state of a packet batch, its view lookups 16 at a
//! time), `tables.rs` (the texel-mean values and range clamps built at load, 16 lobes per
//! step). The exp2/log2 of the kernels are the fused ones of `math::simd::approx`.
//!

#[cfg(target_arch = "x86_64")]
mod avx512;
#[cfg(target_arch = "x86_64")]
mod batch;
#[cfg(target_arch = "x86_64")]
mod batch_avx2;
mod bsdf;
mod kernel;
mod lobes;
mod material;
mod prepare16;
mod query;
mod tables;
#[cfg(test)]
mod tests;

pub use bsdf::{PlmcBsdf, PlmcHit};
pub use kernel::{FLUSH, LANES};
pub use lobes::{HitLobes, LOBE_FRACTION};
pub use material::{LobeRec, PlmcMaterial, PolyRow, shared_material};
pub use prepare16::PREPARE_LANES;
pub use query::{BATCH, BatchQuery};
