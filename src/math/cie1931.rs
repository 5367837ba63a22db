//! Wavelength-list spectra to linear sRGB, as Mitsuba 3.9.1's RGB variants convert a
//! `<spectrum value="400:0.343, 404:0.445, ...">` at load time (`spectrum_list_to_srgb` in its
//! `src/core/spectrum.cpp`): the piecewise-linear spectrum is integrated against the CIE 1931
//! colour matching functions (times the D65 illuminant for reflectances) by a Riemann sum over
//! 1000 evenly spaced wavelengths from 360 to 830 nm (both ends included), normalised so that a
//! unit spectrum has luminance 1, then taken from XYZ to linear Rec.709 RGB and clipped
//! (reflectances to [0, 1], others at 0).
//!
//! Tables: the CIE 1931 2° standard observer colour matching functions and the CIE standard
//! illuminant D65, both at 5 nm from 360 to 830 nm (CIE 018:2019 / ISO 11664-1 and ISO 11664-2,
//! as published by the CIE and tabulated by the Colour & Vision Research Laboratory, UCL), the
//! values Mitsuba 3 also uses (stored there as f32, hence the f32 rounding in [`table`]).

/// Number of table entries (360..=830 nm every 5 nm).
const SAMPLES: usize = 95;
/// First tabulated wavelength in nm.
pub const CIE_MIN: f64 = 360.0;
/// Last tabulated wavelength in nm.
pub const CIE_MAX: f64 = 830.0;
/// Makes a unit spectrum integrate to luminance 1 (Mitsuba's `MI_CIE_Y_NORMALIZATION`).
const Y_NORMALIZATION: f64 = 1.0 / 106.750_259_399_414_06;
/// Makes D65 integrate to luminance 1 (Mitsuba's `MI_CIE_D65_NORMALIZATION`).
const D65_NORMALIZATION: f64 = 1.0 / 98.997_417_518_762_55;
/// Points of the Riemann sum over [`CIE_MIN`, `CIE_MAX`].
const STEPS: usize = 1000;

/// CIE 1931 2° colour matching function (X), 360..=830 nm every 5 nm.
const CMF_X: [f64; SAMPLES] = [
    0.0001299,
    0.0002321,
    0.0004149,
    0.0007416,
    0.001368,
    0.002236,
    0.004243,
    0.00765,
    0.01431,
    0.02319,
    0.04351,
    0.07763,
    0.13438,
    0.21477,
    0.2839,
    0.3285,
    0.34828,
    0.34806,
    0.3362,
    0.3187,
    0.2908,
    0.2511,
    0.19536,
    0.1421,
    0.09564,
    0.05795001,
    0.03201,
    0.0147,
    0.0049,
    0.0024,
    0.0093,
    0.0291,
    0.06327,
    0.1096,
    0.1655,
    0.2257499,
    0.2904,
    0.3597,
    0.4334499,
    0.5120501,
    0.5945,
    0.6784,
    0.7621,
    0.8425,
    0.9163,
    0.9786,
    1.0263,
    1.0567,
    1.0622,
    1.0456,
    1.0026,
    0.9384,
    0.8544499,
    0.7514,
    0.6424,
    0.5419,
    0.4479,
    0.3608,
    0.2835,
    0.2187,
    0.1649,
    0.1212,
    0.0874,
    0.0636,
    0.04677,
    0.0329,
    0.0227,
    0.01584,
    0.01135916,
    0.008110916,
    0.005790346,
    0.004109457,
    0.002899327,
    0.00204919,
    0.001439971,
    0.0009999493,
    0.0006900786,
    0.0004760213,
    0.0003323011,
    0.0002348261,
    0.0001661505,
    0.000117413,
    0.00008307527,
    0.00005870652,
    0.00004150994,
    0.00002935326,
    0.00002067383,
    0.00001455977,
    0.00001025398,
    0.000007221456,
    0.000005085868,
    0.000003581652,
    0.000002522525,
    0.000001776509,
    0.000001251141,
];

