//! Colour encodings: the exact sRGB transfer functions and Rec.709 luminance (as Mitsuba 3).

use glam::Vec3;

/// sRGB-encoded value in [0, 1] → linear (exact piecewise EOTF).
#[inline]
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Linear value → sRGB encoding (not clamped).
#[inline]
pub fn linear_to_srgb(v: f32) -> f32 {
    if v <= 0.0031308 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Lookup table for decoding 8-bit sRGB, the hot path of every UBO2003 image load.
pub fn srgb8_to_linear_table() -> &'static [f32; 256] {
    static TABLE: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0)))
}

/// Rec.709 luminance of a linear RGB triple (same weights as Mitsuba's `luminance`).
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    c.x * 0.212671 + c.y * 0.715160 + c.z * 0.072169
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trip_and_table() {
        for i in 0..=255 {
            let v = i as f32 / 255.0;
            assert!((linear_to_srgb(srgb_to_linear(v)) - v).abs() < 1e-5);
            assert_eq!(srgb8_to_linear_table()[i], srgb_to_linear(v));
        }
        assert!((srgb_to_linear(0.5) - 0.214_041_14).abs() < 1e-6);
    }
}
