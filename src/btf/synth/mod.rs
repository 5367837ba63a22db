//! The BTF measurement simulator: procedural micro-geometry (a periodic height field with a
//! spatially varying microfacet BRDF) "measured" as a gonioreflectometer sees it, producing a
//! linear [`crate::btf::RawBtf`] for views × lights (see `measure`).

pub mod brdf;
pub mod disk_cache;
pub mod heightfield;
pub mod materials;
pub mod measure;
pub mod noise;
pub mod spec;
pub mod surface;

pub use brdf::BrdfParams;
pub use disk_cache::SynthOrigin;
pub use materials::MaterialKind;
pub use measure::{SynthSettings, measure};
pub use spec::SynthSpec;
pub use surface::MicroSurface;

#[cfg(test)]
mod tests;
