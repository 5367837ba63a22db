//! The integrators: radiometric checks with analytic answers, the packet integrator against
//! the scalar one, and determinism of split work (threads, checkpoints, crops, sample ranges).

#[path = "../common/mod.rs"]
mod common;

mod determinism;
mod packet_vs_scalar;
mod physics;
