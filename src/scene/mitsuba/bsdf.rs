//! `<bsdf>` (every BSDF plugin btfpt implements, measured BTFs via `btf_bsdf`) with Mitsuba's
//! named IOR table, and the texture-or-colour parameters BSDFs take (`texture.rs` builds the
//! `<texture>`s).

use super::properties::Props;
use super::{Builder, N};
use crate::Result;
use crate::bsdf::BlendBsdf;
use crate::bsdf::Bsdf;
use crate::bsdf::BumpMap;
use crate::bsdf::Conductor;
use crate::bsdf::Dielectric;
use crate::bsdf::Diffuse;
use crate::bsdf::Mask;
use crate::bsdf::MicrofacetType;
use crate::bsdf::NormalMap;
use crate::bsdf::Plastic;
use crate::bsdf::RoughConductor;
use crate::bsdf::RoughDielectric;
use crate::bsdf::RoughPlastic;
use crate::bsdf::Texture;
use crate::bsdf::ThinDielectric;
use crate::bsdf::TwoSided;
use crate::math::Spectrum;
use crate::math::Vec3;
use crate::math::cie1931::SpectrumUse;
use crate::model::BtfModel;

impl<'a, 'x> Builder<'a, 'x> {
    /// The BSDF of a shape that names none, as Mitsuba 3 creates it: diffuse with reflectance
    /// 0.5, or 0 on a shape carrying an area emitter (built once each).
    pub(super) fn default_bsdf(&mut self, emitter: bool) -> u32 {
        let slot = usize::from(emitter);
        if let Some(i) = self.default_bsdf[slot] {
            return i;
        }
        self.bsdfs.push(Bsdf::Diffuse(Diffuse {
            reflectance: Texture::Constant(Spectrum::splat(if emitter { 0.0 } else { 0.5 })),
        }));
        let i = (self.bsdfs.len() - 1) as u32;
        self.default_bsdf[slot] = Some(i);
        i
    }

    /// The index in `Scene::bsdfs` of a `<bsdf>` element (built once per element).
    pub(super) fn bsdf_index(&mut self, node: N<'a>) -> Result<u32> {
        if let Some(&i) = self.bsdf_memo.get(&self.x.key(node)) {
            return Ok(i);
        }
        let b = self.build_bsdf(node)?;
        self.bsdfs.push(b);
        let i = (self.bsdfs.len() - 1) as u32;
        self.bsdf_memo.insert(self.x.key(node), i);
        Ok(i)
    }

    pub(super) fn build_bsdf(&mut self, node: N<'a>) -> Result<Bsdf> {
        let x = self.x;
        if node.tag_name().name() != "bsdf" {
            return Err(x.err(
                node,
                format!("expected a <bsdf>, found <{}>", node.tag_name().name()),
            ));
        }
        if let Some(&i) = self.bsdf_memo.get(&self.x.key(node)) {
            return Ok(self.bsdfs[i as usize].clone());
        }
        if !self.busy.insert(x.key(node)) {
            return Err(x.err(node, "cyclic <ref> between bsdfs"));
        }
        let r = self.build_bsdf_inner(node);
        self.busy.remove(&x.key(node));
        r
    }

