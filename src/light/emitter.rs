//! What a scene says about its emitters that are not attached to a shape (area emitters live on
//! [`Mesh::emitter`](crate::geometry::Mesh)), and the constructors that read each one's
//! properties (Mitsuba 3's `point`, `spot`, `directional`, `constant`, `envmap`); [`LightSet`]
//! makes the lights the integrators sample from these descriptions.
//!
//! [`LightSet`]: super::LightSet

use crate::Result;
use crate::io::RgbImage;
use crate::math::transform::xf_point;
use crate::math::{Mat4, Spectrum, Vec3};
use crate::plugin::Properties;
use std::path::PathBuf;
use std::sync::Arc;

/// Emitters that are not attached to a shape (area emitters live on [`Mesh::emitter`]).
#[derive(Clone, Debug)]
pub enum Emitter {
    /// Isotropic point light; `intensity` in W/sr.
    Point { position: Vec3, intensity: Spectrum },
    /// Spot light shining along +z of `to_world`; angles in degrees (Mitsuba defaults 20 and 0.75·cutoff).
    Spot {
        to_world: Mat4,
        intensity: Spectrum,
        cutoff_angle: f32,
        beam_width: f32,
    },
    /// Distant light; `direction` is the unit direction of travel (world), `irradiance` in W/m².
    Directional {
        direction: Vec3,
        irradiance: Spectrum,
    },
    /// Uniform environment radiance.
    Constant { radiance: Spectrum },
    /// Lat-long environment map (Mitsuba `envmap` mapping), radiance = scale · image.
    EnvMap {
        image: Arc<RgbImage>,
        to_world: Mat4,
        scale: f32,
        filename: PathBuf,
    },
}

impl Emitter {
    /// Mitsuba's `area` (nested in a shape, whose mesh carries it): its `radiance` in
    /// W/(m² sr).
    pub fn area_radiance_from_props(p: &dyn Properties) -> Result<Spectrum> {
        p.emission("radiance", Vec3::ONE)
    }

    /// Mitsuba's `point`: `intensity` (W/sr), `position` or `to_world`.
    pub fn point_from_props(p: &dyn Properties) -> Result<Emitter> {
        let intensity = p.emission("intensity", Vec3::ONE)?;
        let pos = p.vec3_opt("position")?;
        let xf = p.transform_opt("to_world")?;
        let position = match (pos, xf) {
            (Some(_), Some(_)) => {
                return Err(p.err("only one of \"position\" and \"to_world\" can be specified"));
            }
            (Some(v), None) => v,
            (None, Some(m)) => xf_point(&m, Vec3::ZERO),
            (None, None) => Vec3::ZERO,
        };
        if !position.is_finite() {
            return Err(p.err("non-finite position"));
        }
        Ok(Emitter::Point {
            position,
            intensity,
        })
    }

    /// Mitsuba's `spot`: `intensity`, `cutoff_angle`, `beam_width` (degrees), `to_world`.
    pub fn spot_from_props(p: &dyn Properties) -> Result<Emitter> {
        let intensity = p.emission("intensity", Vec3::ONE)?;
        let cutoff_angle = p.float("cutoff_angle", 20.0)?;
        let mut beam_width = p.float("beam_width", cutoff_angle * 0.75)?;
        if beam_width > cutoff_angle {
            beam_width = cutoff_angle; // Mitsuba clamps (with a warning)
        }
        if !(cutoff_angle > 0.0 && cutoff_angle <= 180.0) {
            return Err(p.err("cutoff_angle must be in (0, 180] degrees"));
        }
        let to_world = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
        Ok(Emitter::Spot {
            to_world,
            intensity,
            cutoff_angle,
            beam_width,
        })
    }

    /// Mitsuba's `directional`: `irradiance` (W/m²), `direction` or `to_world`.
    pub fn directional_from_props(p: &dyn Properties) -> Result<Emitter> {
        let irradiance = p.emission("irradiance", Vec3::ONE)?;
        let d = p.vec3_opt("direction")?;
        let xf = p.transform_opt("to_world")?;
        let direction = match (d, xf) {
            (Some(_), Some(_)) => {
                return Err(p.err("only one of \"direction\" and \"to_world\" can be specified"));
            }
            (Some(v), None) => v.normalize(),
            (None, Some(m)) => m.transform_vector3(Vec3::Z).normalize(),
            (None, None) => Vec3::Z,
        };
        if !direction.is_finite() {
            return Err(p.err("the direction must be a non-zero finite vector"));
        }
        Ok(Emitter::Directional {
            direction,
            irradiance,
        })
    }

    /// Mitsuba's `constant`: `radiance`.
    pub fn constant_from_props(p: &dyn Properties) -> Result<Emitter> {
        Ok(Emitter::Constant {
            radiance: p.emission("radiance", Vec3::ONE)?,
        })
    }

    /// Mitsuba's `envmap`: `filename` (a lat-long image of finite values), `scale`, `to_world`.
    pub fn envmap_from_props(p: &dyn Properties) -> Result<Emitter> {
        let file = p.string_req("filename")?;
        let scale = p.float("scale", 1.0)?;
        let to_world = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
        let path = p.resolve(&file);
        let image: RgbImage = crate::io::read_image(&path).map_err(|e| p.err(&e.to_string()))?;
        image.check_finite(&path).map_err(|m| p.err(&m))?;
        Ok(Emitter::EnvMap {
            image: Arc::new(image),
            to_world,
            scale,
            filename: path,
        })
    }
}
