//! Small numeric building blocks shared by every subsystem.

pub mod alias;
pub mod cie1931;
pub mod color;
pub mod distribution;
pub mod filter;
pub mod frame;
pub mod kmeans;
pub mod order_key;
pub mod quad;
pub mod rng;
pub mod simd;
pub mod special;
pub mod transform;
pub mod warp;

pub use frame::Frame;
pub use glam::{Mat3, Mat4, Vec2, Vec3};
pub use rng::{Pcg32, Pcg32x};

/// Linear RGB radiance/reflectance triple (Rec.709 primaries).
pub type Spectrum = glam::Vec3;

/// π as f32.
pub const PI: f32 = std::f32::consts::PI;
/// 1/π, the Lambertian normalisation.
pub const INV_PI: f32 = std::f32::consts::FRAC_1_PI;
/// 1/(2π).
pub const INV_TWO_PI: f32 = 0.5 * std::f32::consts::FRAC_1_PI;
/// 1/(4π), the pdf of a uniform direction on the sphere.
pub const INV_FOUR_PI: f32 = 0.25 * std::f32::consts::FRAC_1_PI;
