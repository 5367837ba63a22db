//! Light sources with Mitsuba 3 semantics, one file per type — area (one-sided, on a mesh or an
//! analytic sphere), point, spot, projector, directional, constant and lat-long environment map — and
//! uniform emitter selection ([`LightSet`]); [`Emitter`] is what a scene says about a light.

pub mod area;
pub mod constant;
pub mod directional;
pub mod emitter;
pub mod envmap;
pub mod light_set;
pub mod point;
pub mod projector;
pub mod sphere_area;
pub mod spot;

use crate::math::simd::f16::{F16, M16, V3x};
use crate::math::{Spectrum, Vec3};
pub use area::AreaLight;
pub use constant::ConstantLight;
pub use directional::DirectionalLight;
pub use emitter::Emitter;
pub use envmap::EnvMapLight;
pub use light_set::LightSet;
pub use point::PointLight;
pub use projector::ProjectorLight;
pub use sphere_area::SphereAreaLight;
pub use spot::SpotLight;

/// One emitter, ready for sampling (an enum so the integrator's light loop has no dyn dispatch).
#[derive(Clone, Debug)]
pub enum Light {
    Area(AreaLight),
    SphereArea(SphereAreaLight),
    Point(PointLight),
    Spot(SpotLight),
    Projector(ProjectorLight),
    Directional(DirectionalLight),
    Constant(ConstantLight),
    EnvMap(Box<EnvMapLight>),
}

/// 16 [`LightSample`]s, one per lane (the packet kernels' form).
#[derive(Clone, Copy, Debug)]
pub struct LightSampleX {
    pub wi: V3x,
    pub dist: F16,
    pub n_geo: V3x,
    pub weight: V3x,
    pub pdf: F16,
    pub delta: M16,
}

impl LightSampleX {
    /// Stores lane `l` of `s` (the scalar sample of an emitter the kernel does not sample itself).
    #[inline(always)]
    pub fn set(&mut self, l: usize, s: &LightSample) {
        self.wi.set(l, s.wi);
        self.dist.0[l] = s.dist;
        self.n_geo.set(l, s.n_geo);
        self.weight.set(l, s.weight);
        self.pdf.0[l] = s.pdf;
        self.delta.0[l] = s.delta;
    }

    /// [`crate::light::light_set::with_selection`] per lane.
    #[inline(always)]
    pub fn with_selection(mut self, sel: f32) -> LightSampleX {
        self.pdf = self.pdf * sel;
        self.weight = self.weight.div(F16::splat(sel));
        self
    }

    /// Lanes of `a` where `m`, of `b` elsewhere.
    #[inline(always)]
    pub fn select(m: M16, a: &LightSampleX, b: &LightSampleX) -> LightSampleX {
        LightSampleX {
            wi: V3x::select(m, a.wi, b.wi),
            dist: F16::select(m, a.dist, b.dist),
            n_geo: V3x::select(m, a.n_geo, b.n_geo),
            weight: V3x::select(m, a.weight, b.weight),
            pdf: F16::select(m, a.pdf, b.pdf),
            delta: m.and(a.delta).or(m.not().and(b.delta)),
        }
    }
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

#[cfg(test)]
mod tests;
