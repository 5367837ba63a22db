//! The image channels beside R, G, B that Mitsuba's wrapping integrators write: `aov` (values
//! of the surface the camera ray hits first, and each nested integrator's RGBA) and `moment`
//! (each nested integrator's CIE XYZ and its square). Channel names are Mitsuba 3.9.1's.

use crate::plugin::Properties;
use crate::scene::IntegratorSettings;

/// One scalar a camera sample contributes to an extra channel: the film accumulates it with
/// the sample's filter weight, as it does the radiance.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SampleValue {
    /// Ray distance to the first hit (`depth`; world units, 0 where the ray escapes).
    Depth,
    /// World position of the first hit, axis 0..3 (`position`).
    Position(usize),
    /// Texture coordinates, 0 = u, 1 = v (`uv`).
    Uv(usize),
    /// Unit geometric normal, world (`geo_normal`).
    GeoNormal(usize),
    /// Unit interpolated shading normal, world (`sh_normal`).
    ShNormal(usize),
    /// ∂p/∂u and ∂p/∂v, world (`dp_du`, `dp_dv`).
    DpDu(usize),
    DpDv(usize),
    /// The BSDF's diffuse reflectance at the hit, channel 0..3 (`albedo`; see
    /// [`crate::bsdf::Bsdf::diffuse_reflectance`]).
    Albedo(usize),
    /// ∂uv/∂x and ∂uv/∂y, component 0 = u, 1 = v (`duv_dx`, `duv_dy`): the uv change across the
    /// camera's ray differentials, scaled by 1/√spp as Mitsuba scales them.
    DuvDx(usize),
    DuvDy(usize),
    /// Triangle index in its mesh (`prim_index`).
    PrimIndex,
    /// 1 + the shape's index in the scene, 0 where the ray escapes (`shape_index`).
    ShapeIndex,
    /// The nested integrator's alpha: 1 where its ray is valid (a surface is hit, or an
    /// environment is visible), else 0.
    Alpha,
    /// CIE XYZ of the sample's radiance (Mitsuba's `srgb_to_xyz`), and its square.
    Xyz(usize),
    XyzSquared(usize),
}

impl SampleValue {
    /// True if the value needs the camera ray's first hit.
    pub fn needs_hit(self) -> bool {
        !matches!(
            self,
            SampleValue::Xyz(_) | SampleValue::XyzSquared(_) | SampleValue::Alpha
        )
    }
}

/// Where an extra output channel's pixel value comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChannelValue {
    /// Channel `c` (0 = R, 1 = G, 2 = B) of the image itself (a nested integrator's colour,
    /// which is the rendered image).
    Image(usize),
    /// The filtered mean of `ImageChannels::per_sample[k]`.
    Sample(usize),
}

/// The extra channels of a render, in Mitsuba's order (the EXR sorts them by name).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImageChannels {
    /// Output channels: name as Mitsuba writes it and where its value comes from.
    pub outputs: Vec<(String, ChannelValue)>,
    /// The values each camera sample adds to the film, beside its radiance.
    pub per_sample: Vec<SampleValue>,
}

/// An `aov` or `moment` integrator's nested integrator: its name and settings.
pub struct Nested<'n> {
    /// The `name` attribute (Mitsuba's `_arg_<i>` when it has none).
    pub name: &'n str,
    pub settings: &'n IntegratorSettings,
}

/// AOV types of Mitsuba 3.9.1 btfpt writes, with their channel suffixes.
const AOV_TYPES: &[(&str, &[&str])] = &[
    ("albedo", &["R", "G", "B"]),
    ("depth", &["T"]),
    ("position", &["X", "Y", "Z"]),
    ("uv", &["U", "V"]),
    ("geo_normal", &["X", "Y", "Z"]),
    ("sh_normal", &["X", "Y", "Z"]),
    ("dp_du", &["X", "Y", "Z"]),
    ("dp_dv", &["X", "Y", "Z"]),
    ("duv_dx", &["U", "V"]),
    ("duv_dy", &["U", "V"]),
    ("prim_index", &["I"]),
    ("shape_index", &["I"]),
];

