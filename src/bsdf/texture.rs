//! Spatially varying parameters: a constant, a bitmap or a checkerboard looked up by uv, as
//! Mitsuba 3.9's `srgb`/`bitmap`/`checkerboard` textures evaluate them in its rgb variants.

use super::plugin::BsdfProperties;
use crate::Result;
use crate::geometry::{Mesh, MeshAttribute, SurfaceInteraction};
use crate::io::RgbImage;
use crate::math::color::luminance;
use crate::math::simd::f16::{F16, V2x, V3x};
use crate::math::simd::real::{Cond, Real, V2, V3};
use crate::math::transform::is_finite;
use crate::math::{Mat4, Spectrum, Vec2, Vec3};
use crate::plugin::Properties;
use std::sync::Arc;

/// A reflectance-like parameter (linear RGB).
#[derive(Clone, Debug)]
pub enum Texture {
    /// A uniform value (`<rgb>`, `<float>`, `<spectrum value>`).
    Constant(Spectrum),
    /// A bitmap with Mitsuba's defaults: bilinear filtering, repeat wrap, identity `to_uv`
    /// (row 0 of the image at v = 0).
    Bitmap(Arc<RgbImage>),
    /// A bitmap with explicit filter, wrap mode and `to_uv` transform.
    Mapped(Arc<BitmapTexture>),
    /// Mitsuba `checkerboard`.
    Checkerboard(Arc<Checkerboard>),
    /// Mitsuba `mesh_attribute`: an attribute of the mesh that was hit (see
    /// [`MeshAttributeTexture`]); evaluated only through [`Texture::eval_at`].
    MeshAttribute(Arc<MeshAttributeTexture>),
}

/// Mitsuba's `mesh_attribute`: the attribute `name` (`vertex_color`, `face_weight`, ...) of
/// the mesh that was hit, interpolated at the hit, times `scale`. The scene loader binds it
/// to one mesh's attribute ([`MeshAttributeTexture::bind`]); only the BSDFs that look their
/// textures up through the hit ([`Texture::eval_at`]: `diffuse`'s reflectance) accept it.
#[derive(Clone, Debug)]
pub struct MeshAttributeTexture {
    /// The attribute's name, starting with `vertex_` or `face_`.
    pub name: String,
    /// Factor applied to the attribute's value.
    pub scale: f32,
    /// The attribute of the mesh this texture is bound to, with that mesh's triangles (for a
    /// per-vertex attribute; empty for a per-face one).
    pub bound: Option<(MeshAttribute, Arc<Vec<[u32; 3]>>)>,
}

impl MeshAttributeTexture {
    /// Mitsuba's `mesh_attribute`: `name` (required, `vertex_…` or `face_…`) and `scale` (1).
    pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Texture> {
        let name = p.string_req("name")?;
        if !name.starts_with("vertex_") && !name.starts_with("face_") {
            return Err(p.err_at(
                "name",
                &format!(
                    "mesh_attribute: invalid attribute name \"{name}\" (it must start with \"vertex_\" or \"face_\")"
                ),
            ));
        }
        let scale = p.float("scale", 1.0)?;
        Ok(Texture::MeshAttribute(Arc::new(MeshAttributeTexture {
            name,
            scale,
            bound: None,
        })))
    }

    /// This texture bound to `mesh`'s attribute of its name; an error message naming the
    /// attributes the mesh has if it has none of that name.
    pub fn bind(&self, mesh: &Mesh) -> std::result::Result<MeshAttributeTexture, String> {
        let Some(a) = mesh.attributes.iter().find(|a| a.name == self.name) else {
            let names: Vec<&str> = mesh.attributes.iter().map(|a| a.name.as_str()).collect();
            return Err(format!(
                "mesh_attribute: the mesh \"{}\" has no attribute \"{}\" (it has {})",
                mesh.name,
                self.name,
                if names.is_empty() {
                    "none".to_string()
                } else {
                    names.join(", ")
                }
            ));
        };
        // A per-face attribute is looked up by triangle alone: no copy of the triangles.
        let tris = if a.per_vertex() {
            mesh.indices.clone()
        } else {
            Vec::new()
        };
        Ok(MeshAttributeTexture {
            bound: Some((a.clone(), Arc::new(tris))),
            ..self.clone()
        })
    }

