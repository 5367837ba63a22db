//! A nested BSDF evaluated in a tilted shading frame: what normal mapping and bump mapping share
//! once each has built its frame (as Mitsuba's normalmap.cpp and bumpmap.cpp do the same steps).
//! Directions whose side differs between the two frames get no response; Estevez et al.'s (2019)
//! shadowing term damps the bump-terminator artefacts.

use super::{Bsdf, BsdfSample};
use crate::geometry::SurfaceInteraction;
use crate::math::{Frame, Spectrum, Vec2, Vec3};

/// tan² θ of a local direction (Mitsuba `Frame3f::tan_theta_2`).
#[inline]
fn tan_theta_2(v: Vec3) -> f32 {
    (1.0 - v.z * v.z).max(0.0) / (v.z * v.z)
}

/// Estevez et al.'s shadowing term for a perturbed normal `n` and a direction `wo`, both local
/// to the unperturbed frame (Mitsuba `eval_shadow_terminator`).
#[inline]
pub fn shadow_terminator(n: Vec3, wo: Vec3) -> f32 {
    let alpha2 = (0.125 * tan_theta_2(n)).min(1.0);
    2.0 / (1.0 + (1.0 + alpha2 * tan_theta_2(wo)).sqrt())
}

/// The nested model at one hit, seen through the perturbed frame `local` (relative to the hit's
/// shading frame).
pub struct Perturbed<'a> {
    pub nested: &'a Bsdf,
    /// The perturbed frame in the shading frame's coordinates.
    pub local: Frame,
    /// The hit as the nested model sees it (shading frame and wi in the perturbed frame).
    pub si: SurfaceInteraction,
    /// Apply the shadowing term.
    pub shadowing: bool,
}

impl<'a> Perturbed<'a> {
    /// The nested model at `si` through `local`.
    #[inline]
    pub fn new(nested: &'a Bsdf, si: &SurfaceInteraction, local: Frame, shadowing: bool) -> Self {
        let mut psi = *si;
        psi.sh_frame = Frame {
            s: si.sh_frame.to_world(local.s),
            t: si.sh_frame.to_world(local.t),
            n: si.sh_frame.to_world(local.n),
        };
        psi.wi = local.to_local(si.wi);
        Perturbed {
            nested,
            local,
            si: psi,
            shadowing,
        }
    }

    /// Nested pdf in the perturbed frame (rotations keep solid angle).
    pub fn pdf(&self, wo: Vec3) -> f32 {
        let pwo = self.local.to_local(wo);
        if !(wo.z * pwo.z > 0.0) {
            return 0.0;
        }
        self.nested.pdf(&self.si, pwo)
    }

    /// Nested eval and pdf in the perturbed frame, the value times the shadowing term.
    pub fn eval_pdf(&self, wo: Vec3) -> (Spectrum, f32) {
        let pwo = self.local.to_local(wo);
        if !(wo.z * pwo.z > 0.0) {
            return (Spectrum::ZERO, 0.0);
        }
        let (mut v, p) = self.nested.eval_pdf(&self.si, pwo);
        if self.shadowing {
            v *= shadow_terminator(self.local.n, wo);
        }
        (v, p)
    }

    /// Samples the nested model in the perturbed frame and rotates the direction back.
    pub fn sample(&self, sample1: f32, sample2: Vec2) -> Option<(BsdfSample, Spectrum)> {
        let (mut bs, mut w) = self.nested.sample(&self.si, sample1, sample2)?;
        if w == Spectrum::ZERO {
            return None;
        }
        let wo = self.local.to_world(bs.wo);
        if !(bs.wo.z * wo.z > 0.0) {
            return None;
        }
        bs.wo = wo;
        if self.shadowing {
            w *= shadow_terminator(self.local.n, wo);
        }
        Some((bs, w))
    }
}
