//! The UBO2014 header: signature, version-dependent fields, direction sets, rotations, and the
//! payload kind and colour model it announces.

use crate::btf::DirectionSet;
use crate::io::bytes::Reader;
use crate::{Error, Result};
use std::path::Path;

/// How the byte reader names this data in errors.
pub(super) const KIND: &str = "UBO2014 .btf";

/// Offset the Bonn tools add before taking logarithms (btflib's default `drr_eps`).
pub(super) const DRR_EPS: f32 = 1e-5;
/// Upper bound on channel counts and name lengths accepted from a header.
pub(super) const MAX_CHANNELS: u32 = 64;

/// Which payload a `.btf` file carries.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PayloadKind {
    /// Full matrix factorisation of all channels together; `extended` = `!FMF12FCE` header.
    Fmf { extended: bool },
    /// Decorrelated FMF: one factorisation per decorrelated colour channel.
    Dfmf,
}

/// DFMF colour models that can be inverted (btflib numbering).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ColorModel {
    /// 0: plain RGB.
    Rgb,
    /// 1: YUV.
    Yuv,
    /// 3: PCA colour space, as Bonn's btflib decodes it: rgb = v · M + mean for the row vector
    /// v, i.e. rgb_j = Σᵢ vᵢ · M(i, j) + mean_j. `matrix` is M row by row, `matrix[3·i + j]` =
    /// M(i, j), the order of the file (btflib writes `fwrite(M')` and reads it back row-major).
    Pca { mean: [f32; 3], matrix: [f32; 9] },
    /// 4: YCoCg.
    YCoCg,
    /// 9: log Y, linear UV.
    YlogUv,
    /// 10: log Y, signed log U and V.
    YlogUlogVlog,
    /// 11: log Y, U/Y, V/Y.
    YlogUdivYVdivY,
    /// 12: log RGB.
    LogRgb,
}

impl ColorModel {
    /// Btflib's numeric code of this model.
    pub fn code(&self) -> i32 {
        match self {
            ColorModel::Rgb => 0,
            ColorModel::Yuv => 1,
            ColorModel::Pca { .. } => 3,
            ColorModel::YCoCg => 4,
            ColorModel::YlogUv => 9,
            ColorModel::YlogUlogVlog => 10,
            ColorModel::YlogUdivYVdivY => 11,
            ColorModel::LogRgb => 12,
        }
    }

    pub(super) fn from_code(code: i32, mean: [f32; 3], matrix: [f32; 9]) -> Option<Self> {
        Some(match code {
            0 => ColorModel::Rgb,
            1 => ColorModel::Yuv,
            3 => ColorModel::Pca { mean, matrix },
            4 => ColorModel::YCoCg,
            9 => ColorModel::YlogUv,
            10 => ColorModel::YlogUlogVlog,
            11 => ColorModel::YlogUdivYVdivY,
            12 => ColorModel::LogRgb,
            _ => return None,
        })
    }

    #[inline]
    pub(super) fn decode(self, v: [f32; 3]) -> [f32; 3] {
        #[inline]
        fn yuv(v: [f32; 3]) -> [f32; 3] {
            [
                v[0] + 1.13983 * v[2],
                v[0] - 0.39465 * v[1] - 0.5806 * v[2],
                v[0] + 2.03211 * v[1],
            ]
        }
        match self {
            ColorModel::Rgb => v,
            ColorModel::Yuv => yuv(v),
            ColorModel::Pca { mean, matrix: m } => {
                std::array::from_fn(|j| v[0] * m[j] + v[1] * m[3 + j] + v[2] * m[6 + j] + mean[j])
            }
            ColorModel::YCoCg => [v[0] + v[1] - v[2], v[0] + v[2], v[0] - v[1] - v[2]],
            ColorModel::YlogUv => yuv([v[0].exp() - DRR_EPS, v[1], v[2]]),
            ColorModel::YlogUlogVlog => {
                let slog = |x: f32| x.signum() * (x.abs() + DRR_EPS.ln()).exp();
                yuv([v[0].exp() - DRR_EPS, slog(v[1]), slog(v[2])])
            }
            ColorModel::YlogUdivYVdivY => {
                let y = v[0].exp() - DRR_EPS;
                yuv([y, v[1] * (y + DRR_EPS), v[2] * (y + DRR_EPS)])
            }
            ColorModel::LogRgb => v.map(|x| x.exp() - DRR_EPS),
        }
    }
}

/// The header fields shared by all UBO2014 formats.
#[derive(Clone, Debug)]
pub struct Ubo2014Header {
    /// The signature as found in the file, e.g. `!FMF12FCER`.
    pub signature: String,
    /// Header version (1–4).
    pub version: u32,
    /// 1 if the stored values include cos θ_l, 0 if not (then we multiply it in).
    pub cosine_flag: u32,
    /// Per-channel RGB scale factor of the header, reported but not applied: Bonn's btflib
    /// reads it and never uses it, and the reference reader `btf.hh` skips it.
    pub rgb_scale: [f32; 3],
    /// Channel names (R, G, B unless the header says otherwise).
    pub channels: Vec<String>,
    /// Measured view directions.
    pub views: DirectionSet,
    /// Measured light directions (identical for every view).
    pub lights: DirectionSet,
    /// Texels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Payload kind.
    pub kind: PayloadKind,
}

/// Radians (as stored) → degrees, rounded to 1e-4° so nominal angles (30°, 23.5°) survive the
/// f32 round trip exactly (the rounding moves a direction by < 2e-6 rad).
pub(super) fn angles_deg(theta: f32, phi: f32) -> (f32, f32) {
    let deg = |r: f32| ((r as f64).to_degrees() * 1e4).round() / 1e4;
    (deg(theta) as f32, deg(phi).rem_euclid(360.0) as f32)
}

