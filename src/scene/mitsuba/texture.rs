//! `<texture>`: Mitsuba's `bitmap` (PNG/JPEG/EXR/.hdr/.pfm, `filter_type`, `wrap_mode`, `raw`,
//! `to_uv`) and `checkerboard` (`color0`, `color1`, `to_uv`), nested in a BSDF parameter or
//! referenced by id. Mitsuba 0.6 files' `uoffset`/`voffset`/`uscale`/`vscale` become `to_uv`
//! as Mitsuba 3's upgrade pass does.

use super::properties::Props;
use super::{Builder, N};
use crate::Result;
use crate::bsdf::Texture;
use crate::bsdf::texture::{BitmapTexture, Checkerboard, TexFilter, UvTransform, Wrap};
use crate::math::Mat4;
use crate::math::Vec3;
use crate::math::transform::is_finite;
use crate::plugin::Properties;
use std::sync::Arc;

impl<'a, 'x> Builder<'a, 'x> {
    /// The texture an element describes (built once per element).
    pub(super) fn texture(&mut self, node: N<'a>) -> Result<Texture> {
        let x = self.x;
        let key = x.key(node);
        if let Some(t) = self.tex_memo.get(&key) {
            return Ok(t.clone());
        }
        if !self.busy.insert(key) {
            return Err(x.err(node, "cyclic <ref> between textures"));
        }
        let r = self.build_texture(node);
        self.busy.remove(&key);
        let t = r?;
        self.tex_memo.insert(key, t.clone());
        Ok(t)
    }

    fn build_texture(&mut self, node: N<'a>) -> Result<Texture> {
        let x = self.x;
        if node.tag_name().name() != "texture" {
            return Err(x.err(
                node,
                format!("expected a <texture>, found <{}>", node.tag_name().name()),
            ));
        }
        let p = Props::parse(x, node)?;
        let to_uv = to_uv(&p, x.is_legacy(node))?;
        let t = match p.ty.as_str() {
            "bitmap" => {
                let file = p.string_req("filename")?;
                let filter = match p.string("filter_type", "bilinear")?.as_str() {
                    "bilinear" => TexFilter::Bilinear,
                    "nearest" => TexFilter::Nearest,
                    f => {
                        return Err(p.err(format!(
                            "invalid filter type \"{f}\", must be one of: \"nearest\", or \"bilinear\""
                        )));
                    }
                };
                let wrap = match p.string("wrap_mode", "repeat")?.as_str() {
                    "repeat" => Wrap::Repeat,
                    "mirror" => Wrap::Mirror,
                    "clamp" => Wrap::Clamp,
                    w => {
                        return Err(p.err(format!(
                            "invalid wrap mode \"{w}\", must be one of: \"repeat\", \"mirror\", or \"clamp\""
                        )));
                    }
                };
                let raw = p.bool("raw", false)?;
                // Storage precision only (8-bit, half or float): the looked-up values are the same.
                let format = p.string("format", "auto")?;
                if !["auto", "variant", "float16", "fp16", "uint8"].contains(&format.as_str()) {
                    return Err(p.err(format!(
                        "invalid format \"{format}\", must be one of: \"auto\", \"variant\", \"float16\", or \"uint8\""
                    )));
                }
                p.finish()?;
                let path = x.resolve(&file);
                let img =
                    crate::io::read_image_as(&path, !raw).map_err(|e| p.err(e.to_string()))?;
                if img.width == 0 || img.height == 0 {
                    return Err(p.err(format!("{}: the image is empty", path.display())));
                }
                img.check_finite(&path).map_err(|m| p.err(m))?;
                if filter == TexFilter::Bilinear
                    && wrap == Wrap::Repeat
                    && to_uv == UvTransform::IDENTITY
                {
                    Texture::Bitmap(Arc::new(img))
                } else {
                    Texture::Mapped(Arc::new(BitmapTexture::new(img, filter, wrap, to_uv)))
                }
            }
            "checkerboard" => {
                let color0 = self.texture_param(&p, "color0", Vec3::splat(0.4))?;
                let color1 = self.texture_param(&p, "color1", Vec3::splat(0.2))?;
                p.finish()?;
                Texture::Checkerboard(Arc::new(Checkerboard {
                    color0,
                    color1,
                    to_uv,
                }))
            }
            _ => {
                return Err(p.err(
                    "unsupported texture type (btfpt implements \"bitmap\" and \"checkerboard\")",
                ));
            }
        };
        Ok(t)
    }
}

/// The `to_uv` property (a `<transform>`), or for Mitsuba 0.6 files the `uoffset`, `voffset`,
/// `uscale`, `vscale` floats it replaces (to_uv = scale · translate, as Mitsuba's upgrade).
fn to_uv(p: &Props, legacy: bool) -> Result<UvTransform> {
    let mut m = p.transform_opt("to_uv")?.unwrap_or(Mat4::IDENTITY);
    if legacy {
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