    /// The scalar value at the hit `si` (Mitsuba's `eval_1`): a one-value attribute's value,
    /// 0 for any other (and while unbound).
    pub fn eval_1_at(&self, si: &SurfaceInteraction) -> f32 {
        match &self.bound {
            Some((a, _)) if a.dim == 1 => self.eval_at(si).x,
            _ => 0.0,
        }
    }

    /// The value at the hit `si` (0 while unbound).
    pub fn eval_at(&self, si: &SurfaceInteraction) -> Spectrum {
        match &self.bound {
            Some((a, tris)) => {
                let tri = tris.get(si.prim as usize).copied().unwrap_or_default();
                a.eval(si.prim, tri, si.bary) * self.scale
            }
            None => Spectrum::ZERO,
        }
    }
}

/// Texel filtering of a bitmap (`filter_type`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TexFilter {
    /// Interpolate the four nearest texel centres.
    Bilinear,
    /// The texel containing the lookup point.
    Nearest,
}

/// How texel indices outside the image wrap (`wrap_mode`, Dr.Jit's texture semantics).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    /// Tile the image.
    Repeat,
    /// Tile the image, every other tile mirrored.
    Mirror,
    /// Use the edge texel.
    Clamp,
}

/// Mitsuba's `to_uv` as the 2D affine map it keeps of the XML's 4×4 transform
/// (`Transform4f::extract`): uv' = (a·u + b·v + c, d·u + e·v + f).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform(pub [f32; 6]);

