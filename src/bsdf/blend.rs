//! Linear blend of two BSDFs (Mitsuba `blendbsdf`; Mitsuba 0.6's two-component `mixturebsdf`
//! maps onto it): f = (1 − w) f₀ + w f₁ with a texturable weight w ∈ [0, 1], sampled by choosing
//! a component with probability w and weighting by the mixture's eval / pdf.

use super::{Bsdf, BsdfFlags, Bxdf, BsdfSample, Texture};
use crate::geometry::SurfaceInteraction;
use crate::math::color::luminance;
use crate::math::{Spectrum, Vec2, Vec3};

/// Mitsuba `blendbsdf`: `bsdfs[1]` has weight w, `bsdfs[0]` weight 1 − w.
#[derive(Clone, Debug)]
pub struct BlendBsdf {
    /// Weight of the second BSDF (luminance of the texture, clipped to [0, 1]).
    pub weight: Texture,
    /// The two nested models.
    pub bsdfs: Box<[Bsdf; 2]>,
}

impl BlendBsdf {
    #[inline]
    fn w(&self, uv: Vec2) -> f32 {
        luminance(self.weight.eval(uv)).clamp(0.0, 1.0)
    }
}

impl Bxdf for BlendBsdf {
    /// Prefetches for the nested models.
    #[inline]
    fn prefetch(&self, si: &SurfaceInteraction) {
        self.bsdfs[0].prefetch(si);
        self.bsdfs[1].prefetch(si);
    }

    /// Union of the nested models' lobes.
    fn flags(&self) -> BsdfFlags {
        let f = self.bsdfs[0].flags() | self.bsdfs[1].flags();
        if self.weight.is_spatially_varying() {
            f | BsdfFlags::SPATIALLY_VARYING
        } else {
            f
        }
    }

    /// (1 − w) f₀ + w f₁.
    fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        let w = self.w(si.uv);
        self.bsdfs[0].eval(si, wo) * (1.0 - w) + self.bsdfs[1].eval(si, wo) * w
    }

    /// (1 − w) p₀ + w p₁.
    fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        let w = self.w(si.uv);
        self.bsdfs[0].pdf(si, wo) * (1.0 - w) + self.bsdfs[1].pdf(si, wo) * w
    }

    /// `eval` and `pdf` together.
    fn eval_pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> (Spectrum, f32) {
        let w = self.w(si.uv);
        let (v0, p0) = self.bsdfs[0].eval_pdf(si, wo);
        let (v1, p1) = self.bsdfs[1].eval_pdf(si, wo);
        (v0 * (1.0 - w) + v1 * w, p0 * (1.0 - w) + p1 * w)
    }

    /// Samples component 1 if `sample1` ≤ w (else 0) with `sample1` rescaled; the weight and
    /// pdf are those of the mixture (Mitsuba's one-sample MIS over the two components).
    fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        let w = self.w(si.uv);
        // w = 0 always takes the first (avoids 0/0 at sample1 = 0).
        let first = sample1 > w || w == 0.0;
        let (chosen, other, s1, w_chosen) = if first {
            (
                &self.bsdfs[0],
                &self.bsdfs[1],
                (sample1 - w) / (1.0 - w),
                1.0 - w,
            )
        } else {
            (&self.bsdfs[1], &self.bsdfs[0], sample1 / w, w)
        };
        let (mut bs, result) = chosen.sample(si, s1, sample2)?;
        let (eval_other, pdf_other) = other.eval_pdf(si, bs.wo);
        let w_other = 1.0 - w_chosen;
        let pdf = w_chosen * bs.pdf + w_other * pdf_other;
        let value = if pdf > 0.0 {
            (result * (w_chosen * bs.pdf) + eval_other * w_other) / pdf
        } else {
            Spectrum::ZERO
        };
        bs.pdf = pdf;
        Some((bs, value))
    }
}
