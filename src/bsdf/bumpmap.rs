//! Bump mapping (Mitsuba `bumpmap`): the nested BSDF is evaluated in a shading frame tilted by
//! the gradient of a height texture. The surface's ∂p/∂u, ∂p/∂v are displaced along the
//! shading normal by `scale` × the texture's uv gradient, and their cross product is the new
//! normal; the evaluation in that frame is [`Perturbed`]'s, as for [`super::NormalMap`].

use super::perturbed::Perturbed;
use super::plugin::{BsdfProperties, single_nested_bsdf};
use super::{Bsdf, BsdfFlags, BsdfSample, Bxdf, Texture};
use crate::Result;
use crate::geometry::SurfaceInteraction;
use crate::math::{Frame, Spectrum, Vec2, Vec3};

/// Mitsuba `bumpmap` around `nested`.
#[derive(Clone, Debug)]
pub struct BumpMap {
    /// Height field (a bitmap: its luminance, as Mitsuba's `eval_1`), in units of `scale`.
    pub height: Texture,
    /// Multiplier on the height gradient (Mitsuba default 1).
    pub scale: f32,
    /// The model evaluated in the perturbed frame.
    pub nested: Box<Bsdf>,
    /// Mirror normals facing away from wi about the shading normal (Mitsuba default true).
    pub flip_invalid_normals: bool,
    /// Apply the shadowing term (Mitsuba `use_shadowing_function`, default true).
    pub use_shadowing_function: bool,
}

impl BumpMap {
    /// Mitsuba's `bumpmap`: one nested BSDF, one nested height texture whatever its name (a
    /// bitmap: Mitsuba differentiates only bitmaps), `scale`, `flip_invalid_normals`,
    /// `use_shadowing_function`.
    pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Self> {
        single_nested_bsdf(
            p,
            "exactly one nested bsdf must be specified",
            "only a single nested bsdf can be specified",
        )?;
        let height = match p.nested_texture_count() {
            1 => p.nested_texture(0)?,
            0 => return Err(p.err("exactly one nested height texture must be specified")),
            _ => return Err(p.err("only a single nested texture can be specified")),
        };
        if !height.has_gradient() {
            return Err(
                p.err("the height texture must be a bitmap (Mitsuba differentiates only bitmaps)")
            );
        }
        Ok(BumpMap {
            height,
            // NaN/Inf are refused by the property parser.
            scale: p.float("scale", 1.0)?,
            flip_invalid_normals: p.bool("flip_invalid_normals", true)?,
            use_shadowing_function: p.bool("use_shadowing_function", true)?,
            nested: Box::new(p.nested_bsdf(0)?),
        })
    }
}

impl BumpMap {
    /// The nested model seen through the bumped frame (Mitsuba `BumpMap::frame`) at this hit.
    #[inline]
    fn perturb(&self, si: &SurfaceInteraction) -> Perturbed<'_> {
        let grad = self.height.eval_1_grad(si.uv) * self.scale;
        let sn = si.sh_frame.n;
        let dp_du = si.dpdu + sn * (grad.x - sn.dot(si.dpdu));
        let dp_dv = si.dpdv + sn * (grad.y - sn.dot(si.dpdv));
        let mut n = dp_du.cross(dp_dv).normalize();
        if si.n.dot(n) < 0.0 {
            n = -n;
        }
        let mut n = si.to_local(n);
        if self.flip_invalid_normals && si.wi.z * si.wi.dot(n) <= 0.0 {
            n = Vec3::new(-n.x, -n.y, n.z);
        }
        // Mitsuba orthogonalises the world ∂p/∂u against the now-local normal; reproduced as
        // is (only the tangent's azimuth depends on it, which matters for anisotropic models).
        let s = (si.dpdu - n * n.dot(si.dpdu)).normalize();
        let local = Frame {
            s,
            t: n.cross(s),
            n,
        };
        Perturbed::new(&self.nested, si, local, self.use_shadowing_function)
    }
}

impl Bxdf for BumpMap {
    /// The nested model's lobes, spatially varying.
    fn flags(&self) -> BsdfFlags {
        self.nested.flags() | BsdfFlags::SPATIALLY_VARYING
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