    pub(super) fn build_bsdf_inner(&mut self, node: N<'a>) -> Result<Bsdf> {
        let x = self.x;
        let p = Props::parse(x, node)?;
        let b = match p.ty.as_str() {
            "diffuse" => Bsdf::Diffuse(Diffuse {
                reflectance: self.texture_param(&p, "reflectance", Vec3::splat(0.5))?,
            }),
            "conductor" | "roughconductor" => {
                let (eta, k) = self.conductor_ior(&p)?;
                let specular_reflectance =
                    self.texture_param(&p, "specular_reflectance", Vec3::ONE)?;
                if p.ty == "conductor" {
                    Bsdf::Conductor(Conductor {
                        eta,
                        k,
                        specular_reflectance,
                    })
                } else {
                    let distribution = microfacet_type(&p)?;
                    let (alpha_u, alpha_v) = self.roughness(&p)?;
                    Bsdf::RoughConductor(RoughConductor {
                        distribution,
                        alpha_u,
                        alpha_v,
                        eta,
                        k,
                        specular_reflectance,
                        sample_visible: p.bool("sample_visible", true)?,
                    })
                }
            }
            "dielectric" | "thindielectric" => {
                let int_ior = ior(&p, "int_ior", "bk7")?;
                let ext_ior = ior(&p, "ext_ior", "air")?;
                if int_ior < 0.0 || ext_ior < 0.0 {
                    return Err(
                        p.err("the interior and exterior indices of refraction must be positive")
                    );
                }
                let specular_reflectance =
                    self.texture_param(&p, "specular_reflectance", Vec3::ONE)?;
                let specular_transmittance =
                    self.texture_param(&p, "specular_transmittance", Vec3::ONE)?;
                let eta = int_ior / ext_ior;
                if p.ty == "dielectric" {
                    Bsdf::Dielectric(Dielectric {
                        eta,
                        specular_reflectance,
                        specular_transmittance,
                    })
                } else {
                    Bsdf::ThinDielectric(ThinDielectric {
                        eta,
                        specular_reflectance,
                        specular_transmittance,
                    })
                }
            }
            "twosided" => {
                let kids = p.children_tagged("bsdf");
                let nodes: Vec<N<'a>> = kids.iter().map(|c| c.node).collect();
                let (front, back) = match nodes.as_slice() {
                    [one] => {
                        let b = self.build_bsdf(*one)?;
                        (b.clone(), b)
                    }
                    [a, b] => (self.build_bsdf(*a)?, self.build_bsdf(*b)?),
                    _ => return Err(p.err("twosided needs one or two nested bsdfs")),
                };
                if matches!(front, Bsdf::TwoSided(_)) || matches!(back, Bsdf::TwoSided(_)) {
                    return Err(p.err("a twosided bsdf cannot contain another twosided bsdf"));
                }
                Bsdf::TwoSided(TwoSided {
                    front: Box::new(front),
                    back: Box::new(back),
                })
            }
            "plastic" | "roughplastic" => {
                let int_ior = ior(&p, "int_ior", "polypropylene")?;
                let ext_ior = ior(&p, "ext_ior", "air")?;
                if !(int_ior > 0.0 && ext_ior > 0.0)
                    || (p.ty == "roughplastic" && int_ior == ext_ior)
                {
                    return Err(p.err(
                        "the interior and exterior indices of refraction must be positive and differ",
                    ));
                }
                let diffuse_reflectance =
                    self.texture_param(&p, "diffuse_reflectance", Vec3::splat(0.5))?;
                let specular_reflectance =
                    self.texture_param(&p, "specular_reflectance", Vec3::ONE)?;
                let nonlinear = p.bool("nonlinear", false)?;
                let eta = int_ior / ext_ior;
                if p.ty == "plastic" {
                    Bsdf::Plastic(Plastic::new(
                        eta,
                        diffuse_reflectance,
                        specular_reflectance,
                        nonlinear,
                    ))
                } else {
                    let distribution = microfacet_type(&p)?;
                    if p.has("alpha_u") || p.has("alpha_v") {
                        return Err(p.err(
                            "roughplastic does not support anisotropic roughness (as Mitsuba): use \"alpha\"",
                        ));
                    }
                    let alpha = p.float("alpha", 0.1)?;
                    check_alpha(&p, "alpha", alpha)?;
                    Bsdf::RoughPlastic(RoughPlastic::new(
                        distribution,
                        alpha,
                        eta,
                        diffuse_reflectance,
                        specular_reflectance,
                        nonlinear,
                        p.bool("sample_visible", true)?,
                    ))
                }
            }
            "roughdielectric" => {
                let int_ior = ior(&p, "int_ior", "bk7")?;
                let ext_ior = ior(&p, "ext_ior", "air")?;
                if !(int_ior > 0.0 && ext_ior > 0.0) || int_ior == ext_ior {
                    return Err(p.err(
                        "the interior and exterior indices of refraction must be positive and differ",
                    ));
                }
                let distribution = microfacet_type(&p)?;
                let (alpha_u, alpha_v) = self.roughness(&p)?;
                Bsdf::RoughDielectric(RoughDielectric {
                    distribution,
                    alpha_u,
                    alpha_v,
                    eta: int_ior / ext_ior,
                    specular_reflectance: self.texture_param(
                        &p,
                        "specular_reflectance",
                        Vec3::ONE,
                    )?,
                    specular_transmittance: self.texture_param(
                        &p,
                        "specular_transmittance",
                        Vec3::ONE,
                    )?,
                    sample_visible: p.bool("sample_visible", true)?,
                })
            }
            "blendbsdf" | "mixturebsdf" => {
                let kids = p.children_tagged("bsdf");
                let nodes: Vec<N<'a>> = kids.iter().map(|c| c.node).collect();
                if nodes.len() != 2 {
                    return Err(p.err(format!(
                        "needs exactly two nested bsdfs, found {} (a mixture of more than two \
                         components is not supported)",
                        nodes.len()
                    )));
                }
                let weight = if p.ty == "blendbsdf" {
                    if !p.has("weight") {
                        return Err(
                            p.err("the blend \"weight\" (0..1, a float or texture) is required")
                        );
                    }
                    let w = self.texture_param(&p, "weight", Vec3::splat(0.5))?;
                    if let Texture::Constant(c) = &w
                        && !(c.min_element() >= 0.0 && c.max_element() <= 1.0)
                    {
                        return Err(p.err(format!("\"weight\" must lie in [0, 1], got {c}")));
                    }
                    w
                } else {
                    let text = p.string_req("weights")?;
                    let ws = text
                        .split([',', ' '])
                        .filter(|t| !t.is_empty())
                        .map(|t| t.parse::<f32>().ok().filter(|v| v.is_finite() && *v >= 0.0))
                        .collect::<Option<Vec<f32>>>()
                        .ok_or_else(|| {
                            p.err(format!(
                                "\"weights\" must be non-negative numbers, got \"{text}\""
                            ))
                        })?;
                    if ws.len() != nodes.len() {
                        return Err(p.err(format!(
                            "{} weights for {} nested bsdfs",
                            ws.len(),
                            nodes.len()
                        )));
                    }
                    let sum = ws[0] + ws[1];
                    // Mitsuba 0.6 renormalises weights summing to more than 1; a sum below 1
                    // (an absorbing mixture) has no blendbsdf equivalent.
                    if !(sum >= 1.0 - 1e-3) {
                        return Err(p.err(format!(
                            "\"weights\" sum to {sum} < 1: only mixtures whose weights sum to 1 \
                             (or more, renormalised) are supported"
                        )));
                    }
                    Texture::Constant(Spectrum::splat(ws[1] / sum))
                };
                let a = self.build_bsdf(nodes[0])?;
                let b = self.build_bsdf(nodes[1])?;
                Bsdf::Blend(BlendBsdf {
                    weight,
                    bsdfs: Box::new([a, b]),
                })
            }
            "mask" => {
                let kids = p.children_tagged("bsdf");
                let node = match kids.as_slice() {
                    [one] => one.node,
                    [] => return Err(p.err("needs a nested bsdf")),
                    _ => return Err(p.err("cannot have more than one nested bsdf")),
                };
                let opacity = self.texture_param(&p, "opacity", Vec3::splat(0.5))?;
                if let Texture::Constant(c) = &opacity
                    && !(c.min_element() >= 0.0 && c.max_element() <= 1.0)
                {
                    return Err(p.err(format!("\"opacity\" must lie in [0, 1], got {c}")));
                }
                Bsdf::Mask(Mask {
                    opacity,
                    nested: Box::new(self.build_bsdf(node)?),
                })
            }
            "normalmap" => {
                let kids = p.children_tagged("bsdf");
                let node = match kids.as_slice() {
                    [one] => one.node,
                    [] => return Err(p.err("needs a nested bsdf")),
                    _ => return Err(p.err("cannot have more than one nested bsdf")),
                };
                if !p.has("normalmap") {
                    return Err(p.err("the \"normalmap\" texture is required"));
                }
                let normalmap = self.texture_param(&p, "normalmap", Vec3::new(0.5, 0.5, 1.0))?;
                Bsdf::NormalMap(NormalMap {
                    normalmap,
                    flip_invalid_normals: p.bool("flip_invalid_normals", true)?,
                    use_shadowing_function: p.bool("use_shadowing_function", true)?,
                    nested: Box::new(self.build_bsdf(node)?),
                })
            }
            "bumpmap" => {
                let kids = p.children_tagged("bsdf");
                let node = match kids.as_slice() {
                    [one] => one.node,
                    [] => return Err(p.err("exactly one nested bsdf must be specified")),
                    _ => return Err(p.err("only a single nested bsdf can be specified")),
                };
                // Mitsuba takes the texture child whatever its name.
                let texs = p.children_tagged("texture");
                let tnode = match texs.as_slice() {
                    [one] => one.node,
                    [] => return Err(p.err("exactly one nested height texture must be specified")),
                    _ => return Err(p.err("only a single nested texture can be specified")),
                };
                let height = self.texture(tnode)?;
                if !height.has_gradient() {
                    return Err(p.err(
                        "the height texture must be a bitmap (Mitsuba differentiates only bitmaps)",
                    ));
                }
                // NaN/Inf are refused by the property parser.
                let scale = p.float("scale", 1.0)?;
                Bsdf::BumpMap(BumpMap {
                    height,
                    scale,
                    flip_invalid_normals: p.bool("flip_invalid_normals", true)?,
                    use_shadowing_function: p.bool("use_shadowing_function", true)?,
                    nested: Box::new(self.build_bsdf(node)?),
                })
            }
            "btf" => {
                let file = p.string_req("filename")?;
                let uv_scale = p.float("uv_scale", 1.0)?;
                let model = p
                    .string_opt("model")?
                    .map(|m| BtfModel::parse(&m).map_err(|e| p.err(e.to_string())))
                    .transpose()?;
                p.finish()?;
                if uv_scale <= 0.0 {
                    return Err(p.err("\"uv_scale\" must be positive"));
                }
                let (bsdf, used) = crate::scene::btf_bsdf::build_btf(
                    x.file_of(node),
                    x.line(node),
                    &file,
                    &|f| x.resolve(f),
                    uv_scale,
                    self.btf_model.or(model),
                    self.synth_cache.as_deref(),
                )?;
                self.btf_uses.push(used);
                return Ok(bsdf);
            }
            _ => {
                return Err(p.err(
                    "unsupported bsdf type (btfpt implements diffuse, conductor, roughconductor, dielectric, \
                     thindielectric, roughdielectric, plastic, roughplastic, twosided, blendbsdf, \
                     mixturebsdf (two components), mask, normalmap, bumpmap, btf)",
                ));
            }
        };
        p.finish()?;
        Ok(b)
    }

