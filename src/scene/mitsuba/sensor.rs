//! `<sensor>` (perspective camera with its `<film>` and `<sampler>`) and `<integrator>`.

use super::properties::Props;
use super::{Builder, N};
use crate::Result;
use crate::math::Mat3;
use crate::math::Mat4;
use crate::math::filter::Filter;
use crate::plugin::Properties;
use crate::scene::Camera;
use crate::scene::{DirectSettings, IntegratorSettings, SamplerType};

/// Mitsuba's film defaults.
const DEFAULT_WIDTH: i64 = 768;
const DEFAULT_HEIGHT: i64 = 576;

impl<'a, 'x> Builder<'a, 'x> {
    pub(super) fn integrator(&mut self, node: N<'a>) -> Result<IntegratorSettings> {
        let p = Props::parse(self.x, node)?;
        match p.ty.as_str() {
            "path" => {
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
                    ..Default::default()
                })
            }
            "direct" => {
                if p.has("shading_samples") && (p.has("emitter_samples") || p.has("bsdf_samples")) {
                    return Err(p.err(
                        "cannot specify both 'shading_samples' and ('emitter_samples' and/or 'bsdf_samples')",
                    ));
                }
                let count = |name: &str, default: i64| -> Result<u32> {
                    let v = p.int(name, default)?;
                    u32::try_from(v)
                        .ok()
                        .filter(|v| *v <= 1 << 16)
                        .ok_or_else(|| p.err(format!("\"{name}\" = {v} must be in 0..=65536")))
                };
                let shading = count("shading_samples", 1)?;
                let emitter_samples = count("emitter_samples", shading as i64)?;
                let bsdf_samples = count("bsdf_samples", shading as i64)?;
                let hide_emitters = p.bool("hide_emitters", false)?;
                p.finish()?;
                if emitter_samples + bsdf_samples == 0 {
                    return Err(p.err("must have at least 1 BSDF or emitter sample"));
                }
                Ok(IntegratorSettings {
                    direct: Some(DirectSettings {
                        emitter_samples,
                        bsdf_samples,
                    }),
                    hide_emitters,
                    ..Default::default()
                })
            }
            _ => {
                Err(p.err("unsupported integrator type (btfpt implements \"path\" and \"direct\")"))
            }
        }
    }

    /// The camera, the sample count and the sampler named.
    pub(super) fn sensor(&mut self, node: N<'a>) -> Result<(Camera, u32, SamplerType)> {
        let x = self.x;
        let p = Props::parse(x, node)?;
        if p.ty != "perspective" {
            return Err(p.err("unsupported sensor type (btfpt implements only \"perspective\")"));
        }
        // Film first: the aspect ratio resolves fov_axis. No <film>: Mitsuba's default hdrfilm
        // (768 × 576, gaussian filter).
        let (width, height, crop, filter) = match p.single_child("film")? {
            None => (DEFAULT_WIDTH, DEFAULT_HEIGHT, None, Filter::default()),
            Some(film) => {
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
                if cox < 0 || coy < 0 || cw <= 0 || ch <= 0 || cox + cw > width || coy + ch > height
                {
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
                // The Mitsuba logo stamped into the output file: no effect on the radiance.
                let _ = f.bool("banner", true)?;
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
                (width, height, crop, filter)
            }
        };
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

        let (spp, sampler) = match p.single_child("sampler")? {
            None => (4, SamplerType::Independent),
            Some(s) => {
                let s = Props::parse(x, s.node)?;
                let ty = match s.ty.as_str() {
                    "independent" => SamplerType::Independent,
                    "stratified" => SamplerType::Stratified,
                    "multijitter" => SamplerType::Multijitter,
                    "ldsampler" => SamplerType::LdSampler,
                    "orthogonal" => SamplerType::Orthogonal,
                    _ => {
                        return Err(s.err(
                            "unsupported sampler type (btfpt accepts independent, stratified, \
                             multijitter, ldsampler and orthogonal)",
                        ));
                    }
                };
                let n = s.int("sample_count", 4)?;
                // The seed only changes the noise pattern, never the expected image; so do the
                // stratification options of the other samplers (btfpt draws independently).
                let _ = s.int("seed", 0)?;
                if matches!(
                    ty,
                    SamplerType::Stratified | SamplerType::Multijitter | SamplerType::Orthogonal
                ) {
                    let _ = s.bool("jitter", true)?;
                }
                if ty == SamplerType::Orthogonal {
                    let _ = s.int("strength", 2)?;
                }
                s.finish()?;
                if n <= 0 || n > 1 << 24 {
                    return Err(s.err(format!("invalid sample_count {n}")));
                }
                (mitsuba_sample_count(ty, n as u32), ty)
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
            sampler,
        ))
    }
}

/// The sample count Mitsuba's sampler takes for `sample_count = n`: stratified rounds up to a
/// square, multijitter to ⌈n / ⌊√n⌋⌉·⌊√n⌋, ldsampler to the square of a power of two (≥ 4),
/// orthogonal to the square of a prime; independent takes n.
pub(super) fn mitsuba_sample_count(ty: SamplerType, n: u32) -> u32 {
    match ty {
        SamplerType::Independent => n,
        SamplerType::Stratified => {
            let mut r = 1u32;
            while r * r < n {
                r += 1;
            }
            r * r
        }
        SamplerType::Multijitter => {
            let ry = ((n as f32).sqrt() as u32).max(1);
            n.div_ceil(ry) * ry
        }
        SamplerType::LdSampler => {
            let mut r = 2u32;
            while r * r < n {
                r = (r + 1).next_power_of_two();
            }
            r * r
        }
        SamplerType::Orthogonal => {
            let is_prime = |x: u32| {
                x >= 2
                    && (2..)
                        .take_while(|d| d * d <= x)
                        .all(|d| !x.is_multiple_of(d))
            };
            let mut r = 2u32;
            while r * r < n || !is_prime(r) {
                r += 1;
            }
            r * r
        }
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
