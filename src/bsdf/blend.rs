//! Linear blend of two BSDFs (Mitsuba `blendbsdf`; Mitsuba 0.6's two-component `mixturebsdf`
//! maps onto it): f = (1 − w) f₀ + w f₁ with a texturable weight w ∈ [0, 1], sampled by choosing
//! a component with probability w and weighting by the mixture's eval / pdf.

use super::plugin::{BsdfProperties, check_unit_interval};
use super::{Bsdf, BsdfFlags, BsdfSample, Bxdf, Texture};
use crate::Result;
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
    /// Mitsuba's `blendbsdf`: two nested BSDFs and the `weight` (0..1, float or texture) of
    /// the second.
    pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Self> {
        two_nested(p)?;
        if !p.has("weight") {
            return Err(p.err("the blend \"weight\" (0..1, a float or texture) is required"));
        }
        let weight = p.texture("weight", Vec3::splat(0.5))?;
        check_unit_interval(p, "weight", &weight)?;
        BlendBsdf::with_nested(p, weight)
    }

    /// Mitsuba 0.6's `mixturebsdf` of two components: `weights` "w0, w1" summing to 1 (or
    /// more, renormalised).
    pub fn mixture_from_props(p: &mut dyn BsdfProperties) -> Result<Self> {
        two_nested(p)?;
        let text = p.string_req("weights")?;
        let ws = text
            .split([',', ' '])
            .filter(|t| !t.is_empty())
            .map(|t| t.parse::<f32>().ok().filter(|v| v.is_finite() && *v >= 0.0))
            .collect::<Option<Vec<f32>>>()
            .ok_or_else(|| {
                p.err(&format!(
                    "\"weights\" must be non-negative numbers, got \"{text}\""
                ))
            })?;
        if ws.len() != 2 {
            return Err(p.err(&format!("{} weights for 2 nested bsdfs", ws.len())));
        }
        let sum = ws[0] + ws[1];
        // Mitsuba 0.6 renormalises weights summing to more than 1; a sum below 1 (an
        // absorbing mixture) has no blendbsdf equivalent.
        if !(sum >= 1.0 - 1e-3) {
            return Err(p.err(&format!(
                "\"weights\" sum to {sum} < 1: only mixtures whose weights sum to 1 \
                 (or more, renormalised) are supported"
            )));
        }
        BlendBsdf::with_nested(p, Texture::Constant(Spectrum::splat(ws[1] / sum)))
    }

    /// The blend of the two nested BSDFs with `weight`.
    fn with_nested(p: &mut dyn BsdfProperties, weight: Texture) -> Result<Self> {
        let a = p.nested_bsdf(0)?;
        let b = p.nested_bsdf(1)?;
        Ok(BlendBsdf {
            weight,
            bsdfs: Box::new([a, b]),
        })
    }
}

/// A blend takes exactly two nested BSDFs.
fn two_nested(p: &mut dyn BsdfProperties) -> Result<()> {
    match p.nested_bsdf_count() {
        2 => Ok(()),
        n => Err(p.err(&format!(
            "needs exactly two nested bsdfs, found {n} (a mixture of more than two \
             components is not supported)"
        ))),
    }
}

impl BlendBsdf {
    /// The weight at the hit: a mesh attribute's scalar value (Mitsuba's `eval_1`), any other
    /// texture's luminance at the hit's uv; clipped to [0, 1].
    #[inline]
    pub fn weight_at(&self, si: &SurfaceInteraction) -> f32 {
        let w = match &self.weight {
            Texture::MeshAttribute(m) => m.eval_1_at(si),
            t => luminance(t.eval(si.uv)),
        };
        w.clamp(0.0, 1.0)
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
        f.varying_if(self.weight.is_spatially_varying())
    }

    /// (1 − w) f₀ + w f₁.
    fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        let w = self.weight_at(si);
        self.bsdfs[0].eval(si, wo) * (1.0 - w) + self.bsdfs[1].eval(si, wo) * w
    }

    /// (1 − w) p₀ + w p₁.
    fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        let w = self.weight_at(si);
        self.bsdfs[0].pdf(si, wo) * (1.0 - w) + self.bsdfs[1].pdf(si, wo) * w
    }

    /// `eval` and `pdf` together.
    fn eval_pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> (Spectrum, f32) {
        let w = self.weight_at(si);
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
        let w = self.weight_at(si);
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
