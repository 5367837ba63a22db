//! Linear polarizer (Mitsuba `polarizer`) as Mitsuba 3.9.1's unpolarized (RGB) variants evaluate
//! it: a two-sided null interface that lets every path straight through with weight
//! ½ · transmittance, the intensity an ideal polarizer passes of unpolarized light (its Mueller
//! matrix's top-left entry). `theta` and `polarizing` change only polarized variants' results;
//! they are read (and `theta` built) so scenes written for them load unchanged.

use super::plugin::BsdfProperties;
use super::{BsdfFlags, BsdfSample, Bxdf, Texture};
use crate::Result;
use crate::geometry::SurfaceInteraction;
use crate::math::cie1931::SpectrumUse;
use crate::math::{Spectrum, Vec2, Vec3};

/// Mitsuba `polarizer` seen by unpolarized light.
#[derive(Clone, Debug)]
pub struct Polarizer {
    /// Fraction of the polarized component the filter passes (Mitsuba default 1).
    pub transmittance: Texture,
}

impl Polarizer {
    /// Mitsuba's `polarizer`: `transmittance` (default 1), `theta` (degrees, a float or
    /// texture; no effect without polarization), `polarizing` (likewise).
    pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Self> {
        p.texture_as("theta", Vec3::ZERO, SpectrumUse::Unbounded)?;
        p.bool("polarizing", true)?;
        Ok(Polarizer {
            transmittance: p.texture("transmittance", Vec3::ONE)?,
        })
    }
}

impl Bxdf for Polarizer {
    /// Only the straight-through (null) lobe.
    fn flags(&self) -> BsdfFlags {
        BsdfFlags::DELTA_TRANSMISSION.varying_if(self.transmittance.is_spatially_varying())
    }

    /// 0: the only lobe is a delta.
    fn eval(&self, _si: &SurfaceInteraction, _wo: Vec3) -> Spectrum {
        Spectrum::ZERO
    }

    /// 0: the only lobe is a delta.
    fn pdf(&self, _si: &SurfaceInteraction, _wo: Vec3) -> f32 {
        0.0
    }

    /// Direction −wi, probability 1, weight ½ · transmittance, reported as a delta
    /// transmission (Mitsuba's `Null` lobe: no MIS, depth counted).
    fn sample(
        &self,
        si: &SurfaceInteraction,
        _sample1: f32,
        _sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        let bs = BsdfSample {
            wo: -si.wi,
            pdf: 1.0,
            eta: 1.0,
            sampled: BsdfFlags::DELTA_TRANSMISSION,
        };
        Some((bs, self.transmittance.eval(si.uv) * 0.5))
    }
}

#[cfg(test)]
mod tests {
    use super::Polarizer;
    use crate::bsdf::{Bxdf, Texture};
    use crate::geometry::SurfaceInteraction;
    use crate::math::{Spectrum, Vec2, Vec3};

    /// Unpolarized light through an ideal polarizer keeps half its intensity, from either side.
    #[test]
    fn passes_half_of_unpolarized_light_straight_through() {
        let p = Polarizer {
            transmittance: Texture::Constant(Spectrum::new(1.0, 0.8, 0.6)),
        };
        for wi in [
            Vec3::new(0.3, -0.2, 0.9).normalize(),
            Vec3::new(0.1, 0.5, -0.7).normalize(),
        ] {
            let si = SurfaceInteraction::for_tests(wi, Vec2::new(0.3, 0.6));
            let (bs, w) = p.sample(&si, 0.7, Vec2::new(0.2, 0.9)).unwrap();
            assert_eq!(bs.wo, -wi);
            assert_eq!(bs.pdf, 1.0);
            assert_eq!(w, Spectrum::new(0.5, 0.4, 0.3));
            assert_eq!(p.eval(&si, -wi), Spectrum::ZERO);
        }
    }
}
