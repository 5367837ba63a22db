//! What a scene says about its sensor — the [`Camera`] and its [`Projection`], its [`Film`]
//! and reconstruction filter, the [`Sampler`] — and the constructors that read each plugin's
//! properties (Mitsuba 3's `perspective`, `thinlens`, `orthographic`, `hdrfilm`, the
//! `<rfilter>`s and samplers). The renderer's ray generator is
//! [`crate::render::camera::ProjectiveCamera`].

// `!(x > 0.0)` deliberately also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::Result;
use crate::math::filter::Filter;
use crate::math::{Mat3, Mat4};
use crate::plugin::Properties;
pub use crate::plugin::horizontal_fov;

/// A camera (pinhole, thin lens or orthographic, see [`Projection`]) with its film and
/// reconstruction filter (Mitsuba semantics).
///
/// **Image orientation (what the renderer must do to match Mitsuba pixel for pixel).** Camera
/// space looks along +z with +y up, and — as in Mitsuba's `perspective.cpp`, whose sample-space
/// transform scales x by −½ — camera-space **+x appears on the LEFT of the image** (Mitsuba's
/// `lookat` puts +x = up × dir, i.e. to the viewer's left, so the image is not mirrored). For a
/// film position (fx, fy) in pixels of the full film (x right, y down, pixel (i, j) covering
/// [i, i+1) × [j, j+1)), with t = tan(fov_x / 2) and aspect = width / height:
///
/// d_cam = normalize(((1 − 2 fx / width) · t, (1 − 2 fy / height) · t / aspect, 1)),
/// ray origin = to_world · (0, 0, 0), direction = linear part of to_world · d_cam,
/// t_min = near_clip / d_cam.z, t_max = far_clip / d_cam.z. The renderer's
/// [`crate::render::camera::ProjectiveCamera`] does exactly this (and the thin lens and
/// orthographic variants of [`Projection`]). With a crop window, pixel (i, j) of the output is pixel (i + x, j + y) of the full film.
#[derive(Clone, Debug)]
pub struct Camera {
    /// Camera → world (no scale, except for the orthographic camera, whose view extent it
    /// scales); the camera looks along +z with +y up and +x to the image's left.
    pub to_world: Mat4,
    /// Pinhole, thin lens or orthographic.
    pub projection: Projection,
    /// Full horizontal field of view in degrees (any `fov_axis` resolved by the loader; unused
    /// by the orthographic camera).
    pub fov_x_deg: f32,
    pub near_clip: f32,
    pub far_clip: f32,
    /// Film resolution in pixels.
    pub width: u32,
    pub height: u32,
    /// Optional crop window (x, y, w, h) in pixels of the full film.
    pub crop: Option<[u32; 4]>,
    /// The film's reconstruction filter (Mitsuba's default: gaussian, σ = 0.5 pixel).
    pub filter: Filter,
}

impl Camera {
    /// Size (width, height) in pixels of the image actually rendered (the crop window if any).
    pub fn image_size(&self) -> (u32, u32) {
        match self.crop {
            Some([_, _, w, h]) => (w, h),
            None => (self.width, self.height),
        }
    }

    /// Mitsuba's `perspective` on `film`: `fov` + `fov_axis` or `focal_length` (see
    /// [`horizontal_fov`]), `near_clip` (0.01), `far_clip` (10⁴), `to_world` (no scale).
    pub fn perspective_from_props(p: &dyn Properties, film: Film) -> Result<Camera> {
        let (fov_x, near_clip, far_clip) = projective_props(p, &film, true)?;
        // A pinhole camera is in focus everywhere: the focus distance changes nothing.
        let _ = p.float("focus_distance", far_clip)?;
        let to_world = rigid_to_world(p)?;
        Ok(Camera::on_film(
            to_world,
            Projection::Perspective,
            fov_x,
            (near_clip, far_clip),
            film,
        ))
    }

