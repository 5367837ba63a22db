//! The encoding a model's values live in: linear reflectance, or the sRGB encoding of 8-bit data.

/// The space the model's values live in (the space it was fitted in).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ValueSpace {
    /// Linear cosine-baked reflectance: the polynomial output is the BTF value.
    Linear,
    /// sRGB-encoded (the stored encoding of 8-bit data): the BTF value is
    /// `srgb_to_linear(max(0, polynomial output))`.
    Srgb,
}

impl ValueSpace {
    /// Code stored in the file header.
    pub fn code(self) -> u8 {
        match self {
            ValueSpace::Linear => 0,
            ValueSpace::Srgb => 1,
        }
    }
    /// Inverse of [`ValueSpace::code`].
    pub fn from_code(c: u8) -> Option<Self> {
        match c {
            0 => Some(ValueSpace::Linear),
            1 => Some(ValueSpace::Srgb),
            _ => None,
        }
    }
    /// Converts a model output (after the polynomial) to the linear BTF value.
    #[inline]
    pub fn to_linear(self, v: f32) -> f32 {
        match self {
            ValueSpace::Linear => v.max(0.0),
            ValueSpace::Srgb => crate::math::color::srgb_to_linear(v.max(0.0)),
        }
    }
}