    /// A reflectance-like parameter: constant (rgb/float/spectrum) or a nested/referenced
    /// `<texture>` (bitmap, checkerboard).
    pub(super) fn texture_param(
        &mut self,
        p: &Props<'a, 'x>,
        name: &str,
        default: Vec3,
    ) -> Result<Texture> {
        self.texture_param_as(p, name, default, SpectrumUse::Reflectance)
    }

    /// [`Builder::texture_param`] for a parameter used as `usage` (what a `<spectrum>` list
    /// converts to: Mitsuba's unbounded textures, eta/k/alpha, are not clipped at 1).
    pub(super) fn texture_param_as(
        &mut self,
        p: &Props<'a, 'x>,
        name: &str,
        default: Vec3,
        usage: SpectrumUse,
    ) -> Result<Texture> {
        if let Some(c) = p.child_named(name) {
            if c.tag() != "texture" {
                return Err(self.x.err(
                    c.at,
                    format!(
                        "\"{name}\" must be a <texture> or a colour, not a <{}>",
                        c.tag()
                    ),
                ));
            }
            return self.texture(c.node);
        }
        Ok(Texture::Constant(
            p.color_opt_as(name, usage)?.unwrap_or(default),
        ))
    }
}

impl<'a, 'x> Builder<'a, 'x> {
    /// `alpha` or `alpha_u`/`alpha_v` of roughconductor and roughdielectric: floats or textures
    /// (Mitsuba 3.9.1's `get_unbounded_texture`, read with `eval_1` at the hit). A constant
    /// must be finite and non-negative.
    fn roughness(&mut self, p: &Props<'a, 'x>) -> Result<(Texture, Texture)> {
        const U: SpectrumUse = SpectrumUse::Unbounded;
        let (alpha_u, alpha_v) = if p.has("alpha_u") || p.has("alpha_v") {
            if p.has("alpha") {
                return Err(p.err("specify either \"alpha\" or \"alpha_u\"/\"alpha_v\", not both"));
            }
            if !(p.has("alpha_u") && p.has("alpha_v")) {
                return Err(p.err("both \"alpha_u\" and \"alpha_v\" must be specified"));
            }
            (
                self.texture_param_as(p, "alpha_u", Vec3::splat(0.1), U)?,
                self.texture_param_as(p, "alpha_v", Vec3::splat(0.1), U)?,
            )
        } else {
            let a = self.texture_param_as(p, "alpha", Vec3::splat(0.1), U)?;
            (a.clone(), a)
        };
        for (name, t) in [("alpha_u", &alpha_u), ("alpha_v", &alpha_v)] {
            if let Texture::Constant(c) = t {
                for v in [c.x, c.y, c.z] {
                    check_alpha(p, name, v)?;
                }
            }
        }
        Ok((alpha_u, alpha_v))
    }