impl UvTransform {
    /// The identity map.
    pub const IDENTITY: UvTransform = UvTransform([1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);

    /// The `to_uv` property (a `<transform>`, identity by default), or in a Mitsuba 0.6 file the
    /// `uoffset`, `voffset`, `uscale`, `vscale` floats it replaces (to_uv = scale · translate,
    /// as Mitsuba 3's upgrade pass writes it).
    pub fn from_props(p: &dyn Properties) -> Result<UvTransform> {
        let mut m = p.transform_opt("to_uv")?.unwrap_or(Mat4::IDENTITY);
        if p.mitsuba_0_6() {
            let names = ["uoffset", "voffset", "uscale", "vscale"];
            if names.iter().any(|n| p.has(n)) {
                let o = Vec3::new(p.float("uoffset", 0.0)?, p.float("voffset", 0.0)?, 0.0);
                let s = Vec3::new(p.float("uscale", 1.0)?, p.float("vscale", 1.0)?, 1.0);
                m = Mat4::from_scale(s) * Mat4::from_translation(o);
            }
        }
        if !is_finite(&m) {
            return Err(p.err("to_uv contains NaN or infinite values"));
        }
        Ok(UvTransform::from_mat4(&m))
    }

    /// The upper-left 2×2 block and the first two entries of the last column of a 4×4
    /// transform (what Mitsuba's `props.get<ScalarAffineTransform3f>` does with it).
    pub fn from_mat4(m: &Mat4) -> UvTransform {
        // glam is column-major: m.col(j)[i] is row i, column j.
        UvTransform([
            m.x_axis.x, m.y_axis.x, m.w_axis.x, m.x_axis.y, m.y_axis.y, m.w_axis.y,
        ])
    }

    /// Applies the map to `uv`.
    #[inline]
    pub fn apply(&self, uv: Vec2) -> Vec2 {
        self.apply_t(uv.into()).into()
    }

    /// [`Self::apply`] for one lane or sixteen.
    #[inline(always)]
    pub fn apply_t<T: Real>(&self, uv: V2<T>) -> V2<T> {
        let m = &self.0;
        V2::new(
            uv.x * m[0] + uv.y * m[1] + m[2],
            uv.x * m[3] + uv.y * m[4] + m[5],
        )
    }
}

/// Mitsuba `bitmap` with its sampling options.
#[derive(Clone, Debug)]
pub struct BitmapTexture {
    /// Linear RGB texels (sRGB already decoded unless `raw`).
    pub image: RgbImage,
    /// Texel filtering.
    pub filter: TexFilter,
    /// Wrap mode of texel indices.
    pub wrap: Wrap,
    /// Applied to the surface uv before the lookup.
    pub to_uv: UvTransform,
    /// Mean Rec.709 luminance of the texels (Mitsuba's `BitmapTexture::mean` in rgb variants).
    mean: f32,
}

impl BitmapTexture {
    /// Mitsuba's `bitmap`: `filename` (PNG, JPEG, EXR, .hdr, .pfm; sRGB decoded unless `raw`),
    /// `filter_type` (bilinear), `wrap_mode` (repeat), `format` (storage precision only: the
    /// looked-up values are the same) and `to_uv`. The default sampling keeps the plain
    /// [`Texture::Bitmap`]; the image is read after every property is checked.
    pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Texture> {
        let to_uv = UvTransform::from_props(p)?;
        let file = p.string_req("filename")?;
        let filter = match p.string("filter_type", "bilinear")?.as_str() {
            "bilinear" => TexFilter::Bilinear,
            "nearest" => TexFilter::Nearest,
            f => {
                return Err(p.err(&format!(
                    "invalid filter type \"{f}\", must be one of: \"nearest\", or \"bilinear\""
                )));
            }
        };
        let wrap = match p.string("wrap_mode", "repeat")?.as_str() {
            "repeat" => Wrap::Repeat,
            "mirror" => Wrap::Mirror,
            "clamp" => Wrap::Clamp,
            w => {
                return Err(p.err(&format!(
                    "invalid wrap mode \"{w}\", must be one of: \"repeat\", \"mirror\", or \"clamp\""
                )));
            }
        };
        let raw = p.bool("raw", false)?;
        let format = p.string("format", "auto")?;
        if !["auto", "variant", "float16", "fp16", "uint8"].contains(&format.as_str()) {
            return Err(p.err(&format!(
                "invalid format \"{format}\", must be one of: \"auto\", \"variant\", \"float16\", or \"uint8\""
            )));
        }
        p.finish()?;
        let path = p.resolve(&file);
        let img = crate::io::read_image_as(&path, !raw).map_err(|e| p.err(&e.to_string()))?;
        if img.width == 0 || img.height == 0 {
            return Err(p.err(&format!("{}: the image is empty", path.display())));
        }
        img.check_finite(&path).map_err(|m| p.err(&m))?;
        Ok(
            if filter == TexFilter::Bilinear
                && wrap == Wrap::Repeat
                && to_uv == UvTransform::IDENTITY
            {
                Texture::Bitmap(Arc::new(img))
            } else {
                Texture::Mapped(Arc::new(BitmapTexture::new(img, filter, wrap, to_uv)))
            },
        )
    }

    /// A bitmap texture; `image` must hold at least one texel.
    pub fn new(image: RgbImage, filter: TexFilter, wrap: Wrap, to_uv: UvTransform) -> Self {
        let mean = luminance_mean(&image);
        BitmapTexture {
            image,
            filter,
            wrap,
            to_uv,
            mean,
        }
    }

    /// The filtered value at (untransformed) `uv`.
    pub fn eval(&self, uv: Vec2) -> Spectrum {
        self.eval_t(uv.into()).into()
    }

