//! Normal mapping (Mitsuba `normalmap`): the nested BSDF is evaluated in a shading frame tilted
//! to the normal n = 2·rgb − 1 read from a texture (tangent space: x along s, y along t, z along
//! the shading normal); the evaluation in that frame is [`Perturbed`]'s.

use super::perturbed::Perturbed;
use super::plugin::{BsdfProperties, single_nested_bsdf};
use super::{Bsdf, BsdfFlags, BsdfSample, Bxdf, Texture};
use crate::Result;
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

impl NormalMap {
    /// Mitsuba's `normalmap`: one nested BSDF, the `normalmap` texture (required),
    /// `flip_invalid_normals`, `use_shadowing_function`.
    pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Self> {
        single_nested_bsdf(
            p,
            "needs a nested bsdf",
            "cannot have more than one nested bsdf",
        )?;
        if !p.has("normalmap") {
            return Err(p.err("the \"normalmap\" texture is required"));
        }
        Ok(NormalMap {
            normalmap: p.texture("normalmap", Vec3::new(0.5, 0.5, 1.0))?,
            flip_invalid_normals: p.bool("flip_invalid_normals", true)?,
            use_shadowing_function: p.bool("use_shadowing_function", true)?,
            nested: Box::new(p.nested_bsdf(0)?),
        })
    }
}

impl NormalMap {
    /// The nested model seen through the normal-mapped frame at this hit.
    #[inline]
    fn perturb(&self, si: &SurfaceInteraction) -> Perturbed<'_> {
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
        Perturbed::new(&self.nested, si, local, self.use_shadowing_function)
    }
}

impl Bxdf for NormalMap {
    /// The nested model's lobes.
    fn flags(&self) -> BsdfFlags {
        let f = self.nested.flags();
        f.varying_if(self.normalmap.is_spatially_varying())
    }

    /// Nested eval in the perturbed frame, times the shadowing term.
    fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        self.eval_pdf(si, wo).0
    }

    /// Nested pdf in the perturbed frame (rotations keep solid angle).
    fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        self.perturb(si).pdf(wo)
    }

    /// `eval` and `pdf` together.
    fn eval_pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> (Spectrum, f32) {
        self.perturb(si).eval_pdf(wo)
    }

    /// Samples the nested model in the perturbed frame and rotates the direction back.
    fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        self.perturb(si).sample(sample1, sample2)
    }
}
