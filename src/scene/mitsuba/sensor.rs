//! `<sensor>` (perspective camera with its `<film>` and `<sampler>`) and `<integrator>`.

use super::properties::Props;
use super::{Builder, N};
use crate::Result;
use crate::math::Mat3;
use crate::math::Mat4;
use crate::math::filter::Filter;
use crate::scene::Camera;
use crate::scene::IntegratorSettings;

/// Mitsuba's film defaults.
const DEFAULT_WIDTH: i64 = 768;
const DEFAULT_HEIGHT: i64 = 576;

impl<'a, 'x> Builder<'a, 'x> {
    pub(super) fn integrator(&mut self, node: N<'a>) -> Result<IntegratorSettings> {
        let p = Props::parse(self.x, node)?;
        if p.ty != "path" {
            return Err(p.err("unsupported integrator type (btfpt implements only \"path\")"));
        }
        let max_depth = p.int("max_depth", -1)?;
        let rr_depth = p.int("rr_depth", 5)?;
        let hide_emitters = p.bool("hide_emitters", false)?;
        p.finish()?;
        if max_depth < -1 || max_depth > i32::MAX as i64 {
            return Err(p.err("\"max_depth\" must be -1 (infinite) or a value >= 0"));
        }
        if rr_depth <= 0 || rr_depth > i32::MAX as i64 {
            return Err(p.err("\"rr_depth\" must be set to a value greater than zero"));
        }
        Ok(IntegratorSettings {
            max_depth: max_depth as i32,
            rr_depth: rr_depth as i32,
            hide_emitters,
        })
    }

    pub(super) fn sensor(&mut self, node: N<'a>) -> Result<(Camera, u32)> {
        let x = self.x;
        let p = Props::parse(x, node)?;
        if p.ty != "perspective" {
            return Err(p.err("unsupported sensor type (btfpt implements only \"perspective\")"));
        }
        // Film first: the aspect ratio resolves fov_axis.
        let film = p.single_child("film")?.ok_or_else(|| {
            p.err(
                "missing <film>: Mitsuba's default film uses a gaussian reconstruction filter; add \
                 <film type=\"hdrfilm\"> with <rfilter type=\"box\"/>",
            )
        })?;
        let f = Props::parse(x, film.node)?;
        if f.ty != "hdrfilm" {
            return Err(f.err("unsupported film type (btfpt implements only \"hdrfilm\")"));
        }
        let width = f.int("width", DEFAULT_WIDTH)?;
        let height = f.int("height", DEFAULT_HEIGHT)?;
        if width <= 0 || height <= 0 || width > 1 << 20 || height > 1 << 20 {
            return Err(f.err(format!("invalid film size {width} x {height}")));
        }
        let cox = f.int("crop_offset_x", 0)?;
        let coy = f.int("crop_offset_y", 0)?;
        let cw = f.int("crop_width", width)?;
        let ch = f.int("crop_height", height)?;
        if cox < 0 || coy < 0 || cw <= 0 || ch <= 0 || cox + cw > width || coy + ch > height {
            return Err(f.err(format!(
                "invalid crop window (offset {cox}, {coy}, size {cw} x {ch}) for a {width} x {height} film"
            )));
        }
        let crop = if (cox, coy, cw, ch) == (0, 0, width, height) {
            None
        } else {
            Some([cox as u32, coy as u32, cw as u32, ch as u32])
        };
        // Output-format options that do not change RGB pixel values are accepted.
        for (name, default, ok) in [
            ("file_format", "openexr", &["openexr", "exr"][..]),
            ("pixel_format", "rgb", &["rgb", "rgba"][..]),
            ("component_format", "float32", &["float16", "float32"][..]),
        ] {
            let v = f.string(name, default)?.to_ascii_lowercase();
            if !ok.contains(&v.as_str()) {
                return Err(f.err(format!(
                    "{name} \"{v}\" is not supported (use one of {ok:?})"
                )));
            }
        }
        if f.bool("sample_border", false)? {
            return Err(f.err(
                "sample_border=true is not supported (samples are taken inside the film only)",
            ));
        }
        // No <rfilter>: Mitsuba's default gaussian (stddev 0.5).
        let filter = match f.single_child("rfilter")? {
            None => Filter::default(),
            Some(rf) => {
                let r = Props::parse(x, rf.node)?;
                let filter = match r.ty.as_str() {
                    "box" => Filter::boxed(r.float("radius", 0.5)?),
                    "tent" => Filter::tent(r.float("radius", 1.0)?),
                    "gaussian" => Filter::gaussian(r.float("stddev", 0.5)?),
                    "mitchell" => Filter::mitchell(
                        r.float("B", 1.0 / 3.0)?,
                        r.float("C", 1.0 / 3.0)?,
                        r.float("radius", 2.0)?,
                    ),
                    "catmullrom" => Filter::mitchell(0.0, 0.5, r.float("radius", 2.0)?),
                    "lanczos" => Filter::lanczos(r.int("lobes", 3)?),
                    _ => {
                        return Err(r.err(
                            "unsupported reconstruction filter (box, tent, gaussian, mitchell, \
                             catmullrom and lanczos are implemented)",
                        ));
                    }
                }
                .map_err(|e| r.err(e.to_string()))?;
                r.finish()?;
                filter
            }
        };
        f.finish()?;

        let aspect = width as f64 / height as f64;
        let fov_x = parse_fov(&p, aspect)?;
        let near_clip = p.float("near_clip", 1e-2)?;
        let far_clip = p.float("far_clip", 1e4)?;
        if near_clip <= 0.0 {
            return Err(p.err("the \"near_clip\" parameter must be greater than zero"));
        }
        if near_clip >= far_clip {
            return Err(p.err("the \"near_clip\" parameter must be smaller than \"far_clip\""));
        }
        // A pinhole camera is in focus everywhere: the focus distance changes nothing.
        let _ = p.float("focus_distance", far_clip)?;
        let to_world = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
        let l = Mat3::from_mat4(to_world);
        let g = l.transpose() * l;
        if (g - Mat3::IDENTITY)
            .to_cols_array()
            .iter()
            .any(|v| v.abs() > 1e-3)
        {
            return Err(
                p.err("scale factors in the camera-to-world transformation are not allowed")
            );
        }

        let spp = match p.single_child("sampler")? {
            None => 4,
            Some(s) => {
                let s = Props::parse(x, s.node)?;
                if s.ty != "independent" {
                    return Err(
                        s.err("unsupported sampler type (btfpt implements only \"independent\")")
                    );
                }
                let n = s.int("sample_count", 4)?;
                // The seed only changes the noise pattern, never the expected image.
                let _ = s.int("seed", 0)?;
                s.finish()?;
                if n <= 0 || n > u32::MAX as i64 {
                    return Err(s.err(format!("invalid sample_count {n}")));
                }
                n as u32
            }
        };
        p.finish()?;
        Ok((
            Camera {
                to_world,
                fov_x_deg: fov_x,
                near_clip,
                far_clip,
                width: width as u32,
                height: height as u32,
                crop,
                filter,
            },
            spp,
        ))
    }
}

/// Mitsuba's `parse_fov`: the horizontal field of view in degrees from `fov` + `fov_axis`
/// (x, y, diagonal, smaller, larger) or a 35 mm `focal_length` (default "50mm").
fn parse_fov(p: &Props, aspect: f64) -> Result<f32> {
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
            p.err(format!(
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
        return Err(p.err(format!(
            "the horizontal field of view must be in (0, 180) degrees, got {result}"
        )));
    }
    Ok(result as f32)
}
