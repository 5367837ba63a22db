//! Opacity mask (Mitsuba `mask`): with probability 1 − opacity the path passes straight through
//! the surface (a null interaction: direction −wi, weight 1, reported as a delta transmission so
//! integrators skip MIS for it, as Mitsuba's `Null` lobe); otherwise the nested BSDF scatters.

use super::plugin::{BsdfProperties, check_unit_interval, single_nested_bsdf};
use super::{Bsdf, BsdfFlags, BsdfSample, Bxdf, Texture};
use crate::Result;
use crate::geometry::SurfaceInteraction;
use crate::math::color::luminance;
use crate::math::{Spectrum, Vec2, Vec3};

/// Mitsuba `mask`: `opacity` (luminance, clipped to [0, 1]; default 0.5) of the `nested` model.
#[derive(Clone, Debug)]
pub struct Mask {
    /// Fraction of paths the nested model scatters.
    pub opacity: Texture,
    /// The model seen where the surface is opaque.
    pub nested: Box<Bsdf>,
}

impl Mask {
    /// Mitsuba's `mask`: one nested BSDF and the `opacity` (0..1, float or texture).
    pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Self> {
        single_nested_bsdf(
            p,
            "needs a nested bsdf",
            "cannot have more than one nested bsdf",
        )?;
        let opacity = p.texture("opacity", Vec3::splat(0.5))?;
        check_unit_interval(p, "opacity", &opacity)?;
        Ok(Mask {
            opacity,
            nested: Box::new(p.nested_bsdf(0)?),
        })
    }
}

impl Mask {
    #[inline]
    fn opacity(&self, uv: Vec2) -> f32 {
        luminance(self.opacity.eval(uv)).clamp(0.0, 1.0)
    }
}

impl Bxdf for Mask {
    /// Prefetches for the nested models.
    #[inline]
    fn prefetch(&self, si: &SurfaceInteraction) {
        self.nested.prefetch(si);
    }

    /// The nested lobes plus the straight-through (null) one.
    fn flags(&self) -> BsdfFlags {
        let f = self.nested.flags() | BsdfFlags::DELTA_TRANSMISSION;
        f.varying_if(self.opacity.is_spatially_varying())
    }

    /// opacity · nested (the null lobe is a delta).
    fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        self.nested.eval(si, wo) * self.opacity(si.uv)
    }

    /// opacity · nested pdf.
    fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        self.nested.pdf(si, wo) * self.opacity(si.uv)
    }

    /// `eval` and `pdf` together.
    fn eval_pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> (Spectrum, f32) {
        let o = self.opacity(si.uv);
        let (v, p) = self.nested.eval_pdf(si, wo);
        (v * o, p * o)
    }

    /// Nested sample if `sample1` < opacity (pdf scaled by opacity, weight unchanged), else the
    /// null interaction with pdf 1 − opacity and weight 1.
    fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        let o = self.opacity(si.uv);
        if sample1 < o {
            let (mut bs, w) = self.nested.sample(si, sample1 / o, sample2)?;
            bs.pdf *= o;
            return Some((bs, w));
        }
        let bs = BsdfSample {
            wo: -si.wi,
            pdf: 1.0 - o,
            eta: 1.0,
            sampled: BsdfFlags::DELTA_TRANSMISSION,
        };
        Some((bs, Spectrum::ONE))
    }
}