    /// Mitsuba's `thinlens` on `film`: what `perspective` takes, plus `aperture_radius` (scene
    /// units, required, ≥ 0) and `focus_distance` (scene units along the view axis, > 0;
    /// default `far_clip` as in Mitsuba).
    pub fn thinlens_from_props(p: &dyn Properties, film: Film) -> Result<Camera> {
        let (fov_x, near_clip, far_clip) = projective_props(p, &film, true)?;
        let Some(aperture_radius) = p.float_opt("aperture_radius")? else {
            return Err(p.err("the \"aperture_radius\" parameter is required"));
        };
        if !(aperture_radius >= 0.0 && aperture_radius.is_finite()) {
            return Err(p.err_at(
                "aperture_radius",
                &format!("the aperture radius must be finite and ≥ 0, got {aperture_radius}"),
            ));
        }
        let focus_distance = p.float("focus_distance", far_clip)?;
        if !(focus_distance > 0.0 && focus_distance.is_finite()) {
            return Err(p.err_at(
                "focus_distance",
                &format!("the focus distance must be finite and > 0, got {focus_distance}"),
            ));
        }
        let to_world = rigid_to_world(p)?;
        let projection = Projection::ThinLens {
            aperture_radius,
            focus_distance,
        };
        Ok(Camera::on_film(
            to_world,
            projection,
            fov_x,
            (near_clip, far_clip),
            film,
        ))
    }

    /// Mitsuba's `orthographic` on `film`: `near_clip` (0.01), `far_clip` (10⁴), `to_world`,
    /// whose scale sets the view extent (camera space [−1, 1] × [−1/aspect, 1/aspect]).
    pub fn orthographic_from_props(p: &dyn Properties, film: Film) -> Result<Camera> {
        let (_, near_clip, far_clip) = projective_props(p, &film, false)?;
        let _ = p.float("focus_distance", far_clip)?;
        let to_world = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
        let det = Mat3::from_mat4(to_world).determinant();
        if !(to_world.is_finite() && det.abs() > 1e-20) {
            return Err(p.err("the camera-to-world transformation is singular or not finite"));
        }
        Ok(Camera::on_film(
            to_world,
            Projection::Orthographic,
            90.0,
            (near_clip, far_clip),
            film,
        ))
    }

    fn on_film(
        to_world: Mat4,
        projection: Projection,
        fov_x_deg: f32,
        (near_clip, far_clip): (f32, f32),
        film: Film,
    ) -> Camera {
        Camera {
            to_world,
            projection,
            fov_x_deg,
            near_clip,
            far_clip,
            width: film.width,
            height: film.height,
            crop: film.crop,
            filter: film.filter,
        }
    }
}

/// How a [`Camera`] turns film positions into rays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Mitsuba's `perspective`: every ray leaves the camera origin.
    Perspective,
    /// Mitsuba's `thinlens`: rays leave a disk of `aperture_radius` (scene units) around the
    /// camera origin in its xy plane, sampled with the concentric map from the sampler's 2-D
    /// dimension after the film position, and meet at camera-space z = `focus_distance`.
    ThinLens {
        aperture_radius: f32,
        focus_distance: f32,
    },
    /// Mitsuba's `orthographic`: parallel rays along camera +z from the near plane over
    /// [−1, 1] × [−1/aspect, 1/aspect] in camera space (before `to_world`'s scale).
    Orthographic,
}

/// The properties every projective camera reads: the horizontal field of view (perspective
/// ones only), `near_clip` and `far_clip`, checked as Mitsuba checks them.
fn projective_props(p: &dyn Properties, film: &Film, fov: bool) -> Result<(f32, f32, f32)> {
    let aspect = film.width as f64 / film.height as f64;
    let fov_x = if fov {
        horizontal_fov(p, aspect)?
    } else {
        90.0
    };
    let near_clip = p.float("near_clip", 1e-2)?;
    let far_clip = p.float("far_clip", 1e4)?;
    if !(near_clip > 0.0) {
        return Err(p.err("the \"near_clip\" parameter must be greater than zero"));
    }
    if !(near_clip < far_clip) {
        return Err(p.err("the \"near_clip\" parameter must be smaller than \"far_clip\""));
    }
    Ok((fov_x, near_clip, far_clip))
}

