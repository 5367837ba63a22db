//! Surface scattering models behind one small interface (Mitsuba 3 `BSDF` semantics).
//!
//! Directions are local to the hit's shading frame: `si.wi` points toward the previous vertex (the
//! camera side), `wo` toward the next one (the light side). `eval` returns f(wi, wo) · |cos θ_o|
//! (for a measured BTF that is B/π, docs/conventions.md); `sample` returns the sampled direction with the
//! weight f · |cos θ_o| / pdf. Each model implements [`Bxdf`]; [`Bsdf`] is the enum of them all.

pub mod albedo;
pub mod at;
pub mod batch;
pub mod blend;
pub mod btf;
pub mod btf_clusters;
pub mod btf_sampler;
pub mod bumpmap;
#[cfg(test)]
pub(crate) mod chi2;
pub mod conductor;
pub mod conductor_materials;
pub mod dielectric;
pub mod diffuse;
pub mod fresnel;
pub mod ior;
pub mod mask;
pub mod microfacet;
pub mod normalmap;
pub mod perturbed;
pub mod plastic;
pub mod plmc;
pub mod plugin;
pub mod polarizer;
pub mod pplastic;
pub mod principled;
pub mod principled_lobes;
pub mod principledthin;
pub mod roughconductor;
pub mod roughdielectric;
pub mod roughplastic;
pub mod texture;
pub mod thindielectric;
pub mod twosided;

#[cfg(test)]
mod golden;
#[cfg(test)]
mod tests;

pub use at::BsdfAt;
pub use blend::BlendBsdf;
pub use btf::{BtfBsdf, BtfMaterial};
pub use bumpmap::BumpMap;
pub use conductor::Conductor;
pub use dielectric::Dielectric;
pub use diffuse::Diffuse;
pub use mask::Mask;
pub use microfacet::MicrofacetType;
pub use normalmap::NormalMap;
pub use plastic::Plastic;
pub use plmc::{PlmcBsdf, PlmcHit};
pub use plugin::BsdfProperties;
pub use polarizer::Polarizer;
pub use pplastic::PPlastic;
pub use principled::Principled;
pub use principledthin::PrincipledThin;
pub use roughconductor::RoughConductor;
pub use roughdielectric::RoughDielectric;
pub use roughplastic::RoughPlastic;
pub use texture::Texture;
pub use thindielectric::ThinDielectric;
pub use twosided::TwoSided;

use crate::geometry::SurfaceInteraction;
use crate::math::{Spectrum, Vec2, Vec3};

/// Lobe classification bits (Mitsuba's `BSDFFlags`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct BsdfFlags(pub u32);

impl BsdfFlags {
    pub const NONE: BsdfFlags = BsdfFlags(0);
    pub const DIFFUSE_REFLECTION: BsdfFlags = BsdfFlags(1);
    pub const GLOSSY_REFLECTION: BsdfFlags = BsdfFlags(1 << 1);
    pub const DELTA_REFLECTION: BsdfFlags = BsdfFlags(1 << 2);
    pub const DIFFUSE_TRANSMISSION: BsdfFlags = BsdfFlags(1 << 3);
    pub const GLOSSY_TRANSMISSION: BsdfFlags = BsdfFlags(1 << 4);
    pub const DELTA_TRANSMISSION: BsdfFlags = BsdfFlags(1 << 5);
    /// Spatially varying (uv-dependent) response.
    pub const SPATIALLY_VARYING: BsdfFlags = BsdfFlags(1 << 6);
    pub const DELTA: BsdfFlags = BsdfFlags((1 << 2) | (1 << 5));
    /// Lobes that `eval`/`pdf` can see (everything but delta), i.e. worth emitter sampling.
    pub const SMOOTH: BsdfFlags = BsdfFlags(1 | (1 << 1) | (1 << 3) | (1 << 4));

    /// True if any bit of `other` is set.
    #[inline]
    pub fn has(self, other: BsdfFlags) -> bool {
        self.0 & other.0 != 0
    }

    /// These flags, plus [`BsdfFlags::SPATIALLY_VARYING`] when `varying` (a model whose
    /// parameters include a texture).
    #[inline]
    pub fn varying_if(self, varying: bool) -> BsdfFlags {
        if varying {
            self | BsdfFlags::SPATIALLY_VARYING
        } else {
            self
        }
    }
}

impl std::ops::BitOr for BsdfFlags {
    type Output = BsdfFlags;
    fn bitor(self, rhs: BsdfFlags) -> BsdfFlags {
        BsdfFlags(self.0 | rhs.0)
    }
}

/// The outcome of [`Bsdf::sample`].
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Sampled direction, local to the shading frame.
    pub wo: Vec3,
    /// Solid-angle pdf of `wo` (for a delta lobe: the discrete probability of choosing it).
    pub pdf: f32,
    /// Relative index of refraction along the sampled path (1 for reflection).
    pub eta: f32,
    /// The lobe that was sampled (one of the single-lobe flags).
    pub sampled: BsdfFlags,
}

/// What every scattering model answers (pbrt-v4's `BxDF` interface, Mitsuba 3's `BSDF`
/// methods); [`Bsdf`] forwards each call to the model it holds. Directions are local to the
/// shading frame (see the module doc).
pub trait Bxdf {
    /// The lobes this model has.
    fn flags(&self) -> BsdfFlags;