    /// [`Self::eval`] for one lane or sixteen (texels gathered lane by lane, the filter in SoA).
    #[inline]
    pub fn eval_t<T: Real>(&self, uv: V2<T>) -> V3<T> {
        let uv = self.to_uv.apply_t(uv);
        match self.filter {
            TexFilter::Bilinear => bilinear(&self.image, uv, self.wrap),
            TexFilter::Nearest => nearest(&self.image, uv, self.wrap),
        }
    }
}

/// Mitsuba `checkerboard`: `color0` where both fractional parts of `to_uv(uv)` are on the
/// same side of ½, `color1` elsewhere.
#[derive(Clone, Debug)]
pub struct Checkerboard {
    /// The colour of the squares at uv ∈ [0, ½)² (and [½, 1)²).
    pub color0: Texture,
    /// The other squares.
    pub color1: Texture,
    /// Applied to the surface uv before the test.
    pub to_uv: UvTransform,
}

impl Checkerboard {
    /// Mitsuba's `checkerboard`: `color0` (colour or texture, 0.4), `color1` (0.2), `to_uv`.
    pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Texture> {
        let to_uv = UvTransform::from_props(p)?;
        let color0 = p.texture("color0", Vec3::splat(0.4))?;
        let color1 = p.texture("color1", Vec3::splat(0.2))?;
        Ok(Texture::Checkerboard(Arc::new(Checkerboard {
            color0,
            color1,
            to_uv,
        })))
    }

    /// True where `color0` shows (per lane for [`F16`]).
    #[inline(always)]
    fn is_color0<T: Real>(&self, uv: V2<T>) -> T::Mask {
        let t = self.to_uv.apply_t(uv);
        let half = T::splat(0.5);
        let a = (t.x - t.x.floor()).gt(half);
        let b = (t.y - t.y.floor()).gt(half);
        a.and(b).or(a.not().and(b.not()))
    }
}

/// Mitsuba's `rawconstant`: a uniform `value` (float, or a 3-vector given as vector, point or
/// rgb) used as written, without the colour conversion a reflectance gets, e.g. a constant
/// normal map. The value is required.
pub fn raw_constant_from_props(p: &mut dyn BsdfProperties) -> Result<Texture> {
    use crate::plugin::Value;
    let v = match p.value("value") {
        None => return Err(p.err("rawconstant: missing required parameter \"value\"")),
        Some(Value::Float(f)) => Vec3::splat(*f),
        Some(Value::Integer(i)) => Vec3::splat(*i as f32),
        Some(Value::Vector(v) | Value::Point(v) | Value::Rgb(v)) => *v,
        Some(v) => return Err(p.wrong_type("value", v, "float, vector or rgb")),
    };
    if !v.is_finite() {
        return Err(p.err_at("value", "rawconstant: \"value\" must be finite"));
    }
    Ok(Texture::Constant(v))
}

impl Texture {
    /// A grey constant, e.g. a float roughness (Mitsuba's `uniform` texture).
    pub fn uniform(v: f32) -> Texture {
        Texture::Constant(Spectrum::splat(v))
    }

    /// The value at `uv`.
    pub fn eval(&self, uv: Vec2) -> Spectrum {
        match self {
            Texture::Constant(c) => *c,
            _ => self.eval_t(uv.into()).into(),
        }
    }

    /// The value at the hit `si`: a mesh attribute's at the hit's triangle and barycentrics,
    /// any other texture's at the hit's uv.
    pub fn eval_at(&self, si: &SurfaceInteraction) -> Spectrum {
        match self {
            Texture::MeshAttribute(m) => m.eval_at(si),
            _ => self.eval(si.uv),
        }
    }

    /// [`Self::eval`] for one lane or sixteen: the lanes' texels gathered, the filters and
    /// tests in SoA (a checkerboard evaluates both colours and selects). A mesh attribute has
    /// no value at a uv alone: 0 (the BSDFs that accept one use [`Self::eval_at`]).
    #[inline]
    pub fn eval_t<T: Real>(&self, uv: V2<T>) -> V3<T> {
        match self {
            Texture::MeshAttribute(_) => V3::new(T::splat(0.0), T::splat(0.0), T::splat(0.0)),
            Texture::Constant(c) => V3::new(T::splat(c.x), T::splat(c.y), T::splat(c.z)),
            Texture::Bitmap(img) => bilinear(img, uv, Wrap::Repeat),
            Texture::Mapped(b) => b.eval_t(uv),
            Texture::Checkerboard(c) => {
                V3::select(c.is_color0(uv), c.color0.eval_t(uv), c.color1.eval_t(uv))
            }
        }
    }

