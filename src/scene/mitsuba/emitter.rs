//! `<emitter>`: point, spot, directional, constant, envmap (area emitters are attached by
//! `shape`).

use super::Builder;
use super::check_finite;
use super::properties::Props;
use crate::Result;
use crate::math::Mat4;
use crate::math::Vec3;
use crate::math::transform::xf_point;
use crate::plugin::Properties;
use crate::scene::Emitter;
use std::sync::Arc;

impl<'a, 'x> Builder<'a, 'x> {
    pub(super) fn emitter(&mut self, p: &Props<'a, 'x>) -> Result<Emitter> {
        let x = self.x;
        Ok(match p.ty.as_str() {
            "point" => {
                let intensity = p.emission("intensity", Vec3::ONE)?;
                let pos = p.vec3_opt("position")?;
                let xf = p.transform_opt("to_world")?;
                let position = match (pos, xf) {
                    (Some(_), Some(_)) => {
                        return Err(
                            p.err("only one of \"position\" and \"to_world\" can be specified")
                        );
                    }
                    (Some(v), None) => v,
                    (None, Some(m)) => xf_point(&m, Vec3::ZERO),
                    (None, None) => Vec3::ZERO,
                };
                if !position.is_finite() {
                    return Err(p.err("non-finite position"));
                }
                Emitter::Point {
                    position,
                    intensity,
                }
            }
            "spot" => {
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
                Emitter::Spot {
                    to_world,
                    intensity,
                    cutoff_angle,
                    beam_width,
                }
            }
            "directional" => {
                let irradiance = p.emission("irradiance", Vec3::ONE)?;
                let d = p.vec3_opt("direction")?;
                let xf = p.transform_opt("to_world")?;
                let direction = match (d, xf) {
                    (Some(_), Some(_)) => {
                        return Err(
                            p.err("only one of \"direction\" and \"to_world\" can be specified")
                        );
                    }
                    (Some(v), None) => v.normalize(),
                    (None, Some(m)) => m.transform_vector3(Vec3::Z).normalize(),
                    (None, None) => Vec3::Z,
                };
                if !direction.is_finite() {
                    return Err(p.err("the direction must be a non-zero finite vector"));
                }
                Emitter::Directional {
                    direction,
                    irradiance,
                }
            }
            "constant" => Emitter::Constant {
                radiance: p.emission("radiance", Vec3::ONE)?,
            },
            "envmap" => {
                let file = p.string_req("filename")?;
                let scale = p.float("scale", 1.0)?;
                let to_world = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
                let path = x.resolve(&file);
                let image = crate::io::read_image(&path).map_err(|e| p.err(e.to_string()))?;
                check_finite(&image, &path).map_err(|m| p.err(m))?;
                Emitter::EnvMap {
                    image: Arc::new(image),
                    to_world,
                    scale,
                    filename: path,
                }
            }
            _ => {
                return Err(p.err(
                    "unsupported emitter type (btfpt implements area, point, spot, directional, constant, envmap)",
                ));
            }
        })
    }
}
