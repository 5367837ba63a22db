//! Tests of the BSDFs through their public interfaces: physics (sampling against `pdf`, energy,
//! reciprocity), the Beckmann distribution's sampling, and the batched interface against the
//! scalar code.

mod batch_vs_scalar;
mod beckmann_sampling;
mod physics;