    /// [`Self::eval_t`] of 16 lanes.
    #[inline]
    pub fn eval_x(&self, uv: V2x) -> V3x {
        self.eval_t::<F16>(uv.into()).into()
    }

    /// The scalar value at `uv` (Mitsuba's `eval_1`, used for roughness): a grey constant's
    /// value (Mitsuba's `uniform`), another constant's channel mean (`srgb`), a bitmap's luminance.
    pub fn eval_1(&self, uv: Vec2) -> f32 {
        self.eval_1_t(uv.into())
    }

    /// [`Self::eval_1`] for one lane or sixteen.
    #[inline]
    pub fn eval_1_t<T: Real>(&self, uv: V2<T>) -> T {
        match self {
            Texture::Constant(c) if c.x == c.y && c.y == c.z => T::splat(c.x),
            Texture::Constant(c) => T::splat((c.x + c.y + c.z) / 3.0),
            Texture::Bitmap(_) | Texture::Mapped(_) => {
                let c = self.eval_t(uv);
                c.x * 0.212671 + c.y * 0.715160 + c.z * 0.072169
            }
            // Mitsuba 3.9's Checkerboard::eval_1 selects with the opposite test to its eval
            // (color0 where the halves differ); matched here so scalar uses agree with it.
            Texture::Checkerboard(c) => T::select(
                c.is_color0(uv),
                c.color1.eval_1_t(uv),
                c.color0.eval_1_t(uv),
            ),
            Texture::MeshAttribute(_) => T::splat(0.0),
        }
    }

    /// Gradient (∂/∂u, ∂/∂v) of [`Texture::eval_1`] at `uv` (Mitsuba's `eval_1_grad`, which
    /// only bitmaps implement): the derivative of the bilinear interpolation of the four texels'
    /// luminances, times the resolution, through `to_uv`'s transpose; 0 for nearest filtering
    /// and for non-bitmap textures.
    pub fn eval_1_grad(&self, uv: Vec2) -> Vec2 {
        match self {
            Texture::Bitmap(img) => bilinear_grad(img, uv, Wrap::Repeat, &UvTransform::IDENTITY),
            Texture::Mapped(b) if b.filter == TexFilter::Bilinear => {
                bilinear_grad(&b.image, b.to_uv.apply(uv), b.wrap, &b.to_uv)
            }
            _ => Vec2::ZERO,
        }
    }

    /// True for the textures Mitsuba can differentiate (`eval_1_grad`): bitmaps.
    pub fn has_gradient(&self) -> bool {
        matches!(self, Texture::Bitmap(_) | Texture::Mapped(_))
    }

    /// Mean over the texture (Mitsuba `Texture::mean` in rgb variants, used to steer lobe
    /// selection): a constant's channel mean, a bitmap's mean luminance.
    pub fn mean(&self) -> f32 {
        match self {
            Texture::Constant(c) => (c.x + c.y + c.z) / 3.0,
            Texture::Bitmap(img) => luminance_mean(img),
            Texture::Mapped(b) => b.mean,
            Texture::Checkerboard(c) => 0.5 * (c.color0.mean() + c.color1.mean()),
            Texture::MeshAttribute(m) => m.bound.as_ref().map_or(0.0, |(a, _)| {
                let n = (a.data.len() / a.dim.max(1)).max(1);
                let lum: f32 = match a.dim {
                    1 => a.data.iter().sum(),
                    3 => a
                        .data
                        .chunks_exact(3)
                        .map(|c| luminance(Spectrum::new(c[0], c[1], c[2])))
                        .sum(),
                    _ => 0.0,
                };
                lum / n as f32 * m.scale
            }),
        }
    }