/// CIE 1931 2° colour matching function (Y), 360..=830 nm every 5 nm.
const CMF_Y: [f64; SAMPLES] = [
    0.000003917,
    0.000006965,
    0.00001239,
    0.00002202,
    0.000039,
    0.000064,
    0.00012,
    0.000217,
    0.000396,
    0.00064,
    0.00121,
    0.00218,
    0.004,
    0.0073,
    0.0116,
    0.01684,
    0.023,
    0.0298,
    0.038,
    0.048,
    0.06,
    0.0739,
    0.09098,
    0.1126,
    0.13902,
    0.1693,
    0.20802,
    0.2586,
    0.323,
    0.4073,
    0.503,
    0.6082,
    0.71,
    0.7932,
    0.862,
    0.9148501,
    0.954,
    0.9803,
    0.9949501,
    1.0,
    0.995,
    0.9786,
    0.952,
    0.9154,
    0.87,
    0.8163,
    0.757,
    0.6949,
    0.631,
    0.5668,
    0.503,
    0.4412,
    0.381,
    0.321,
    0.265,
    0.217,
    0.175,
    0.1382,
    0.107,
    0.0816,
    0.061,
    0.04458,
    0.032,
    0.0232,
    0.017,
    0.01192,
    0.00821,
    0.005723,
    0.004102,
    0.002929,
    0.002091,
    0.001484,
    0.001047,
    0.00074,
    0.00052,
    0.0003611,
    0.0002492,
    0.0001719,
    0.00012,
    0.0000848,
    0.00006,
    0.0000424,
    0.00003,
    0.0000212,
    0.00001499,
    0.0000106,
    0.0000074657,
    0.0000052578,
    0.0000037029,
    0.0000026078,
    0.0000018366,
    0.0000012934,
    0.00000091093,
    0.00000064153,
    0.00000045181,
];

/// CIE 1931 2° colour matching function (Z), 360..=830 nm every 5 nm.
const CMF_Z: [f64; SAMPLES] = [
    0.0006061,
    0.001086,
    0.001946,
    0.003486,
    0.006450001,
    0.01054999,
    0.02005001,
    0.03621,
    0.06785001,
    0.1102,
    0.2074,
    0.3713,
    0.6456,
    1.0390501,
    1.3856,
    1.62296,
    1.74706,
    1.7826,
    1.77211,
    1.7441,
    1.6692,
    1.5281,
    1.28764,
    1.0419,
    0.8129501,
    0.6162,
    0.46518,
    0.3533,
    0.272,
    0.2123,
    0.1582,
    0.1117,
    0.07824999,
    0.05725001,
    0.04216,
    0.02984,
    0.0203,
    0.0134,
    0.008749999,
    0.005749999,
    0.0039,
    0.002749999,
    0.0021,
    0.0018,
    0.001650001,
    0.0014,
    0.0011,
    0.001,
    0.0008,
    0.0006,
    0.00034,
    0.00024,
    0.00019,
    0.0001,
    0.00004999999,
    0.00003,
    0.00002,
    0.00001,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
];

/// CIE standard illuminant D65, relative spectral power (100 at 560 nm), 360..=830 nm every 5 nm.
const D65: [f64; SAMPLES] = [
    46.6383, 49.3637, 52.0891, 51.0323, 49.9755, 52.3118, 54.6482, 68.7015, 82.7549, 87.1204,
    91.486, 92.4589, 93.4318, 90.057, 86.6823, 95.7736, 104.865, 110.936, 117.008, 117.41, 117.812,
    116.336, 114.861, 115.392, 115.923, 112.367, 108.811, 109.082, 109.354, 108.578, 107.802,
    106.296, 104.79, 106.239, 107.689, 106.047, 104.405, 104.225, 104.046, 102.023, 100.0, 98.1671,
    96.3342, 96.0611, 95.788, 92.2368, 88.6856, 89.3459, 90.0062, 89.8026, 89.5991, 88.6489,
    87.6987, 85.4936, 83.2886, 83.4939, 83.6992, 81.863, 80.0268, 80.1207, 80.2146, 81.2462,
    82.2778, 80.281, 78.2842, 74.0027, 69.7213, 70.6652, 71.6091, 72.979, 74.349, 67.9765, 61.604,
    65.7448, 69.8856, 72.4863, 75.087, 69.3398, 63.5927, 55.0054, 46.4182, 56.6118, 66.8054,
    65.0941, 63.3828, 63.8434, 64.304, 61.8779, 59.4519, 55.7054, 51.959, 54.6998, 57.4406,
    58.8765, 60.3125,
];