    /// Complex IOR of a conductor: `material="none"` (Mitsuba's default, a perfect mirror: eta
    /// 0, k 1) with optional explicit `eta`/`k`, colours or textures (Mitsuba's unbounded
    /// textures). Named metals need Mitsuba's spectral data: error.
    fn conductor_ior(&mut self, p: &Props<'a, 'x>) -> Result<(Texture, Texture)> {
        const U: SpectrumUse = SpectrumUse::Unbounded;
        let material = p.string("material", "none")?;
        if material != "none" {
            if p.has("eta") || p.has("k") {
                return Err(p.err("should specify either (eta, k) or material, not both"));
            }
            return Err(p.err(format!(
                "named conductor material \"{material}\" is not supported (its spectral IOR tables \
                 ship with Mitsuba, not btfpt): give <rgb name=\"eta\"> and <rgb name=\"k\"> instead"
            )));
        }
        Ok((
            self.texture_param_as(p, "eta", Vec3::ZERO, U)?,
            self.texture_param_as(p, "k", Vec3::ONE, U)?,
        ))
    }
}

/// The `distribution` of a microfacet BSDF: Mitsuba's default `beckmann` when none is given.
fn microfacet_type(p: &Props) -> Result<MicrofacetType> {
    match p.string_opt("distribution")? {
        None => Ok(MicrofacetType::Beckmann),
        Some(d) => MicrofacetType::from_name(&d).ok_or_else(|| {
            p.err(format!(
                "invalid distribution \"{d}\": must be \"beckmann\" or \"ggx\""
            ))
        }),
    }
}

