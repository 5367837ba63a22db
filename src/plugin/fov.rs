//! The field of view of a perspective projection as Mitsuba's `parse_fov` reads it, shared by
//! the `perspective` and `thinlens` sensors and the `projector` emitter.

// `!(x > 0.0)` deliberately also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::Properties;
use crate::Result;

/// Mitsuba's `parse_fov`: the horizontal field of view in degrees from `fov` + `fov_axis`
/// (x, y, diagonal, smaller, larger) or a 35 mm `focal_length` (default "50mm"), for a film
/// of `aspect` = width / height.
pub fn horizontal_fov(p: &dyn Properties, aspect: f64) -> Result<f32> {
    if p.has("fov") && p.has("focal_length") {
        return Err(
            p.err("specify either a focal length (\"focal_length\") or a field of view (\"fov\")")
        );
    }
    let (fov, axis) = if p.has("fov") {
        let fov = p.float("fov", 0.0)? as f64;
        let mut axis = p.string("fov_axis", "x")?.to_ascii_lowercase();
        if axis == "smaller" {
            axis = if aspect > 1.0 { "y".into() } else { "x".into() };
        } else if axis == "larger" {
            axis = if aspect > 1.0 { "x".into() } else { "y".into() };
        }
        (fov, axis)
    } else {
        let f = p.string("focal_length", "50mm")?;
        let v: f64 = f.trim_end_matches("mm").trim().parse().map_err(|_| {
            p.err(&format!(
                "could not parse the focal length \"{f}\" (expected <x>mm)"
            ))
        })?;
        let fov = 2.0
            * ((36.0f64 * 36.0 + 24.0 * 24.0).sqrt() / (2.0 * v))
                .atan()
                .to_degrees();
        (fov, "diagonal".to_string())
    };
    let t = (0.5 * fov.to_radians()).tan();
    let result = match axis.as_str() {
        "x" => fov,
        "y" => (2.0 * (t * aspect).atan()).to_degrees(),
        "diagonal" => {
            let width = 2.0 * t / (1.0 + 1.0 / (aspect * aspect)).sqrt();
            (2.0 * (width * 0.5).atan()).to_degrees()
        }
        _ => {
            return Err(p.err("the \"fov_axis\" parameter must be one of \"smaller\", \"larger\", \"diagonal\", \"x\", \"y\""));
        }
    };
    if !(result > 0.0 && result < 180.0) {
        return Err(p.err(&format!(
            "the horizontal field of view must be in (0, 180) degrees, got {result}"
        )));
    }
    Ok(result as f32)
}