fn aov_value(ty: &str, axis: usize) -> SampleValue {
    match ty {
        "albedo" => SampleValue::Albedo(axis),
        "depth" => SampleValue::Depth,
        "position" => SampleValue::Position(axis),
        "uv" => SampleValue::Uv(axis),
        "geo_normal" => SampleValue::GeoNormal(axis),
        "sh_normal" => SampleValue::ShNormal(axis),
        "dp_du" => SampleValue::DpDu(axis),
        "dp_dv" => SampleValue::DpDv(axis),
        "duv_dx" => SampleValue::DuvDx(axis),
        "duv_dy" => SampleValue::DuvDy(axis),
        "prim_index" => SampleValue::PrimIndex,
        _ => SampleValue::ShapeIndex,
    }
}

impl ImageChannels {
    /// True if the render writes no extra channel.
    pub fn is_empty(&self) -> bool {
        self.outputs.is_empty()
    }

    fn push_sample(&mut self, name: String, v: SampleValue) {
        self.outputs
            .push((name, ChannelValue::Sample(self.per_sample.len())));
        self.per_sample.push(v);
    }

    /// Mitsuba's `aov`: `aovs` = comma- or space-separated `<name>:<type>` pairs; each nested
    /// integrator adds `<name>.R`, `.G`, `.B` (its image) and `<name>.A`, before the AOVs.
    pub fn aov_from_props(
        p: &dyn Properties,
        nested: Option<Nested>,
    ) -> crate::Result<ImageChannels> {
        let spec = p.string_req("aovs")?;
        let mut ch = ImageChannels::default();
        if let Some(n) = nested {
            for (c, s) in ["R", "G", "B"].iter().enumerate() {
                ch.outputs
                    .push((format!("{}.{s}", n.name), ChannelValue::Image(c)));
            }
            ch.push_sample(format!("{}.A", n.name), SampleValue::Alpha);
        }
        for token in spec
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|t| !t.is_empty())
        {
            let item: Vec<&str> = token.split(':').filter(|t| !t.is_empty()).collect();
            let [name, ty] = item[..] else {
                return Err(p.err_at(
                    "aovs",
                    &format!(
                        "\"aovs\": invalid AOV \"{token}\" in \"{spec}\": expected <name>:<type>"
                    ),
                ));
            };
            let Some((_, suffixes)) = AOV_TYPES.iter().find(|(t, _)| *t == ty) else {
                let known: Vec<&str> = AOV_TYPES.iter().map(|(t, _)| *t).collect();
                return Err(p.err_at(
                    "aovs",
                    &format!(
                        "\"aovs\": invalid AOV type \"{ty}\" (in \"{token}\"; btfpt implements {})",
                        known.join(", ")
                    ),
                ));
            };
            for (axis, s) in suffixes.iter().enumerate() {
                ch.push_sample(format!("{name}.{s}"), aov_value(ty, axis));
            }
        }
        Ok(ch)
    }

    /// Mitsuba's `moment`: for the nested integrator, `<name>.X`, `.Y`, `.Z` (CIE XYZ of its
    /// radiance) and `m2_<name>.X`, … (the mean of their squares).
    pub fn moment_from_props(
        _p: &dyn Properties,
        nested: Option<Nested>,
    ) -> crate::Result<ImageChannels> {
        let mut ch = ImageChannels::default();
        if let Some(n) = nested {
            for (axis, s) in ["X", "Y", "Z"].iter().enumerate() {
                ch.push_sample(format!("{}.{s}", n.name), SampleValue::Xyz(axis));
            }
            for (axis, s) in ["X", "Y", "Z"].iter().enumerate() {
                ch.push_sample(format!("m2_{}.{s}", n.name), SampleValue::XyzSquared(axis));
            }
        }
        Ok(ch)
    }
}
