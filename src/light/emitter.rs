//! What a scene says about its emitters that are not attached to a shape (area emitters live on
//! [`Mesh::emitter`](crate::geometry::Mesh)), and the constructors that read each one's
//! properties (Mitsuba 3's `point`, `spot`, `projector`, `directional`, `constant`, `envmap`);
//! [`LightSet`]
//! makes the lights the integrators sample from these descriptions.
//!
//! [`LightSet`]: super::LightSet

use crate::Result;
use crate::bsdf::{BsdfProperties, Texture};
use crate::io::RgbImage;
use crate::math::cie1931::SpectrumUse;
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
    /// Spot light shining along +z of `to_world`; angles in degrees (Mitsuba defaults 20 and
    /// 0.75·cutoff); `texture` (spatially varying) is projected over the cutoff cone.
    Spot {
        to_world: Mat4,
        intensity: Spectrum,
        cutoff_angle: f32,
        beam_width: f32,
        texture: Option<Texture>,
    },
    /// Projector looking along +z of `to_world`: `irradiance` (W/m² on the image plane at
    /// distance 1) times `scale`, over a frustum of horizontal field of view `fov_x` (degrees)
    /// and the texture's aspect ratio.
    Projector {
        to_world: Mat4,
        irradiance: Texture,
        scale: f32,
        fov_x: f32,
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
    /// W/(m² sr), a constant or a texture over the shape's uvs (a `bitmap`, `checkerboard`, ...).
    pub fn area_radiance_from_props(p: &mut dyn BsdfProperties) -> Result<Texture> {
        p.texture_as("radiance", Vec3::ONE, SpectrumUse::Emission)
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

    /// Mitsuba's `spot`: `intensity`, `cutoff_angle`, `beam_width` (degrees), `to_world` and an
    /// optional spatially varying `texture`.
    pub fn spot_from_props(p: &mut dyn BsdfProperties) -> Result<Emitter> {
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
        let texture = if p.has("texture") {
            let t = p.texture_as("texture", Vec3::ONE, SpectrumUse::Reflectance)?;
            if !t.is_spatially_varying() {
                return Err(p.err_at(
                    "texture",
                    "the parameter \"texture\" must be spatially varying (e.g. a bitmap)",
                ));
            }
            Some(t)
        } else {
            None
        };
        Ok(Emitter::Spot {
            to_world,
            intensity,
            cutoff_angle,
            beam_width,
            texture,
        })
    }

    /// Mitsuba's `projector`: `irradiance` (a colour or a texture, typically a bitmap), `scale`,
    /// `to_world`, and `fov` + `fov_axis` or `focal_length` for a film of the texture's aspect.
    pub fn projector_from_props(p: &mut dyn BsdfProperties) -> Result<Emitter> {
        let scale = p.float("scale", 1.0)?;
        if !scale.is_finite() {
            return Err(p.err_at("scale", "\"scale\" must be finite"));
        }
        let to_world = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
        if !crate::math::transform::is_finite(&to_world) {
            return Err(p.err_at("to_world", "to_world contains NaN or infinite values"));
        }
        let irradiance = p.texture_as("irradiance", Vec3::ONE, SpectrumUse::Emission)?;
        let (w, h) = irradiance.resolution();
        let fov_x = crate::plugin::horizontal_fov(p, w as f64 / h as f64)?;
        Ok(Emitter::Projector {
            to_world,
            irradiance,
            scale,
            fov_x,
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
