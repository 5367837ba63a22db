//! Normal mapping (Mitsuba `normalmap`): the nested BSDF is evaluated in a shading frame tilted
//! to the normal n = 2·rgb − 1 read from a texture (tangent space: x along s, y along t, z along
//! the shading normal), with Estevez et al.'s (2019) shadowing term against bump-terminator
//! artefacts. Directions whose side differs between the two frames get no response.

use super::{Bsdf, BsdfFlags, BsdfSample, Texture};
use crate::geometry::SurfaceInteraction;
use crate::math::{Frame, Spectrum, Vec2, Vec3};

/// Mitsuba `normalmap` around `nested`.
#[derive(Clone, Debug)]
pub struct NormalMap {
    /// Tangent-space normals encoded as rgb = (n + 1) / 2 (linear values: use raw/EXR images).
    pub normalmap: Texture,
    /// The model evaluated in the perturbed frame.
    pub nested: Box<Bsdf>,
    /// Mirror normals facing away from wi about the shading normal (Mitsuba default true).
    pub flip_invalid_normals: bool,
    /// Apply the shadowing term (Mitsuba `use_shadowing_function`, default true).
    pub use_shadowing_function: bool,
}

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

impl NormalMap {
    /// The perturbed frame relative to the shading frame, and the hit seen in that frame.
    #[inline]
    fn perturb(&self, si: &SurfaceInteraction) -> (Frame, SurfaceInteraction) {
        let mut n = self.normalmap.eval(si.uv) * 2.0 - Vec3::ONE;
        if self.flip_invalid_normals && si.wi.z * si.wi.dot(n) <= 0.0 {
            n = Vec3::new(-n.x, -n.y, n.z);
        }
        let n = n.normalize();
        let s = (Vec3::X - n * n.x).normalize();
        let local = Frame {
            s,
            t: n.cross(s),
            n,
        };
        let mut psi = *si;
        psi.sh_frame = Frame {
            s: si.sh_frame.to_world(local.s),
            t: si.sh_frame.to_world(local.t),
            n: si.sh_frame.to_world(local.n),
        };
        psi.wi = local.to_local(si.wi);
        (local, psi)
    }

    /// The nested model's lobes.
    pub fn flags(&self) -> BsdfFlags {
        let f = self.nested.flags();
        if self.normalmap.is_spatially_varying() {
            f | BsdfFlags::SPATIALLY_VARYING
        } else {
            f
        }
    }

    /// Nested eval in the perturbed frame, times the shadowing term.
    pub fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        self.eval_pdf(si, wo).0
    }

    /// Nested pdf in the perturbed frame (rotations keep solid angle).
    pub fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        let (local, psi) = self.perturb(si);
        let pwo = local.to_local(wo);
        if !(wo.z * pwo.z > 0.0) {
            return 0.0;
        }
        self.nested.pdf(&psi, pwo)
    }

    /// `eval` and `pdf` together.
    pub fn eval_pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> (Spectrum, f32) {
        let (local, psi) = self.perturb(si);
        let pwo = local.to_local(wo);
        if !(wo.z * pwo.z > 0.0) {
            return (Spectrum::ZERO, 0.0);
        }
        let (mut v, p) = self.nested.eval_pdf(&psi, pwo);
        if self.use_shadowing_function {
            v *= shadow_terminator(local.n, wo);
        }
        (v, p)
    }

    /// Samples the nested model in the perturbed frame and rotates the direction back.
    pub fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        let (local, psi) = self.perturb(si);
        let (mut bs, mut w) = self.nested.sample(&psi, sample1, sample2)?;
        if w == Spectrum::ZERO {
            return None;
        }
        let wo = local.to_world(bs.wo);
        if !(bs.wo.z * wo.z > 0.0) {
            return None;
        }
        bs.wo = wo;
        if self.use_shadowing_function {
            w *= shadow_terminator(local.n, wo);
        }
        Some((bs, w))
    }
}
