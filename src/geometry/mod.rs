//! Scene geometry: triangle meshes in world space, the hit record, and (in `accel`) the BVH.

pub mod accel;
#[cfg(any(test, feature = "test-support"))]
pub mod generate;
pub mod intersection;
pub mod mesh;
pub mod mesh_attribute;
pub mod shading;
pub mod sphere;

pub use intersection::SurfaceInteraction;
pub use mesh::Mesh;
pub use mesh_attribute::MeshAttribute;
