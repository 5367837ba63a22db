//! Scene geometry: triangle meshes in world space, the hit record, and (in `accel`) the BVH.

pub mod intersection;
pub mod mesh;

pub use intersection::SurfaceInteraction;
pub use mesh::Mesh;