    /// (width, height) in texels (Mitsuba's `Texture::resolution`): a bitmap's image size, 1 × 1
    /// for every other texture.
    pub fn resolution(&self) -> (u32, u32) {
        let img = match self {
            Texture::Bitmap(img) => img.as_ref(),
            Texture::Mapped(b) => &b.image,
            Texture::Constant(_) | Texture::Checkerboard(_) | Texture::MeshAttribute(_) => {
                return (1, 1);
            }
        };
        (img.width as u32, img.height as u32)
    }

    /// True if the value depends on uv.
    pub fn is_spatially_varying(&self) -> bool {
        !matches!(self, Texture::Constant(_))
    }
}

fn luminance_mean(img: &RgbImage) -> f32 {
    let s: f64 = img
        .data
        .chunks_exact(3)
        .map(|p| luminance(Spectrum::new(p[0], p[1], p[2])) as f64)
        .sum();
    (s / (img.data.len() / 3).max(1) as f64) as f32
}

/// Dr.Jit's wrap of a texel index `i` into `0..n`.
#[inline]
fn wrap_index(i: i64, n: i64, wrap: Wrap) -> usize {
    (match wrap {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::Clamp => i.clamp(0, n - 1),
        Wrap::Mirror => {
            let p = i.rem_euclid(2 * n);
            if p >= n { 2 * n - p - 1 } else { p }
        }
    }) as usize
}

/// Texel lookup at a float texel coordinate; NaN or huge uv (from a degenerate `to_uv`) clamp
/// to the i64 range instead of panicking.
#[inline]
fn to_index(v: f32) -> i64 {
    if v.is_nan() {
        0
    } else {
        v.clamp(-1e15, 1e15) as i64
    }
}

/// Bilinear filtering for one lane or sixteen: the four texels of each lane gathered, the
/// weights and the blend in SoA.
#[inline(always)]
fn bilinear<T: Real>(img: &RgbImage, uv: V2<T>, wrap: Wrap) -> V3<T> {
    let (w, h) = (img.width as i64, img.height as i64);
    let x = uv.x * w as f32 - 0.5;
    let y = uv.y * h as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let [p00, p10, p01, p11] = T::gather(x0, y0, |x0, y0| {
        let (x0, y0) = (to_index(x0), to_index(y0));
        let px = |xi: i64, yi: i64| {
            Spectrum::from(img.get(wrap_index(xi, w, wrap), wrap_index(yi, h, wrap)))
        };
        [
            px(x0, y0),
            px(x0 + 1, y0),
            px(x0, y0 + 1),
            px(x0 + 1, y0 + 1),
        ]
    });
    let one = T::splat(1.0);
    let top = p00.scale(one - fx).add(p10.scale(fx));
    let bottom = p01.scale(one - fx).add(p11.scale(fx));
    top.scale(one - fy).add(bottom.scale(fy))
}

/// Mitsuba's `BitmapTexture::eval_1_grad` at the transformed `uv`: partials of the bilinear
/// lookup in texel units, mixed by the transpose of `to_uv`'s 2×2 block, then scaled by the
/// resolution (in that order, as Mitsuba does; with a rotating `to_uv` on a non-square image
/// this differs from the exact derivative, and Mitsuba's value is what we match).
fn bilinear_grad(img: &RgbImage, uv: Vec2, wrap: Wrap, to_uv: &UvTransform) -> Vec2 {
    let (w, h) = (img.width as i64, img.height as i64);
    let x = uv.x * w as f32 - 0.5;
    let y = uv.y * h as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (w1x, w1y) = (x - x0, y - y0);
    let (w0x, w0y) = (1.0 - w1x, 1.0 - w1y);
    let (x0, y0) = (to_index(x0), to_index(y0));
    let f = |xi: i64, yi: i64| {
        let p = img.get(wrap_index(xi, w, wrap), wrap_index(yi, h, wrap));
        luminance(Spectrum::from(p))
    };
    let (f00, f10, f01, f11) = (f(x0, y0), f(x0 + 1, y0), f(x0, y0 + 1), f(x0 + 1, y0 + 1));
    let dfx = w0y * (f10 - f00) + w1y * (f11 - f01);
    let dfy = w0x * (f01 - f00) + w1x * (f11 - f10);
    let m = &to_uv.0;
    Vec2::new(
        w as f32 * (m[0] * dfx + m[3] * dfy),
        h as f32 * (m[1] * dfx + m[4] * dfy),
    )
}

/// Nearest-texel lookup for one lane or sixteen.
#[inline(always)]
fn nearest<T: Real>(img: &RgbImage, uv: V2<T>, wrap: Wrap) -> V3<T> {
    let (w, h) = (img.width as i64, img.height as i64);
    let [p] = T::gather(
        (uv.x * w as f32).floor(),
        (uv.y * h as f32).floor(),
        |x, y| {
            let (xi, yi) = (to_index(x), to_index(y));
            [Spectrum::from(
                img.get(wrap_index(xi, w, wrap), wrap_index(yi, h, wrap)),
            )]
        },
    );
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> RgbImage {
        let mut img = RgbImage::new(2, 2);
        img.set(0, 0, [1.0, 0.0, 0.0]);
        img.set(1, 0, [0.0, 1.0, 0.0]);
        img.set(0, 1, [0.0, 0.0, 1.0]);
        img.set(1, 1, [1.0, 1.0, 1.0]);
        img
    }

    #[test]
    fn bitmap_is_exact_at_pixel_centres_and_wraps() {
        let t = Texture::Bitmap(Arc::new(quad()));
        assert_eq!(t.eval(Vec2::new(0.25, 0.25)), Spectrum::new(1.0, 0.0, 0.0));
        assert_eq!(t.eval(Vec2::new(1.75, 0.75)), Spectrum::ONE);
        let mid = t.eval(Vec2::new(0.5, 0.25));
        assert!((mid - Spectrum::new(0.5, 0.5, 0.0)).length() < 1e-6);
    }

    #[test]
    fn wrap_modes_follow_drjit() {
        // n = 3: repeat 0 1 2 0 1 2, mirror 0 1 2 2 1 0, clamp 0 1 2 2 2 2.
        let r: Vec<usize> = (-3..6).map(|i| wrap_index(i, 3, Wrap::Repeat)).collect();
        assert_eq!(r, [0, 1, 2, 0, 1, 2, 0, 1, 2]);
        let m: Vec<usize> = (-3..6).map(|i| wrap_index(i, 3, Wrap::Mirror)).collect();
        assert_eq!(m, [2, 1, 0, 0, 1, 2, 2, 1, 0]);
        let c: Vec<usize> = (-3..6).map(|i| wrap_index(i, 3, Wrap::Clamp)).collect();
        assert_eq!(c, [0, 0, 0, 0, 1, 2, 2, 2, 2]);
    }

    #[test]
    fn nearest_clamp_and_to_uv() {
        let b = BitmapTexture::new(
            quad(),
            TexFilter::Nearest,
            Wrap::Clamp,
            UvTransform::IDENTITY,
        );
        assert_eq!(b.eval(Vec2::new(0.49, 0.1)), Spectrum::new(1.0, 0.0, 0.0));
        assert_eq!(b.eval(Vec2::new(0.51, 0.1)), Spectrum::new(0.0, 1.0, 0.0));
        assert_eq!(b.eval(Vec2::new(7.0, 7.0)), Spectrum::ONE);
        // Bilinear + clamp: beyond the edge the edge texel, not the wrapped one.
        let c = BitmapTexture::new(
            quad(),
            TexFilter::Bilinear,
            Wrap::Clamp,
            UvTransform::IDENTITY,
        );
        assert_eq!(c.eval(Vec2::new(0.0, 0.0)), Spectrum::new(1.0, 0.0, 0.0));
        // to_uv = scale 2 then offset 0.5 in u: uv (0.1, 0.1) → (0.7, 0.2).
        let t = UvTransform([2.0, 0.0, 0.5, 0.0, 2.0, 0.0]);
        let s = BitmapTexture::new(quad(), TexFilter::Nearest, Wrap::Repeat, t);
        assert_eq!(s.eval(Vec2::new(0.1, 0.1)), Spectrum::new(0.0, 1.0, 0.0));
        // Garbage uv does not panic.
        let _ = s.eval(Vec2::new(f32::NAN, f32::INFINITY));
        assert!((s.mean - 0.5).abs() < 1e-6);
    }

    #[test]
    fn gradient_is_the_derivative_of_the_bilinear_lookup() {
        let mut img = RgbImage::new(3, 2);
        for (i, v) in [0.1f32, 0.7, 0.3, 0.9, 0.2, 0.5].iter().enumerate() {
            img.set(i % 3, i / 3, [*v, *v * 0.5, *v * 0.25]);
        }
        // Axis-aligned to_uv: there Mitsuba's formula (resolution applied after the transpose)
        // is the exact derivative; with rotation on a non-square image it is not, and we
        // reproduce Mitsuba rather than the derivative.
        let t = UvTransform([1.5, 0.0, 0.1, 0.0, 0.8, 0.05]);
        let texs = [
            Texture::Bitmap(Arc::new(img.clone())),
            Texture::Mapped(Arc::new(BitmapTexture::new(
                img.clone(),
                TexFilter::Bilinear,
                Wrap::Mirror,
                t,
            ))),
        ];
        // Central differences of eval_1 away from texel-centre kinks.
        let h = 1e-3f32;
        for tex in &texs {
            for uv in [
                Vec2::new(0.27, 0.61),
                Vec2::new(0.71, 0.13),
                Vec2::new(-0.37, 1.3),
            ] {
                let g = tex.eval_1_grad(uv);
                let du = (tex.eval_1(uv + Vec2::new(h, 0.0)) - tex.eval_1(uv - Vec2::new(h, 0.0)))
                    / (2.0 * h);
                let dv = (tex.eval_1(uv + Vec2::new(0.0, h)) - tex.eval_1(uv - Vec2::new(0.0, h)))
                    / (2.0 * h);
                assert!(
                    (g.x - du).abs() < 2e-2 && (g.y - dv).abs() < 2e-2,
                    "{uv}: {g} vs ({du}, {dv})"
                );
            }
        }
        let nearest = Texture::Mapped(Arc::new(BitmapTexture::new(
            img,
            TexFilter::Nearest,
            Wrap::Repeat,
            UvTransform::IDENTITY,
        )));
        assert_eq!(nearest.eval_1_grad(Vec2::new(0.3, 0.3)), Vec2::ZERO);
        assert_eq!(
            Texture::Constant(Spectrum::ONE).eval_1_grad(Vec2::ZERO),
            Vec2::ZERO
        );
    }

    #[test]
    fn checkerboard_matches_mitsuba_layout() {
        let c = Texture::Checkerboard(Arc::new(Checkerboard {
            color0: Texture::Constant(Spectrum::splat(0.4)),
            color1: Texture::Constant(Spectrum::splat(0.2)),
            to_uv: UvTransform([4.0, 0.0, 0.0, 0.0, 4.0, 0.0]),
        }));
        assert_eq!(c.eval(Vec2::new(0.05, 0.05)), Spectrum::splat(0.4));
        assert_eq!(c.eval(Vec2::new(0.2, 0.05)), Spectrum::splat(0.2));
        assert_eq!(c.eval(Vec2::new(0.2, 0.2)), Spectrum::splat(0.4));
        assert_eq!(c.eval(Vec2::new(-0.05, 0.05)), Spectrum::splat(0.2));
        // Mitsuba's eval_1 uses the opposite test.
        assert_eq!(c.eval_1(Vec2::new(0.05, 0.05)), 0.2);
        assert!((c.mean() - 0.3).abs() < 1e-6);
        assert!(c.is_spatially_varying());
    }
}