/// How a spectrum is used, which decides its conversion (Mitsuba's `get_texture`,
/// `get_unbounded_texture` and `get_emissive_texture`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpectrumUse {
    /// A reflectance-like parameter: weighted by D65, the RGB clipped to [0, 1].
    Reflectance,
    /// A parameter without an upper bound (IOR, roughness): weighted by D65, clipped at 0.
    Unbounded,
    /// Emitted radiance, intensity or irradiance: not weighted by D65, clipped at 0.
    Emission,
}

/// Linear interpolation in a 5 nm table at wavelength `w` (nm), 0 outside 360–830 nm, with the
/// table's entries rounded to f32 as Mitsuba stores them.
fn table(t: &[f64; SAMPLES], w: f64) -> f64 {
    if !(CIE_MIN..=CIE_MAX).contains(&w) {
        return 0.0;
    }
    let x = (w - CIE_MIN) * ((SAMPLES - 1) as f64 / (CIE_MAX - CIE_MIN));
    let i0 = (x as usize).min(SAMPLES - 2);
    let w1 = x - i0 as f64;
    let w0 = 1.0 - w1;
    let (v0, v1) = (t[i0] as f32 as f64, t[i0 + 1] as f32 as f64);
    w0.mul_add(v0, w1 * v1)
}

/// XYZ → linear Rec.709 RGB (Mitsuba's `xyz_to_srgb` matrix, f32 entries).
const XYZ_TO_SRGB: [[f32; 3]; 3] = [
    [3.240479, -1.53715, -0.498535],
    [-0.969256, 1.875991, 0.041556],
    [0.055648, -0.204043, 1.057311],
];

/// Linear Rec.709 RGB of CIE XYZ (Mitsuba's `xyz_to_srgb`, its f32 matrix).
pub fn xyz_to_srgb(xyz: [f64; 3]) -> [f64; 3] {
    XYZ_TO_SRGB.map(|r| r[0] as f64 * xyz[0] + r[1] as f64 * xyz[1] + r[2] as f64 * xyz[2])
}

/// Linear Rec.709 RGB → CIE XYZ (Mitsuba's `srgb_to_xyz` matrix, f32 entries).
const SRGB_TO_XYZ: [[f32; 3]; 3] = [
    [0.412453, 0.357580, 0.180423],
    [0.212671, 0.715160, 0.072169],
    [0.019334, 0.119193, 0.950227],
];

/// CIE XYZ of linear Rec.709 RGB, in f32 as Mitsuba's `srgb_to_xyz` (what its `moment`
/// integrator records).
pub fn srgb_to_xyz(rgb: [f32; 3]) -> [f32; 3] {
    SRGB_TO_XYZ.map(|r| r[0] * rgb[0] + r[1] * rgb[1] + r[2] * rgb[2])
}

/// The RGB of a uniform spectrum of value 1 used as an emitter in Mitsuba's RGB variants
/// (`xyz_to_srgb(1, 1, 1)` in f32: the D65 white point makes it purplish, ≈ (1.205, 0.948, 0.909)).
pub fn uniform_emission_rgb() -> [f32; 3] {
    XYZ_TO_SRGB.map(|r| r[0] + r[1] + r[2])
}

