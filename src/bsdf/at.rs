//! A BSDF at one shading point: the per-hit object the integrators call. It carries what the
//! calls at that point share, computed once by [`Bsdf::at`] (for a fitted BTF model the view
//! lookup and texel addressing, which would otherwise be redone by emitter sampling's
//! `eval_pdf` and by `sample`), so integrators never pass per-hit state around by hand.

use super::plmc::{PlmcBsdf, PlmcHit};
use super::{Bsdf, BsdfFlags, BsdfSample};
use crate::geometry::SurfaceInteraction;
use crate::math::{Spectrum, Vec2, Vec3};

/// A BSDF bound to one shading point by [`Bsdf::at`]. Every method returns exactly what the
/// stateless [`Bsdf`] method returns for the same `si` (the one `at` was given). Plain data on
/// the stack: a borrowed BSDF plus, for a fitted BTF, its hit.
/// (One per path vertex on the stack, never stored in bulk: the fitted BTF's hit, with its
/// lobe mixture of a few hundred bytes, stays inline rather than behind an allocation per hit.)
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
pub enum BsdfAt<'a> {
    /// No per-hit state: the calls forward to the stateless ones.
    Stateless(&'a Bsdf),
    /// A fitted BTF model and its hit (wi above the horizon).
    Plmc(&'a PlmcBsdf, PlmcHit),
}

impl Bsdf {
    /// This BSDF at the shading point `si`. Also starts the memory loads the first evaluation
    /// will need (see [`Bsdf::prefetch`]).
    #[inline]
    pub fn at(&self, si: &SurfaceInteraction) -> BsdfAt<'_> {
        match self {
            Bsdf::Plmc(b) => match b.prepare(si) {
                Some(h) => BsdfAt::Plmc(b, h),
                None => BsdfAt::Stateless(self),
            },
            other => {
                other.prefetch(si);
                BsdfAt::Stateless(self)
            }
        }
    }
}

impl BsdfAt<'_> {
    /// The lobes of the BSDF.
    #[inline]
    pub fn flags(&self) -> BsdfFlags {
        match self {
            BsdfAt::Stateless(b) => b.flags(),
            BsdfAt::Plmc(b, _) => b.flags(),
        }
    }

    /// [`Bsdf::eval`] at this point: f(wi, wo) · |cos θ_o|.
    #[inline]
    pub fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        match self {
            BsdfAt::Stateless(b) => b.eval(si, wo),
            BsdfAt::Plmc(b, h) => b.eval_hit(h, wo),
        }
    }

    /// [`Bsdf::pdf`] at this point (solid angle).
    #[inline]
    pub fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        match self {
            BsdfAt::Stateless(b) => b.pdf(si, wo),
            BsdfAt::Plmc(b, h) => b.pdf_hit(h, wo),
        }
    }

    /// [`Bsdf::eval_pdf`] at this point: both from one lookup where the model shares it.
    #[inline]
    pub fn eval_pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> (Spectrum, f32) {
        match self {
            BsdfAt::Stateless(b) => b.eval_pdf(si, wo),
            BsdfAt::Plmc(b, h) => b.eval_pdf_hit(h, wo),
        }
    }

    /// (f, pdf) toward an emitter sample's local direction `wo`, as next-event estimation
    /// needs them: the pdf only for a light that BSDF sampling can also hit (`delta` false),
    /// else 0 without computing it.
    #[inline]
    pub fn eval_for_light(
        &self,
        si: &SurfaceInteraction,
        wo: Vec3,
        delta: bool,
    ) -> (Spectrum, f32) {
        if delta {
            (self.eval(si, wo), 0.0)
        } else {
            self.eval_pdf(si, wo)
        }
    }

    /// [`Bsdf::sample`] at this point: (sample, weight = eval / pdf).
    #[inline]
    pub fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        match self {
            BsdfAt::Stateless(b) => b.sample(si, sample1, sample2),
            BsdfAt::Plmc(b, h) => b.sample_hit(h, sample1, sample2),
        }
    }
}