/// `to_world` of a perspective camera, which Mitsuba requires to have no scale.
fn rigid_to_world(p: &dyn Properties) -> Result<Mat4> {
    let to_world = p.transform_opt("to_world")?.unwrap_or(Mat4::IDENTITY);
    let l = Mat3::from_mat4(to_world);
    let g = l.transpose() * l;
    if (g - Mat3::IDENTITY)
        .to_cols_array()
        .iter()
        .any(|v| !(v.abs() <= 1e-3))
    {
        return Err(p.err("scale factors in the camera-to-world transformation are not allowed"));
    }
    Ok(to_world)
}

/// What a sensor's film contributes to its [`Camera`]: the size, the crop window and the
/// reconstruction filter.
#[derive(Clone, Debug)]
pub struct Film {
    /// Film resolution in pixels.
    pub width: u32,
    pub height: u32,
    /// Crop window (x, y, w, h) in pixels of the full film, None for the whole film.
    pub crop: Option<[u32; 4]>,
    /// The reconstruction filter.
    pub filter: Filter,
}

/// Mitsuba's film size when the scene names none.
const DEFAULT_FILM_SIZE: (i64, i64) = (768, 576);

impl Default for Film {
    /// Mitsuba's default `hdrfilm`: 768 × 576, no crop, gaussian filter.
    fn default() -> Self {
        Film {
            width: DEFAULT_FILM_SIZE.0 as u32,
            height: DEFAULT_FILM_SIZE.1 as u32,
            crop: None,
            filter: Filter::default(),
        }
    }
}

impl Film {
    /// Mitsuba's `hdrfilm` with its reconstruction `filter`: `width`, `height` (768 × 576),
    /// `crop_offset_x/y`, `crop_width/height`; output-format options that do not change RGB
    /// pixel values are accepted, `sample_border` is refused.
    pub fn hdrfilm_from_props(p: &dyn Properties, filter: Filter) -> Result<Film> {
        let width = p.int("width", DEFAULT_FILM_SIZE.0)?;
        let height = p.int("height", DEFAULT_FILM_SIZE.1)?;
        if width <= 0 || height <= 0 || width > 1 << 20 || height > 1 << 20 {
            return Err(p.err(&format!("invalid film size {width} x {height}")));
        }
        let cox = p.int("crop_offset_x", 0)?;
        let coy = p.int("crop_offset_y", 0)?;
        let cw = p.int("crop_width", width)?;
        let ch = p.int("crop_height", height)?;
        if cox < 0 || coy < 0 || cw <= 0 || ch <= 0 || cox + cw > width || coy + ch > height {
            return Err(p.err(&format!(
                "invalid crop window (offset {cox}, {coy}, size {cw} x {ch}) for a {width} x {height} film"
            )));
        }
        let crop = if (cox, coy, cw, ch) == (0, 0, width, height) {
            None
        } else {
            Some([cox as u32, coy as u32, cw as u32, ch as u32])
        };
        for (name, default, ok) in [
            ("file_format", "openexr", &["openexr", "exr"][..]),
            ("pixel_format", "rgb", &["rgb", "rgba"][..]),
            ("component_format", "float32", &["float16", "float32"][..]),
        ] {
            let v = p.string(name, default)?.to_ascii_lowercase();
            if !ok.contains(&v.as_str()) {
                return Err(p.err(&format!(
                    "{name} \"{v}\" is not supported (use one of {ok:?})"
                )));
            }
        }
        // The Mitsuba logo stamped into the output file: no effect on the radiance.
        let _ = p.bool("banner", true)?;
        if p.bool("sample_border", false)? {
            return Err(p.err(
                "sample_border=true is not supported (samples are taken inside the film only)",
            ));
        }
        Ok(Film {
            width: width as u32,
            height: height as u32,
            crop,
            filter,
        })
    }
}

/// The constructors of Mitsuba's reconstruction filters (`<rfilter>`), reading each one's
/// parameters; the filters themselves are [`Filter`]'s.
pub mod rfilter {
    use super::Filter;
    use crate::Result;
    use crate::plugin::Properties;

    /// A filter's own error (a bad radius, ...) located at its element.
    fn at(p: &dyn Properties, f: Result<Filter>) -> Result<Filter> {
        f.map_err(|e| p.err(&e.to_string()))
    }