pub(super) fn parse_common(
    r: &mut Reader,
    signature: String,
    kind: PayloadKind,
    rotations: bool,
) -> Result<Ubo2014Header> {
    let start = r.pos();
    let size = r.u32("header size")?;
    let version = r.u32("header version")?;
    r.take_n(3, 80, "header text fields")?;
    let _ppmm = r.f32("ppmm")?;
    let rgb_scale = [
        r.f32("rgb scale")?,
        r.f32("rgb scale")?,
        r.f32("rgb scale")?,
    ];
    let cosine_flag = if version > 1 {
        r.u32("cosine flag")?
    } else {
        0
    };
    if version > 2 {
        let len = r.u32("XML length")?;
        r.take_n(len as u64, 1, "XML block")?;
    }
    let mut channels = vec!["R".to_string(), "G".to_string(), "B".to_string()];
    if version > 3 {
        let n = r.u32("channel count")?;
        if n == 0 || n > MAX_CHANNELS {
            return Err(r.err(format!("implausible channel count {n}")));
        }
        channels.clear();
        for _ in 0..n {
            let len = r.u32("channel name length")?;
            let name = r.take_n(len as u64, 1, "channel name")?;
            channels.push(String::from_utf8_lossy(name).into_owned());
        }
    }
    if r.pos() - start != size as usize {
        return Err(r.err(format!(
            "header size field says {size} bytes, but the header fields took {}",
            r.pos() - start
        )));
    }
    let nv = r.u32("view count")?;
    if nv == 0 || nv as u64 * 12 > r.remaining() as u64 {
        return Err(r.err(format!("implausible view count {nv}")));
    }
    let mut views = Vec::with_capacity(nv as usize);
    let mut lights: Option<Vec<(f32, f32)>> = None;
    for v in 0..nv {
        let (t, p) = (r.f32("view θ")?, r.f32("view φ")?);
        views.push(angles_deg(t, p));
        let nl = r.u32("light count")?;
        let raw = r.take_n(nl as u64, 8, "light directions")?;
        let ls: Vec<(f32, f32)> = raw
            .chunks_exact(8)
            .map(|c| {
                let t = f32::from_le_bytes([c[0], c[1], c[2], c[3]]);
                let p = f32::from_le_bytes([c[4], c[5], c[6], c[7]]);
                angles_deg(t, p)
            })
            .collect();
        if nl == 0 {
            return Err(r.err(format!("view {v} has no light directions")));
        }
        match &lights {
            None => lights = Some(ls),
            Some(first) => {
                let same = first.len() == ls.len()
                    && first
                        .iter()
                        .zip(&ls)
                        .all(|(a, b)| (a.0 - b.0).abs() < 1e-3 && (a.1 - b.1).abs() < 1e-3);
                if !same {
                    return Err(r.err(format!(
                        "view {v} has a different light set from view 0 (unsupported)"
                    )));
                }
            }
        }
    }
    let width = r.u32("width")? as usize;
    let height = r.u32("height")? as usize;
    if width == 0 || height == 0 {
        return Err(r.err(format!("empty texture size {width}×{height}")));
    }
    if rotations {
        let n = r.u32("rotation count")?;
        r.take_n(n as u64, 36, "rotations")?;
    }
    Ok(Ubo2014Header {
        signature,
        version,
        cosine_flag,
        rgb_scale,
        channels,
        views: DirectionSet::from_angles_deg(views),
        lights: DirectionSet::from_angles_deg(lights.unwrap_or_default()),
        width,
        height,
        kind,
    })
}

/// Parses the signature and common header; returns the header and the payload's start offset.
pub(super) fn parse_header(path: &Path, bytes: &[u8]) -> Result<(Ubo2014Header, usize)> {
    let table: [(&str, Option<PayloadKind>); 5] = [
        ("!DFMF08FC", Some(PayloadKind::Dfmf)),
        ("!FMF12FCE", Some(PayloadKind::Fmf { extended: true })),
        ("!FMF06FC", Some(PayloadKind::Fmf { extended: false })),
        ("!PVF06FC", None),
        ("!BDIF06", None),
    ];
    let Some((sig, kind)) = table.iter().find(|(s, _)| bytes.starts_with(s.as_bytes())) else {
        let shown: String = bytes.iter().take(10).map(|&b| b as char).collect();
        return Err(Error::format(
            path,
            format!("not a UBO2014 .btf file (signature {shown:?})"),
        ));
    };
    let Some(kind) = *kind else {
        return Err(Error::format(
            path,
            format!("UBO2014 format {sig} is not supported (only FMF and DFMF payloads)"),
        ));
    };
    let after = sig.len();
    // A trailing 'R' announces rotations; it is ambiguous with a size byte of 0x52, so fall back
    // to "no rotations" if the header does not parse with it.
    let attempts: &[bool] = if bytes.get(after) == Some(&b'R') {
        &[true, false]
    } else {
        &[false]
    };
    let mut last_err = None;
    for &rot in attempts {
        let mut r = Reader::new(bytes, path, KIND);
        r.seek(after + rot as usize)?;
        let signature = String::from_utf8_lossy(&bytes[..r.pos()]).into_owned();
        match parse_common(&mut r, signature, kind, rot) {
            Ok(h) => return Ok((h, r.pos())),
            Err(e) => {
                last_err.get_or_insert(e);
            }
        }
    }
    Err(last_err.unwrap_or_else(|| Error::format(path, "cannot parse header")))
}
