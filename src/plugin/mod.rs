//! Plugin parameters: what a plugin's constructor reads its properties through (Mitsuba 3's
//! `Properties`, pbrt-v4's `ParameterDictionary`), whatever the scene format that wrote them.
//! A scene format provides the values, the queried-property tracking and errors that name
//! where the plugin was written; the typed readers here are the same for every format.

mod fov;

pub use fov::horizontal_fov;

use crate::math::Mat4;
use crate::math::Vec3;
use crate::math::cie1931::{SpectrumUse, spectrum_list_to_srgb, uniform_emission_rgb};
use crate::{Error, Result};
use std::path::PathBuf;

/// A typed property value as written in the scene.
#[derive(Clone, Debug)]
pub enum Value {
    Float(f32),
    Integer(i64),
    Boolean(bool),
    String(String),
    Rgb(Vec3),
    /// A constant spectrum (`<spectrum value="x">`).
    Spectrum(f32),
    /// A spectrum given as wavelength:value pairs: wavelengths in nm, strictly increasing, at
    /// least two; converted to RGB where it is used.
    SpectrumList(Vec<f64>, Vec<f64>),
    Point(Vec3),
    Vector(Vec3),
    Transform(Mat4),
}

impl Value {
    /// The type name a scene file gives this value (for messages).
    pub fn kind(&self) -> &'static str {
        match self {
            Value::Float(_) => "float",
            Value::Integer(_) => "integer",
            Value::Boolean(_) => "boolean",
            Value::String(_) => "string",
            Value::Rgb(_) => "rgb",
            Value::Spectrum(_) | Value::SpectrumList(..) => "spectrum",
            Value::Point(_) => "point",
            Value::Vector(_) => "vector",
            Value::Transform(_) => "transform",
        }
    }
}

/// The properties of one plugin as its constructor reads them. Reading a property marks it
/// read: the format reports properties no constructor looked at (Mitsuba semantics).
pub trait Properties {
    /// The plugin name (Mitsuba's `type`): "diffuse", "point", ...
    fn plugin_type(&self) -> &str;

    /// An error at the plugin, naming the file, line, element and plugin.
    fn err(&self, msg: &str) -> Error;

    /// An error at the property or nested object called `name` (its own line), else at the plugin.
    fn err_at(&self, name: &str, msg: &str) -> Error;

    /// True if a property or nested object of that name exists (does not mark it read).
    fn has(&self, name: &str) -> bool;

    /// The value of property `name`, marking it read.
    fn value(&self, name: &str) -> Option<&Value>;

    /// The tag (bsdf, texture, ...) of the nested object called `name`, marking it read.
    fn nested_tag(&self, name: &str) -> Option<&str>;

    /// The file a `filename` property names, as the scene format resolves relative paths.
    fn resolve(&self, filename: &str) -> PathBuf;

    /// True if the plugin was written in a Mitsuba 0.6 file (scene version below 2): its
    /// constructor then also reads the old parameters that Mitsuba 3's upgrade pass translates.
    fn mitsuba_0_6(&self) -> bool;

    /// The wrong-type error for property `name` holding `v`.
    fn wrong_type(&self, name: &str, v: &Value, expected: &str) -> Error {
        self.err_at(
            name,
            &format!(
                "property \"{name}\" has the wrong type (expected {expected}, got {})",
                v.kind()
            ),
        )
    }

    /// A float (an integer is accepted too).
    fn float_opt(&self, name: &str) -> Result<Option<f32>> {
        match self.value(name) {
            None => Ok(None),
            Some(v) => match *v {
                Value::Float(f) => Ok(Some(f)),
                Value::Integer(i) => Ok(Some(i as f32)),
                _ => Err(self.wrong_type(name, v, "float")),
            },
        }
    }

    /// A float with a default.
    fn float(&self, name: &str, default: f32) -> Result<f32> {
        Ok(self.float_opt(name)?.unwrap_or(default))
    }

    /// An integer with a default.
    fn int(&self, name: &str, default: i64) -> Result<i64> {
        match self.value(name) {
            None => Ok(default),
            Some(v) => match *v {
                Value::Integer(i) => Ok(i),
                _ => Err(self.wrong_type(name, v, "integer")),
            },
        }
    }

