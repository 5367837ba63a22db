//! Area light on an analytic sphere (Mitsuba: cone sampling from outside), one-sided.

// `!(x > 0.0)` deliberately also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::LightSample;
use crate::bsdf::Texture;
use crate::geometry::SurfaceInteraction;
use crate::geometry::sphere::Sphere;
use crate::math::{Spectrum, Vec2, Vec3};

/// An area emitter on an analytic sphere.
#[derive(Clone, Debug)]
pub struct SphereAreaLight {
    pub sphere: Sphere,
    /// Emitted radiance (W/(m²·sr)) where `texture` is None.
    pub radiance: Spectrum,
    /// A spatially varying radiance over the sphere's uv parameterisation (it replaces
    /// `radiance`).
    pub texture: Option<Texture>,
}

impl SphereAreaLight {
    /// Samples the sphere as seen from `p` (pdf in solid angle, no selection).
    #[inline]
    pub fn sample_li(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        let s = self.sphere.sample(p, u)?;
        // One-sided: emits toward the side of the (possibly flipped) normal.
        if !(s.d.dot(s.n) < 0.0 && s.pdf > 0.0) {
            return None;
        }
        Some(LightSample {
            wi: s.d,
            dist: s.dist,
            n_geo: s.n,
            weight: self.radiance_at(s.p) / s.pdf,
            pdf: s.pdf,
            delta: false,
        })
    }

    /// Radiance emitted at the point `p` of the sphere.
    #[inline]
    fn radiance_at(&self, p: Vec3) -> Spectrum {
        match &self.texture {
            None => self.radiance,
            Some(tex) => tex.eval(self.sphere.uv_at(p)),
        }
    }

    /// Radiance emitted at the hit `si` of the sphere.
    #[inline]
    pub fn radiance_at_hit(&self, si: &SurfaceInteraction) -> Spectrum {
        match &self.texture {
            None => self.radiance,
            Some(tex) => tex.eval(si.uv),
        }
    }

    /// Solid-angle pdf (no selection) that [`SphereAreaLight::sample_li`] from `p_ref` returns
    /// the point `p` with normal `n`.
    #[inline]
    pub fn pdf_li(&self, p_ref: Vec3, p: Vec3, n: Vec3) -> f32 {
        self.sphere.pdf(p_ref, p, n)
    }
}
