//! TEMPORARY (removed before landing): data types of the BSDFs that the `bsdf` helper implements.
//! Field names and meanings are the contract the scene loader builds against.

use super::Texture;
use crate::math::Spectrum;

/// Smooth conductor (Mitsuba `conductor`): Fresnel of complex IOR eta + i·k.
#[derive(Clone, Debug)]
pub struct Conductor {
    pub eta: Spectrum,
    pub k: Spectrum,
    pub specular_reflectance: Texture,
}

/// Rough conductor (Mitsuba `roughconductor`, GGX): alpha_u along s, alpha_v along t.
#[derive(Clone, Debug)]
pub struct RoughConductor {
    pub alpha_u: f32,
    pub alpha_v: f32,
    pub eta: Spectrum,
    pub k: Spectrum,
    pub specular_reflectance: Texture,
    /// Sample visible normals (Mitsuba default true).
    pub sample_visible: bool,
}

/// Smooth dielectric interface (Mitsuba `dielectric`), eta = int_ior / ext_ior.
#[derive(Clone, Debug)]
pub struct Dielectric {
    pub eta: f32,
    pub specular_reflectance: Texture,
    pub specular_transmittance: Texture,
}

/// Thin dielectric sheet (Mitsuba `thindielectric`), eta = int_ior / ext_ior.
#[derive(Clone, Debug)]
pub struct ThinDielectric {
    pub eta: f32,
    pub specular_reflectance: Texture,
    pub specular_transmittance: Texture,
}

/// Mitsuba `twosided`: `front` on the front side, `back` (often the same) seen from below.
#[derive(Clone, Debug)]
pub struct TwoSided {
    pub front: Box<super::Bsdf>,
    pub back: Box<super::Bsdf>,
}