    /// `box`: `radius` (0.5 pixel).
    pub fn boxed(p: &dyn Properties) -> Result<Filter> {
        at(p, Filter::boxed(p.float("radius", 0.5)?))
    }

    /// `tent`: `radius` (1 pixel).
    pub fn tent(p: &dyn Properties) -> Result<Filter> {
        at(p, Filter::tent(p.float("radius", 1.0)?))
    }

    /// `gaussian`: `stddev` (0.5 pixel).
    pub fn gaussian(p: &dyn Properties) -> Result<Filter> {
        at(p, Filter::gaussian(p.float("stddev", 0.5)?))
    }

    /// `mitchell`: `B`, `C` (⅓ each), `radius` (2 pixels).
    pub fn mitchell(p: &dyn Properties) -> Result<Filter> {
        let (b, c) = (p.float("B", 1.0 / 3.0)?, p.float("C", 1.0 / 3.0)?);
        at(p, Filter::mitchell(b, c, p.float("radius", 2.0)?))
    }

    /// `catmullrom`: Mitchell–Netravali with B = 0, C = ½; `radius` (2 pixels).
    pub fn catmullrom(p: &dyn Properties) -> Result<Filter> {
        at(p, Filter::mitchell(0.0, 0.5, p.float("radius", 2.0)?))
    }

    /// `lanczos`: `lobes` (3).
    pub fn lanczos(p: &dyn Properties) -> Result<Filter> {
        at(p, Filter::lanczos(p.int("lobes", 3)?))
    }
}

/// The Mitsuba sampler a scene names. All of them draw from btfpt's independent sampler: the
/// expected image is the same, only the noise differs; the sample count is the one Mitsuba's
/// sampler would take (rounded as it rounds).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SamplerType {
    #[default]
    Independent,
    Stratified,
    Multijitter,
    LdSampler,
    Orthogonal,
}

impl SamplerType {
    /// Mitsuba's plugin name.
    pub fn name(self) -> &'static str {
        match self {
            SamplerType::Independent => "independent",
            SamplerType::Stratified => "stratified",
            SamplerType::Multijitter => "multijitter",
            SamplerType::LdSampler => "ldsampler",
            SamplerType::Orthogonal => "orthogonal",
        }
    }

    /// The sample count Mitsuba's sampler takes for `sample_count = n`: stratified rounds up
    /// to a square, multijitter to ⌈n / ⌊√n⌋⌉·⌊√n⌋, ldsampler to the square of a power of two
    /// (≥ 4), orthogonal to the square of a prime; independent takes n.
    pub fn sample_count(self, n: u32) -> u32 {
        match self {
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
}

/// A sensor's sampler: which one, and the samples per pixel it takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Sampler {
    pub kind: SamplerType,
    /// Samples per pixel, as Mitsuba's sampler rounds `sample_count`.
    pub spp: u32,
}

impl Default for Sampler {
    /// Mitsuba's default: `independent` with 4 samples per pixel.
    fn default() -> Self {
        Sampler {
            kind: SamplerType::Independent,
            spp: 4,
        }
    }
}

impl Sampler {
    /// A sampler plugin of `kind`: `sample_count` (4); `seed`, and the stratified samplers'
    /// `jitter` and `strength`, are read and change only the noise pattern, never the expected
    /// image (btfpt draws independently).
    pub fn from_props(p: &dyn Properties, kind: SamplerType) -> Result<Sampler> {
        let n = p.int("sample_count", 4)?;
        let _ = p.int("seed", 0)?;
        if matches!(
            kind,
            SamplerType::Stratified | SamplerType::Multijitter | SamplerType::Orthogonal
        ) {
            let _ = p.bool("jitter", true)?;
        }
        if kind == SamplerType::Orthogonal {
            let _ = p.int("strength", 2)?;
        }
        if n <= 0 || n > 1 << 24 {
            return Err(p.err(&format!("invalid sample_count {n}")));
        }
        Ok(Sampler {
            kind,
            spp: kind.sample_count(n as u32),
        })
    }
}