    /// f(wi, wo) · |cos θ_o|; zero for delta lobes and for direction pairs the model does not cover.
    fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum;

    /// Solid-angle pdf with which [`Bxdf::sample`] produces `wo` (0 for delta lobes).
    fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32;

    /// `(eval, pdf)` in one call (Mitsuba `eval_pdf`): what emitter sampling with MIS needs.
    /// Models that share work between the two override it.
    fn eval_pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> (Spectrum, f32) {
        (self.eval(si, wo), self.pdf(si, wo))
    }

    /// Samples `wo` given one uniform number for lobe selection and two for the direction.
    /// Returns the sample and its weight f · |cos θ_o| / pdf, or None if sampling failed.
    fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)>;

    /// Hint at a new hit, before light sampling: starts the memory loads the first evaluation
    /// at `si` will need (a PLM-C texel's index entries, usually a DRAM miss), so they overlap
    /// with the work in between. No effect on results; a no-op for analytic models.
    #[inline]
    fn prefetch(&self, _si: &SurfaceInteraction) {}
}

/// Declares [`Bsdf`] with one variant per model, `From` each model, and the [`Bxdf`] calls
/// forwarded to the model: the one place that lists every variant.
macro_rules! bsdf_enum {
    ($($(#[$doc:meta])* $variant:ident($model:ty),)*) => {
        /// Every scattering model of btfpt (a static enum, not a trait object, keeps the hot
        /// path monomorphic).
        #[derive(Clone, Debug)]
        pub enum Bsdf {
            $($(#[$doc])* $variant($model),)*
        }

        $(impl From<$model> for Bsdf {
            fn from(b: $model) -> Bsdf {
                Bsdf::$variant(b)
            }
        })*

        impl Bsdf {
            /// The lobes this BSDF has.
            pub fn flags(&self) -> BsdfFlags {
                match self {
                    $(Bsdf::$variant(b) => b.flags(),)*
                }
            }

            /// [`Bxdf::prefetch`] of the model.
            #[inline]
            pub fn prefetch(&self, si: &SurfaceInteraction) {
                match self {
                    $(Bsdf::$variant(b) => b.prefetch(si),)*
                }
            }

            /// f(wi, wo) · |cos θ_o|; zero for delta lobes and for direction pairs the model does
            /// not cover.
            pub fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
                match self {
                    $(Bsdf::$variant(b) => b.eval(si, wo),)*
                }
            }

            /// Solid-angle pdf with which [`Bsdf::sample`] produces `wo` (0 for delta lobes).
            pub fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
                match self {
                    $(Bsdf::$variant(b) => b.pdf(si, wo),)*
                }
            }

            /// `(eval, pdf)` in one call (Mitsuba `eval_pdf`): what emitter sampling with MIS needs.
            pub fn eval_pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> (Spectrum, f32) {
                match self {
                    $(Bsdf::$variant(b) => b.eval_pdf(si, wo),)*
                }
            }

            /// Samples `wo` given one uniform number for lobe selection and two for the direction.
            /// Returns the sample and its weight f · |cos θ_o| / pdf, or None if sampling failed.
            pub fn sample(
                &self,
                si: &SurfaceInteraction,
                sample1: f32,
                sample2: Vec2,
            ) -> Option<(BsdfSample, Spectrum)> {
                match self {
                    $(Bsdf::$variant(b) => b.sample(si, sample1, sample2),)*
                }
            }
        }
    };
}

bsdf_enum! {
    Diffuse(Diffuse),
    Conductor(Conductor),
    RoughConductor(RoughConductor),
    Dielectric(Dielectric),
    ThinDielectric(ThinDielectric),
    TwoSided(TwoSided),
    /// Smooth plastic: diffuse base under a smooth dielectric coating.
    Plastic(Plastic),
    /// Rough plastic: diffuse base under a rough (Beckmann or GGX) dielectric coating.
    RoughPlastic(RoughPlastic),
    /// Rough (Beckmann or GGX) dielectric interface.
    RoughDielectric(RoughDielectric),
    /// Polarized plastic's unpolarized response (Mitsuba `pplastic`).
    PPlastic(PPlastic),
    /// Linear polarizer seen by unpolarized light: a null interface passing half (Mitsuba
    /// `polarizer`).
    Polarizer(Polarizer),
    /// Weighted blend of two BSDFs (also Mitsuba 0.6's two-component `mixturebsdf`).
    Blend(BlendBsdf),
    /// Opacity mask: a null (straight-through) lobe around a nested BSDF.
    Mask(Mask),
    /// Shading-frame perturbation from a tangent-space normal map around a nested BSDF.
    NormalMap(NormalMap),
    /// Shading-frame perturbation from the gradient of a height texture around a nested BSDF.
    BumpMap(BumpMap),
    /// Disney's principled BSDF (Mitsuba `principled`).
    Principled(Principled),
    /// Disney's thin-sheet principled BSDF (Mitsuba `principledthin`).
    PrincipledThin(PrincipledThin),
    /// Measured BTF (raw data), docs/conventions.md.
    Btf(BtfBsdf),
    /// Measured BTF as a fitted LM / PLM / PLM-C model (docs/model.md).
    Plmc(PlmcBsdf),
}
