//! Tests of the BSDFs through their public interfaces: physics (sampling against `pdf`, energy,
//! reciprocity), the Beckmann distribution's sampling, the batched interface against the
//! scalar code, and the named-conductor table against Mitsuba.

mod batch_vs_scalar;
mod beckmann_sampling;
mod conductor_materials;
mod physics;
mod pplastic;
mod principled;
