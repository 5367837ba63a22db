//! Two-sided adapter (Mitsuba `twosided`): a one-sided reflectance model seen from the back is
//! evaluated with both directions mirrored through the surface (z → −z).

use super::plugin::BsdfProperties;
use super::{Bsdf, BsdfFlags, BsdfSample, Bxdf};
use crate::geometry::SurfaceInteraction;
use crate::math::{Spectrum, Vec2, Vec3};

/// Mitsuba `twosided`: `front` on the front side, `back` (often the same) seen from below.
#[derive(Clone, Debug)]
pub struct TwoSided {
    /// Model used when cos θ_i > 0.
    pub front: Box<Bsdf>,
    /// Model used when cos θ_i < 0, evaluated in the z-mirrored frame.
    pub back: Box<Bsdf>,
}

impl TwoSided {
    /// Mitsuba's `twosided`: one nested BSDF for both sides, or two (front, back).
    pub fn from_props(p: &mut dyn BsdfProperties) -> crate::Result<Self> {
        let (front, back) = match p.nested_bsdf_count() {
            1 => {
                let b = p.nested_bsdf(0)?;
                (b.clone(), b)
            }
            2 => (p.nested_bsdf(0)?, p.nested_bsdf(1)?),
            _ => return Err(p.err("twosided needs one or two nested bsdfs")),
        };
        if matches!(front, Bsdf::TwoSided(_)) || matches!(back, Bsdf::TwoSided(_)) {
            return Err(p.err("a twosided bsdf cannot contain another twosided bsdf"));
        }
        Ok(TwoSided {
            front: Box::new(front),
            back: Box::new(back),
        })
    }
}

#[inline]
fn flip_z(v: Vec3) -> Vec3 {
    Vec3::new(v.x, v.y, -v.z)
}

impl TwoSided {
    /// Checked constructor: like Mitsuba, only reflecting (non-transmissive) models may be nested.
    pub fn new(front: Bsdf, back: Bsdf) -> crate::Result<Self> {
        let transmissive = BsdfFlags::DIFFUSE_TRANSMISSION
            | BsdfFlags::GLOSSY_TRANSMISSION
            | BsdfFlags::DELTA_TRANSMISSION;
        if (front.flags() | back.flags()).has(transmissive) {
            return Err(crate::Error::Invalid(
                "twosided: only materials without a transmission component can be nested".into(),
            ));
        }
        Ok(TwoSided {
            front: Box::new(front),
            back: Box::new(back),
        })
    }
}

impl Bxdf for TwoSided {
    /// Prefetches for the nested models.
    #[inline]
    fn prefetch(&self, si: &SurfaceInteraction) {
        self.front.prefetch(si);
        self.back.prefetch(si);
    }

    /// Union of the nested models' lobes.
    fn flags(&self) -> BsdfFlags {
        self.front.flags() | self.back.flags()
    }

    /// `front` if cos θ_i > 0, `back` on mirrored directions if cos θ_i < 0, else 0.
    fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        if si.wi.z > 0.0 {
            self.front.eval(si, wo)
        } else if si.wi.z < 0.0 {
            let mut s = *si;
            s.wi = flip_z(si.wi);
            self.back.eval(&s, flip_z(wo))
        } else {
            Spectrum::ZERO
        }
    }

    /// Density matching [`TwoSided::sample`].
    fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        if si.wi.z > 0.0 {
            self.front.pdf(si, wo)
        } else if si.wi.z < 0.0 {
            let mut s = *si;
            s.wi = flip_z(si.wi);
            self.back.pdf(&s, flip_z(wo))
        } else {
            0.0
        }
    }

    /// `eval` and `pdf` together.
    fn eval_pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> (Spectrum, f32) {
        if si.wi.z > 0.0 {
            self.front.eval_pdf(si, wo)
        } else if si.wi.z < 0.0 {
            let mut s = *si;
            s.wi = flip_z(si.wi);
            self.back.eval_pdf(&s, flip_z(wo))
        } else {
            (Spectrum::ZERO, 0.0)
        }
    }

    /// Samples the side's model; from below the sampled direction is mirrored back.
    fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        if si.wi.z > 0.0 {
            self.front.sample(si, sample1, sample2)
        } else if si.wi.z < 0.0 {
            let mut s = *si;
            s.wi = flip_z(si.wi);
            let (mut bs, w) = self.back.sample(&s, sample1, sample2)?;
            bs.wo = flip_z(bs.wo);
            Some((bs, w))
        } else {
            None
        }
    }
}