    /// A boolean with a default.
    fn bool(&self, name: &str, default: bool) -> Result<bool> {
        match self.value(name) {
            None => Ok(default),
            Some(v) => match *v {
                Value::Boolean(b) => Ok(b),
                _ => Err(self.wrong_type(name, v, "boolean")),
            },
        }
    }

    /// A string, if present.
    fn string_opt(&self, name: &str) -> Result<Option<String>> {
        match self.value(name) {
            None => Ok(None),
            Some(Value::String(s)) => Ok(Some(s.clone())),
            Some(v) => Err(self.wrong_type(name, v, "string")),
        }
    }

    /// A string with a default.
    fn string(&self, name: &str, default: &str) -> Result<String> {
        Ok(self
            .string_opt(name)?
            .unwrap_or_else(|| default.to_string()))
    }

    /// A required string.
    fn string_req(&self, name: &str) -> Result<String> {
        self.string_opt(name)?
            .ok_or_else(|| self.err(&format!("missing required property \"{name}\"")))
    }

    /// A float or a string (for named IORs).
    fn float_or_string(&self, name: &str) -> Result<Option<std::result::Result<f32, String>>> {
        match self.value(name) {
            None => Ok(None),
            Some(v) => match v {
                Value::Float(f) => Ok(Some(Ok(*f))),
                Value::Integer(i) => Ok(Some(Ok(*i as f32))),
                Value::String(s) => Ok(Some(Err(s.clone()))),
                _ => Err(self.wrong_type(name, v, "float or string")),
            },
        }
    }

    /// An emitted quantity (radiance, intensity, irradiance) given as `rgb`, `float` or
    /// `spectrum`: a constant spectrum is that multiple of Mitsuba's white (D65-relative) RGB,
    /// a wavelength list is converted without the D65 weighting, as Mitsuba's RGB variants do.
    fn emission(&self, name: &str, default: Vec3) -> Result<Vec3> {
        Ok(self
            .color_opt_as(name, SpectrumUse::Emission)?
            .unwrap_or(default))
    }

    /// A colour given as `rgb`, `float` or `spectrum` (a nested object of that name is an
    /// error), used as `usage`: what a wavelength list or constant spectrum converts to, as in
    /// Mitsuba's RGB variants.
    fn color_opt_as(&self, name: &str, usage: SpectrumUse) -> Result<Option<Vec3>> {
        match self.value(name) {
            None => match self.nested_tag(name) {
                Some(tag) => Err(self.err_at(
                    name,
                    &format!(
                        "property \"{name}\" must be a constant (rgb/float), not a nested <{tag}>"
                    ),
                )),
                None => Ok(None),
            },
            Some(v) => match v {
                Value::Rgb(c) => Ok(Some(*c)),
                Value::Float(f) => Ok(Some(Vec3::splat(*f))),
                Value::Spectrum(s) if usage == SpectrumUse::Emission => {
                    Ok(Some(Vec3::from(uniform_emission_rgb()) * *s))
                }
                Value::Spectrum(s) => Ok(Some(Vec3::splat(*s))),
                Value::SpectrumList(w, s) => {
                    Ok(Some(Vec3::from(spectrum_list_to_srgb(w, s, usage).0)))
                }
                Value::Integer(i) => Ok(Some(Vec3::splat(*i as f32))),
                _ => Err(self.wrong_type(name, v, "rgb or float")),
            },
        }
    }

    /// A point or vector.
    fn vec3_opt(&self, name: &str) -> Result<Option<Vec3>> {
        match self.value(name) {
            None => Ok(None),
            Some(v) => match *v {
                Value::Point(p) | Value::Vector(p) => Ok(Some(p)),
                _ => Err(self.wrong_type(name, v, "point or vector")),
            },
        }
    }

    /// A transform, if present.
    fn transform_opt(&self, name: &str) -> Result<Option<Mat4>> {
        match self.value(name) {
            None => Ok(None),
            Some(v) => match *v {
                Value::Transform(m) => Ok(Some(m)),
                _ => Err(self.wrong_type(name, v, "transform")),
            },
        }
    }
}