/// A roughness must be finite and non-negative (0 is clamped to 1e-4, as Mitsuba).
fn check_alpha(p: &Props, name: &str, alpha: f32) -> Result<()> {
    if alpha.is_finite() && alpha >= 0.0 {
        Ok(())
    } else {
        Err(p.err(format!(
            "\"{name}\" must be a non-negative roughness, got {alpha}"
        )))
    }
}

/// Mitsuba's named IOR table (`ior.h`).
pub(super) const IOR_TABLE: &[(&str, f32)] = &[
    ("vacuum", 1.0),
    ("helium", 1.00004),
    ("hydrogen", 1.00013),
    ("air", 1.00028),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

/// An IOR given as a float or one of Mitsuba's named materials.
pub(super) fn ior(p: &Props, name: &str, default: &str) -> Result<f32> {
    let lookup = |s: &str| {
        let l = s.to_ascii_lowercase();
        IOR_TABLE
            .iter()
            .find(|(n, _)| *n == l)
            .map(|(_, v)| *v)
            .ok_or_else(|| p.err(format!("unknown IOR material \"{s}\" for \"{name}\"")))
    };
    match p.float_or_string(name)? {
        None => lookup(default),
        Some(Ok(v)) => Ok(v),
        Some(Err(s)) => lookup(&s),
    }
}
