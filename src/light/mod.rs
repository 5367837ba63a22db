//! Light sources with Mitsuba 3 semantics, one file per type — area (one-sided, on a mesh or an
//! analytic sphere), point, spot, directional, constant and lat-long environment map — and
//! uniform emitter selection ([`LightSet`]).

pub mod area;
pub mod constant;
pub mod directional;
pub mod envmap;
pub mod light_set;
pub mod point;
pub mod sphere_area;
pub mod spot;

use crate::math::{Spectrum, Vec3};
pub use area::AreaLight;
pub use constant::ConstantLight;
pub use directional::DirectionalLight;
pub use envmap::EnvMapLight;
pub use light_set::LightSet;
pub use point::PointLight;
pub use sphere_area::SphereAreaLight;
pub use spot::SpotLight;

/// One emitter, ready for sampling (an enum so the integrator's light loop has no dyn dispatch).
#[derive(Clone, Debug)]
pub enum Light {
    Area(AreaLight),
    SphereArea(SphereAreaLight),
    Point(PointLight),
    Spot(SpotLight),
    Directional(DirectionalLight),
    Constant(ConstantLight),
    EnvMap(Box<EnvMapLight>),
}

/// The result of sampling a light from a reference point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit world direction from the reference point toward the light.
    pub wi: Vec3,
    /// Distance to the sampled point (∞ for lights at infinity).
    pub dist: f32,
    /// Geometric normal at the sampled point (zero for points and infinite lights), used to
    /// offset the far end of the shadow ray.
    pub n_geo: Vec3,
    /// Radiance (or intensity / d², or irradiance) divided by the pdf, including the
    /// emitter-selection probability.
    pub weight: Spectrum,
    /// Solid-angle pdf including selection (for delta lights: the selection probability).
    pub pdf: f32,
    /// True for point, spot and directional lights (no MIS).
    pub delta: bool,
}