/// Linear sRGB of the piecewise-linear spectrum through (`wavelengths[i]` nm, `values[i]`),
/// exactly as Mitsuba 3.9.1's `spectrum_list_to_srgb` (in double precision, then f32): zero
/// outside the listed range. Also returns whether the result had to be clipped (Mitsuba warns).
/// `wavelengths` must hold at least two strictly increasing values, as many as `values`.
pub fn spectrum_list_to_srgb(
    wavelengths: &[f64],
    values: &[f64],
    usage: SpectrumUse,
) -> ([f32; 3], bool) {
    assert!(wavelengths.len() >= 2 && wavelengths.len() == values.len());
    let d65 = usage != SpectrumUse::Emission;
    let (first, last) = (wavelengths[0], wavelengths[wavelengths.len() - 1]);
    let mut xyz = [0.0f64; 3];
    for i in 0..STEPS {
        let w = CIE_MIN + (i as f64 / (STEPS - 1) as f64) * (CIE_MAX - CIE_MIN);
        if w < first || w > last {
            continue;
        }
        // The interval [index, index + 1] holding w (Mitsuba's find_interval).
        let index = wavelengths[1..wavelengths.len() - 1]
            .partition_point(|&x| x <= w)
            .min(wavelengths.len() - 2);
        let (w0, w1) = (wavelengths[index], wavelengths[index + 1]);
        let (v0, v1) = (values[index], values[index + 1]);
        let v = ((w - w1) * v0 + (w0 - w) * v1) / (w0 - w1);
        let illum = if d65 {
            table(&D65, w) * D65_NORMALIZATION
        } else {
            1.0
        };
        for (acc, cmf) in xyz.iter_mut().zip([&CMF_X, &CMF_Y, &CMF_Z]) {
            *acc += table(cmf, w) * v * illum;
        }
    }
    let scale = (CIE_MAX - CIE_MIN) * Y_NORMALIZATION / STEPS as f64;
    let rgb = xyz_to_srgb(xyz.map(|c| c * scale));
    let upper = if usage == SpectrumUse::Reflectance {
        1.0
    } else {
        f64::INFINITY
    };
    let clipped = rgb.iter().any(|&c| c < 0.0 || c > upper);
    (rgb.map(|c| c.clamp(0.0, upper) as f32), clipped)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mitsuba 3.9.1's own results (`reference-images/spectrum_golden.py`, scalar_rgb).
    const GOLDEN: &str = include_str!("../../reference-images/spectrum_golden.txt");

    fn parse(list: &str) -> (Vec<f64>, Vec<f64>) {
        list.split([',', ' '])
            .filter(|t| !t.is_empty())
            .map(|t| {
                let (w, v) = t.split_once(':').unwrap();
                (w.parse::<f64>().unwrap(), v.parse::<f64>().unwrap())
            })
            .unzip()
    }

    #[test]
    fn matches_mitsuba_spectrum_list_to_srgb() {
        let mut n = 0;
        for line in GOLDEN.lines() {
            let mut f = line.splitn(5, ' ');
            let usage = match f.next().unwrap() {
                "reflectance" => SpectrumUse::Reflectance,
                "unbounded" => SpectrumUse::Unbounded,
                "emitter" => SpectrumUse::Emission,
                other => panic!("unknown use {other}"),
            };
            let want: Vec<f32> = (0..3).map(|_| f.next().unwrap().parse().unwrap()).collect();
            let list = f.next().unwrap();
            let got = if list.contains(':') {
                let (w, v) = parse(list);
                spectrum_list_to_srgb(&w, &v, usage).0
            } else {
                let v: f32 = list.parse().unwrap();
                uniform_emission_rgb().map(|c| c * v)
            };
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() <= 2e-6 * want[c].abs().max(1.0),
                    "{line}: ours {got:?}, Mitsuba {want:?}"
                );
            }
            n += 1;
        }
        assert_eq!(n, 14);
    }

    #[test]
    fn tables_integrate_to_their_normalisations() {
        // Σ ȳ · 5 nm = 106.857 (the 5 nm CIE sum); Mitsuba's constant is its 1000-step Riemann sum.
        let sum_y: f64 = CMF_Y.iter().sum::<f64>() * 5.0;
        assert!((sum_y - 106.857).abs() < 1e-2, "{sum_y}");
        // A flat unit reflectance under D65 has luminance 1 within the Riemann sum's error.
        let (rgb, clipped) =
            spectrum_list_to_srgb(&[CIE_MIN, CIE_MAX], &[1.0, 1.0], SpectrumUse::Unbounded);
        let y = 0.212671 * rgb[0] + 0.715160 * rgb[1] + 0.072169 * rgb[2];
        assert!(!clipped && (y - 1.0).abs() < 2e-3, "{rgb:?}");
        // Outside the listed range the spectrum is 0.
        let (rgb, _) = spectrum_list_to_srgb(&[200.0, 300.0], &[5.0, 5.0], SpectrumUse::Emission);
        assert_eq!(rgb, [0.0; 3]);
    }
}
