//! Bonn UBO2014 `.btf` files: full-matrix-factorised payloads (FMF: `!FMF06FC`, `!FMF12FCE`;
//! DFMF: `!DFMF08FC`; each optionally followed by `R` = rotations in the header), decoded one view
//! at a time into linear, cosine-baked RGB (DESIGN §2–3).
//!
//! Payload layout (as documented by the public `btf.hh` of zeroeffects/btf and Bonn's btflib):
//! the BTF matrix of one channel is U · (S·V)ᵀ. With "ABRDFs stacked" (the usual case) U has
//! one row per (view, light) pair, `row = view · nL + light`, and S·V one row per texel,
//! `row = y · width + x` (row 0 = first stored row; we do not flip). FMF factorises all channels
//! together (U rows interleave the channel fastest: `row = (view · nL + light) · 3 + c`, one shared
//! S·V); DFMF factorises each decorrelated channel separately and stores a colour model (YUV
//! variants, PCA with mean and matrix, YCoCg, log encodings) that is inverted on decode. The
//! transposed variant ("images stacked", U rows = texels) is accepted too. Scalars are f16, f32 or
//! f64. After the colour model (and FMF's log dynamic-range reduction), values are multiplied by
//! the header's per-channel RGB scale, by cos θ_l when the cosine flag is 0 (the data then lack
//! the cosine), and clamped at 0 (factorisation ringing can go slightly negative).

use super::{BtfSource, DirectionSet, RawBtf, StoredEncoding};
use crate::io::bytes::Reader;
use crate::{Error, Result};
use half::f16;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// How the byte reader names this data in errors.
const KIND: &str = "UBO2014 .btf";

/// Offset the Bonn tools add before taking logarithms (btflib's default `drr_eps`).
const DRR_EPS: f32 = 1e-5;
/// Upper bound on channel counts and name lengths accepted from a header.
const MAX_CHANNELS: u32 = 64;

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
    /// 3: PCA colour space: rgb = v · M + mean (M stored column-major).
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

    fn from_code(code: i32, mean: [f32; 3], matrix: [f32; 9]) -> Option<Self> {
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
    fn decode(self, v: [f32; 3]) -> [f32; 3] {
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
            ColorModel::Pca { mean, matrix: m } => std::array::from_fn(|j| {
                v[0] * m[3 * j] + v[1] * m[3 * j + 1] + v[2] * m[3 * j + 2] + mean[j]
            }),
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
    /// Per-channel scale applied on decode.
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
fn angles_deg(theta: f32, phi: f32) -> (f32, f32) {
    let deg = |r: f32| ((r as f64).to_degrees() * 1e4).round() / 1e4;
    (deg(theta) as f32, deg(phi).rem_euclid(360.0) as f32)
}

fn parse_common(
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
fn parse_header(path: &Path, bytes: &[u8]) -> Result<(Ubo2014Header, usize)> {
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

/// A factor matrix, row-major `rows × k` (f32).
#[derive(Clone, Debug)]
struct Matrix {
    k: usize,
    data: Vec<f32>,
}

impl Matrix {
    #[inline]
    fn row(&self, i: usize) -> &[f32] {
        &self.data[i * self.k..(i + 1) * self.k]
    }
}

/// Splits a matrix whose rows interleave `c` channels (channel fastest) into `c` matrices.
fn deinterleave(m: &Matrix, c: usize) -> Vec<Matrix> {
    let rows = m.data.len() / m.k / c;
    (0..c)
        .map(|ch| Matrix {
            k: m.k,
            data: (0..rows)
                .flat_map(|r| m.row(r * c + ch).iter().copied())
                .collect(),
        })
        .collect()
}

/// An opened UBO2014 `.btf`: header plus factor matrices in memory; views are decoded on demand.
#[derive(Clone, Debug)]
pub struct Ubo2014Btf {
    path: PathBuf,
    header: Ubo2014Header,
    /// Per channel: the (view, light) factor, rows `view · nL + light`.
    angular: [Matrix; 3],
    /// Per channel: the texel factor, rows `y · width + x`.
    spatial: [Matrix; 3],
    color: ColorModel,
    /// FMF log dynamic-range reduction: decode with exp(v) − ε.
    drr: bool,
}

fn dot(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0.0f32; 8];
    let (ac, ar) = a.split_at(a.len() / 8 * 8);
    let (bc, br) = b.split_at(ac.len());
    for (x, y) in ac.chunks_exact(8).zip(bc.chunks_exact(8)) {
        for i in 0..8 {
            acc[i] += x[i] * y[i];
        }
    }
    let tail: f32 = ar.iter().zip(br).map(|(x, y)| x * y).sum();
    acc.iter().sum::<f32>() + tail
}

impl Ubo2014Btf {
    /// Reads and validates a `.btf` file (header, matrix sizes bounded by the file length).
    pub fn open(path: &Path) -> Result<Self> {
        let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        // SAFETY: read-only map, only read during this call; the factors are copied out.
        let map = unsafe { memmap2::Mmap::map(&file) }.map_err(|e| Error::io(path, e))?;
        Self::parse(path, &map)
    }

    fn parse(path: &Path, bytes: &[u8]) -> Result<Self> {
        let (header, pos) = parse_header(path, bytes)?;
        let mut r = Reader::new(bytes, path, KIND);
        r.seek(pos)?;
        let nc = header.channels.len();
        if nc != 3 {
            return Err(r.err(format!(
                "{nc} channels ({}): only RGB BTFs are supported",
                header.channels.join(",")
            )));
        }
        let n_lv = (header.views.len() * header.lights.len()) as u64;
        let n_xy = (header.width * header.height) as u64;
        let scalar_ok = |r: &Reader, s: u8| {
            if matches!(s, 2 | 4 | 8) {
                Ok(())
            } else {
                Err(r.err(format!("unsupported scalar size {s} (expected 2, 4 or 8)")))
            }
        };
        let (angular, spatial, color, drr) = match header.kind {
            PayloadKind::Fmf { extended } => {
                let mut drr = false;
                if extended {
                    let hv = r.u8("FMF header version")?;
                    if hv >= 1 {
                        drr = r.u32("dynamic range reduction")? != 0;
                    }
                    if hv >= 2 {
                        let (w, h) = (r.u32("height map width")?, r.u32("height map height")?);
                        r.take_n(w as u64 * h as u64, 2, "height map")?;
                    }
                    if hv >= 3 {
                        return Err(r.err(format!("unsupported FMF header version {hv}")));
                    }
                }
                let _k_file = r.u32("component count")?;
                let scalar = r.u8("scalar size")?;
                scalar_ok(&r, scalar)?;
                let k = r.u32("component count")? as u64;
                let rows = r.u32("row count")? as u64;
                let cols = r.u32("column count")? as u64;
                if k == 0 {
                    return Err(r.err("zero components"));
                }
                r.scalars(k, scalar, "singular values")?;
                let u = Matrix {
                    k: k as usize,
                    data: r.scalars(rows * k, scalar, "U matrix")?,
                };
                let sxv = Matrix {
                    k: k as usize,
                    data: r.scalars(cols * k, scalar, "S·V matrix")?,
                };
                let (ang, spa) = if rows == 3 * n_lv && cols == n_xy {
                    let a = deinterleave(&u, 3);
                    (a, vec![sxv.clone(), sxv.clone(), sxv])
                } else if rows == 3 * n_xy && cols == n_lv {
                    let s = deinterleave(&u, 3);
                    (vec![sxv.clone(), sxv.clone(), sxv], s)
                } else {
                    return Err(r.err(format!(
                        "matrix is {rows} × {cols}, expected {} × {n_xy} (3 channels × {} views × {} lights, {}×{} texels)",
                        3 * n_lv,
                        header.views.len(),
                        header.lights.len(),
                        header.width,
                        header.height
                    )));
                };
                (ang, spa, ColorModel::Rgb, drr)
            }
            PayloadKind::Dfmf => {
                let _k_max = r.u32("component count")?;
                let code = r.u32("colour model")? as i32;
                let mean = [
                    r.f32("colour mean")?,
                    r.f32("colour mean")?,
                    r.f32("colour mean")?,
                ];
                let mut matrix = [0.0f32; 9];
                for m in &mut matrix {
                    *m = r.f32("colour matrix")?;
                }
                let Some(color) = ColorModel::from_code(code, mean, matrix) else {
                    return Err(r.err(format!("unsupported DFMF colour model {code}")));
                };
                let mut ang = Vec::new();
                let mut spa = Vec::new();
                for c in 0..3 {
                    let scalar = r.u8("scalar size")?;
                    scalar_ok(&r, scalar)?;
                    let k = r.u32("component count")? as u64;
                    let rows = r.u32("row count")? as u64;
                    let cols = r.u32("column count")? as u64;
                    if k == 0 {
                        return Err(r.err(format!("channel {c}: zero components")));
                    }
                    if !((rows == n_lv && cols == n_xy) || (rows == n_xy && cols == n_lv)) {
                        return Err(r.err(format!(
                            "channel {c}: matrix is {rows} × {cols}, expected {n_lv} × {n_xy}"
                        )));
                    }
                    r.scalars(k, scalar, "singular values")?;
                    let u = Matrix {
                        k: k as usize,
                        data: r.scalars(rows * k, scalar, "U matrix")?,
                    };
                    let sxv = Matrix {
                        k: k as usize,
                        data: r.scalars(cols * k, scalar, "S·V matrix")?,
                    };
                    if rows == n_lv {
                        ang.push(u);
                        spa.push(sxv);
                    } else {
                        ang.push(sxv);
                        spa.push(u);
                    }
                }
                (ang, spa, color, false)
            }
        };
        if r.remaining() != 0 {
            return Err(r.err(format!("{} unexpected trailing bytes", r.remaining())));
        }
        let to3 = |v: Vec<Matrix>| -> Result<[Matrix; 3]> {
            v.try_into()
                .map_err(|_| Error::format(path, "internal: expected 3 channel matrices"))
        };
        Ok(Ubo2014Btf {
            path: path.to_path_buf(),
            header,
            angular: to3(angular)?,
            spatial: to3(spatial)?,
            color,
            drr,
        })
    }

    /// The parsed header.
    pub fn header(&self) -> &Ubo2014Header {
        &self.header
    }

    /// The DFMF colour model (RGB for FMF).
    pub fn color_model(&self) -> ColorModel {
        self.color
    }

    /// Decodes view `view` into `out` (`[light][row][col][rgb]`).
    fn decode_view_into(&self, view: usize, out: &mut [f32]) {
        // Lights per task and texels per block: a block of S·V rows (≤ 256 · k scalars) stays in
        // cache while it is reused for every light of the group and every channel.
        const LIGHTS_PER_TASK: usize = 8;
        const TEXEL_BLOCK: usize = 256;
        let h = &self.header;
        let nl = h.lights.len();
        let n_xy = h.width * h.height;
        out.par_chunks_mut(3 * n_xy * LIGHTS_PER_TASK)
            .enumerate()
            .for_each(|(task, imgs)| {
                let l0 = task * LIGHTS_PER_TASK;
                for start in (0..n_xy).step_by(TEXEL_BLOCK) {
                    let end = (start + TEXEL_BLOCK).min(n_xy);
                    for (li, img) in imgs.chunks_exact_mut(3 * n_xy).enumerate() {
                        let row = view * nl + l0 + li;
                        for c in 0..3 {
                            let a = self.angular[c].row(row);
                            let s = &self.spatial[c];
                            for xy in start..end {
                                img[3 * xy + c] = dot(a, s.row(xy));
                            }
                        }
                    }
                }
                for (li, img) in imgs.chunks_exact_mut(3 * n_xy).enumerate() {
                    let cos = h.lights.dirs[l0 + li].z.max(0.0);
                    let factor = h
                        .rgb_scale
                        .map(|s| if h.cosine_flag == 0 { s * cos } else { s });
                    for px in img.chunks_exact_mut(3) {
                        let mut v = self.color.decode([px[0], px[1], px[2]]);
                        if self.drr {
                            v = v.map(|x| x.exp() - DRR_EPS);
                        }
                        for c in 0..3 {
                            let x = v[c] * factor[c];
                            px[c] = if x > 0.0 { x } else { 0.0 };
                        }
                    }
                }
            });
    }

    /// Decodes every view into an in-memory [`RawBtf`] (f16). Fails cleanly if memory is short.
    pub fn load(&self) -> Result<RawBtf> {
        let h = &self.header;
        let per_view = h.lights.len() * h.width * h.height * 3;
        let total = per_view * h.views.len();
        let mut data: Vec<f16> = Vec::new();
        data.try_reserve_exact(total).map_err(|_| {
            Error::format(
                &self.path,
                format!(
                    "not enough memory to decode the whole BTF ({} GB as f16)",
                    total as f64 * 2e-9
                ),
            )
        })?;
        let mut buf = vec![0.0f32; per_view];
        for v in 0..h.views.len() {
            self.decode_view_into(v, &mut buf);
            data.extend(buf.iter().map(|&x| f16::from_f32(x)));
        }
        RawBtf::from_f16(
            h.views.clone(),
            h.lights.clone(),
            h.width,
            h.height,
            StoredEncoding::Linear,
            data,
        )
    }
}

impl BtfSource for Ubo2014Btf {
    fn views(&self) -> &DirectionSet {
        &self.header.views
    }
    fn lights(&self) -> &DirectionSet {
        &self.header.lights
    }
    fn width(&self) -> usize {
        self.header.width
    }
    fn height(&self) -> usize {
        self.header.height
    }
    fn encoding(&self) -> StoredEncoding {
        StoredEncoding::Linear
    }
    fn load_view(&self, view: usize) -> Result<Vec<f32>> {
        let h = &self.header;
        if view >= h.views.len() {
            return Err(Error::format(
                &self.path,
                format!("view {view} out of range ({} views)", h.views.len()),
            ));
        }
        let mut out = vec![0.0f32; h.lights.len() * h.width * h.height * 3];
        self.decode_view_into(view, &mut out);
        Ok(out)
    }
}

/// Opens a `.btf` for per-view decoding.
pub fn open_btf(path: &Path) -> Result<Ubo2014Btf> {
    Ubo2014Btf::open(path)
}

/// Loads and fully decodes a `.btf`.
pub fn load_btf(path: &Path) -> Result<RawBtf> {
    Ubo2014Btf::open(path)?.load()
}

/// Everything needed to write a factorised `.btf` (used to make test data and for interchange).
/// Matrices are row-major with `components` columns, in the "ABRDFs stacked" orientation.
#[derive(Clone, Debug)]
pub struct FactorisedBtf {
    /// Payload kind (FMF or DFMF).
    pub kind: PayloadKind,
    /// DFMF colour model (ignored for FMF).
    pub color: ColorModel,
    /// FMF extended header: dynamic range reduction flag (log encoding).
    pub drr: bool,
    /// Header version to write (1–4).
    pub version: u32,
    /// 1 = values include cos θ_l.
    pub cosine_flag: u32,
    /// Per-channel scale.
    pub rgb_scale: [f32; 3],
    /// Write the `R` flag and an (identity) rotation table.
    pub rotations: bool,
    /// 2 (f16), 4 (f32) or 8 (f64).
    pub scalar_size: u8,
    /// View directions (degrees; written as radians).
    pub views: DirectionSet,
    /// Light directions, the same for every view.
    pub lights: DirectionSet,
    /// Texels per row.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// FMF: one matrix (3 · nV · nL rows, channel fastest); DFMF: one per channel (nV · nL rows).
    pub u: Vec<Vec<f64>>,
    /// FMF: one matrix (W · H rows); DFMF: one per channel.
    pub sxv: Vec<Vec<f64>>,
    /// Columns of each U / S·V pair.
    pub components: Vec<usize>,
}

impl FactorisedBtf {
    /// Serialises to the UBO2014 byte layout.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::new();
        let sig = match self.kind {
            PayloadKind::Dfmf => "!DFMF08FC",
            PayloadKind::Fmf { extended: true } => "!FMF12FCE",
            PayloadKind::Fmf { extended: false } => "!FMF06FC",
        };
        b.extend_from_slice(sig.as_bytes());
        if self.rotations {
            b.push(b'R');
        }
        let u32le = |b: &mut Vec<u8>, v: u32| b.extend_from_slice(&v.to_le_bytes());
        let f32le = |b: &mut Vec<u8>, v: f32| b.extend_from_slice(&v.to_le_bytes());
        let mut head = Vec::new();
        u32le(&mut head, 0); // size, patched below
        u32le(&mut head, self.version);
        for text in ["btfpt test setup", "synthetic sensor", "synthetic light"] {
            let mut field = [0u8; 80];
            field[..text.len()].copy_from_slice(text.as_bytes());
            head.extend_from_slice(&field);
        }
        f32le(&mut head, 10.0);
        for s in self.rgb_scale {
            f32le(&mut head, s);
        }
        if self.version > 1 {
            u32le(&mut head, self.cosine_flag);
        }
        if self.version > 2 {
            let xml = b"<btf/>";
            u32le(&mut head, xml.len() as u32);
            head.extend_from_slice(xml);
        }
        if self.version > 3 {
            u32le(&mut head, 3);
            for n in ["R", "G", "B"] {
                u32le(&mut head, n.len() as u32);
                head.extend_from_slice(n.as_bytes());
            }
        }
        let size = head.len() as u32;
        head[0..4].copy_from_slice(&size.to_le_bytes());
        b.extend_from_slice(&head);
        let rad = |(t, p): (f32, f32)| (t.to_radians(), p.to_radians());
        u32le(&mut b, self.views.len() as u32);
        for &v in &self.views.angles_deg {
            let (t, p) = rad(v);
            f32le(&mut b, t);
            f32le(&mut b, p);
            u32le(&mut b, self.lights.len() as u32);
            for &l in &self.lights.angles_deg {
                let (t, p) = rad(l);
                f32le(&mut b, t);
                f32le(&mut b, p);
            }
        }
        u32le(&mut b, self.width as u32);
        u32le(&mut b, self.height as u32);
        if self.rotations {
            u32le(&mut b, 1);
            for x in [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0] {
                f32le(&mut b, x);
            }
        }
        let scalar = |b: &mut Vec<u8>, x: f64| match self.scalar_size {
            2 => b.extend_from_slice(&f16::from_f64(x).to_le_bytes()),
            4 => b.extend_from_slice(&(x as f32).to_le_bytes()),
            _ => b.extend_from_slice(&x.to_le_bytes()),
        };
        let matrices = |b: &mut Vec<u8>, i: usize| {
            let k = self.components[i];
            u32le(b, k as u32);
            u32le(b, (self.u[i].len() / k) as u32);
            u32le(b, (self.sxv[i].len() / k) as u32);
            for j in 0..k {
                scalar(b, 1.0 + j as f64); // singular values: unused on decode
            }
            for &x in self.u[i].iter().chain(&self.sxv[i]) {
                scalar(b, x);
            }
        };
        match self.kind {
            PayloadKind::Fmf { extended } => {
                if extended {
                    b.push(1); // header version 1: DRR flag only
                    u32le(&mut b, self.drr as u32);
                }
                u32le(&mut b, self.components[0] as u32);
                b.push(self.scalar_size);
                matrices(&mut b, 0);
            }
            PayloadKind::Dfmf => {
                u32le(
                    &mut b,
                    self.components.iter().copied().max().unwrap_or(0) as u32,
                );
                u32le(&mut b, self.color.code() as u32);
                let (mean, m) = match self.color {
                    ColorModel::Pca { mean, matrix } => (mean, matrix),
                    _ => ([0.0; 3], [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]),
                };
                for x in mean.iter().chain(&m) {
                    f32le(&mut b, *x);
                }
                for c in 0..3 {
                    b.push(self.scalar_size);
                    matrices(&mut b, c);
                }
            }
        }
        b
    }

    /// Writes the file atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        let bytes = self.to_bytes();
        crate::io::write_atomic(path, |w| {
            w.write_all(&bytes).map_err(|e| Error::io(path, e))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic small values exactly representable in f16 (multiples of 1/64 in [-1, 1]).
    fn vals(n: usize, seed: u64) -> Vec<f64> {
        let mut s = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (0..n)
            .map(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((s >> 40) % 129) as f64 / 64.0 - 1.0
            })
            .collect()
    }

    fn dirs() -> (DirectionSet, DirectionSet) {
        (
            DirectionSet::from_angles_deg(vec![(0.0, 0.0), (30.0, 90.0)]),
            DirectionSet::from_angles_deg(vec![(0.0, 0.0), (45.0, 0.0), (60.0, 270.0)]),
        )
    }

    fn fmf(
        scalar_size: u8,
        cosine_flag: u32,
        extended: bool,
        rotations: bool,
        version: u32,
    ) -> FactorisedBtf {
        let (views, lights) = dirs();
        let (w, h, k) = (3, 2, 5);
        let n_lv = views.len() * lights.len();
        FactorisedBtf {
            kind: PayloadKind::Fmf { extended },
            color: ColorModel::Rgb,
            drr: false,
            version,
            cosine_flag,
            rgb_scale: [1.0, 0.5, 2.0],
            rotations,
            scalar_size,
            views,
            lights,
            width: w,
            height: h,
            u: vec![vals(3 * n_lv * k, 1)],
            sxv: vec![vals(w * h * k, 2)],
            components: vec![k],
        }
    }

    /// The value the spec says texel (x, y) of channel c has, computed directly from the factors.
    fn expected(f: &FactorisedBtf, view: usize, light: usize, x: usize, y: usize) -> [f32; 3] {
        let nl = f.lights.len();
        let xy = y * f.width + x;
        let raw: [f64; 3] = std::array::from_fn(|c| {
            let (ui, row) = match f.kind {
                PayloadKind::Fmf { .. } => (0, (view * nl + light) * 3 + c),
                PayloadKind::Dfmf => (c, view * nl + light),
            };
            let k = f.components[ui];
            let si = if matches!(f.kind, PayloadKind::Fmf { .. }) {
                0
            } else {
                c
            };
            (0..k)
                .map(|j| f.u[ui][row * k + j] * f.sxv[si][xy * k + j])
                .sum()
        });
        let raw = raw.map(|v| v as f32);
        let rgb = match f.kind {
            PayloadKind::Dfmf => f.color.decode(raw),
            _ => raw,
        };
        let cos = f.lights.dirs[light].z;
        std::array::from_fn(|c| {
            let mut v = if f.drr {
                rgb[c].exp() - DRR_EPS
            } else {
                rgb[c]
            } * f.rgb_scale[c];
            // Version 1 headers carry no cosine flag: the reader then assumes 0.
            if f.cosine_flag == 0 || f.version < 2 {
                v *= cos;
            }
            v.max(0.0)
        })
    }

    fn check_all(f: &FactorisedBtf, btf: &RawBtf, tol: f32) {
        let mut nonzero = 0;
        for v in 0..f.views.len() {
            for l in 0..f.lights.len() {
                for y in 0..f.height {
                    for x in 0..f.width {
                        let e = expected(f, v, l, x, y);
                        let g = btf.texel(v, l, x, y);
                        for c in 0..3 {
                            // f16 storage of the decoded value: relative 2^-11.
                            let bound = tol + e[c].abs() * 1.0e-3;
                            assert!(
                                (e[c] - g[c]).abs() <= bound,
                                "v{v} l{l} ({x},{y}) c{c}: {} vs {}",
                                e[c],
                                g[c]
                            );
                            nonzero += (e[c] > 0.0) as usize;
                        }
                    }
                }
            }
        }
        assert!(nonzero > 10, "test data should not decode to all zeros");
    }

    #[test]
    fn fmf_round_trips_for_every_scalar_size_and_header_variant() {
        let dir = tempfile::tempdir().unwrap();
        for (i, (s, cos, ext, rot, ver)) in [
            (2u8, 0u32, true, true, 4u32),
            (4, 1, false, false, 1),
            (8, 0, false, true, 3),
            (2, 1, true, false, 2),
        ]
        .into_iter()
        .enumerate()
        {
            let f = fmf(s, cos, ext, rot, ver);
            let p = dir.path().join(format!("t{i}.btf"));
            f.write(&p).unwrap();
            let btf = load_btf(&p).unwrap();
            assert_eq!(btf.views(), &f.views);
            assert_eq!(btf.lights().len(), 3);
            assert!((btf.lights().angles_deg[2].1 - 270.0).abs() < 1e-3);
            check_all(&f, &btf, 1e-5);
            let src = open_btf(&p).unwrap();
            assert_eq!(src.header().cosine_flag, if ver > 1 { cos } else { 0 });
        }
    }

    #[test]
    fn decoding_spans_several_light_groups_and_texel_blocks() {
        // 10 lights (> 8 per task) and 20 × 15 = 300 texels (> one 256-texel block).
        let dir = tempfile::tempdir().unwrap();
        let mut f = fmf(4, 0, false, false, 2);
        f.lights = DirectionSet::from_rings(&[(0.0, 1, 0.0), (40.0, 9, 5.0)]);
        (f.width, f.height) = (20, 15);
        let n_lv = f.views.len() * f.lights.len();
        f.u = vec![vals(3 * n_lv * 5, 3)];
        f.sxv = vec![vals(300 * 5, 4)];
        let p = dir.path().join("big.btf");
        f.write(&p).unwrap();
        check_all(&f, &load_btf(&p).unwrap(), 1e-5);
    }

    #[test]
    fn fmf_dynamic_range_reduction_is_inverted() {
        let dir = tempfile::tempdir().unwrap();
        let mut f = fmf(4, 1, true, false, 4);
        f.drr = true;
        let p = dir.path().join("drr.btf");
        f.write(&p).unwrap();
        check_all(&f, &load_btf(&p).unwrap(), 1e-5);
    }

    #[test]
    fn dfmf_inverts_every_colour_model() {
        let dir = tempfile::tempdir().unwrap();
        let (views, lights) = dirs();
        let (w, h) = (2, 3);
        let n_lv = views.len() * lights.len();
        let ks = vec![4, 2, 3];
        let pca = ColorModel::Pca {
            mean: [0.25, 0.5, 0.125],
            matrix: [0.5, 0.25, 0.0, 0.125, 1.0, 0.0, 0.0, 0.5, 0.75],
        };
        for color in [
            ColorModel::Rgb,
            ColorModel::Yuv,
            pca,
            ColorModel::YCoCg,
            ColorModel::YlogUv,
            ColorModel::YlogUlogVlog,
            ColorModel::YlogUdivYVdivY,
            ColorModel::LogRgb,
        ] {
            let f = FactorisedBtf {
                kind: PayloadKind::Dfmf,
                color,
                drr: false,
                version: 4,
                cosine_flag: 0,
                rgb_scale: [1.0, 1.0, 1.0],
                rotations: true,
                scalar_size: 2,
                views: views.clone(),
                lights: lights.clone(),
                width: w,
                height: h,
                u: ks
                    .iter()
                    .enumerate()
                    .map(|(c, &k)| vals(n_lv * k, 10 + c as u64))
                    .collect(),
                sxv: ks
                    .iter()
                    .enumerate()
                    .map(|(c, &k)| vals(w * h * k, 20 + c as u64))
                    .collect(),
                components: ks.clone(),
            };
            let p = dir.path().join(format!("dfmf{}.btf", color.code()));
            f.write(&p).unwrap();
            check_all(&f, &load_btf(&p).unwrap(), 1e-4);
        }
        // YUV inverse against a hand-computed value: Y = 0.5, U = 0.1, V = -0.2.
        let rgb = ColorModel::Yuv.decode([0.5, 0.1, -0.2]);
        assert!((rgb[0] - (0.5 - 0.2 * 1.13983)).abs() < 1e-6);
        assert!((rgb[1] - (0.5 - 0.039465 + 0.11612)).abs() < 1e-6);
        assert!((rgb[2] - (0.5 + 0.203211)).abs() < 1e-6);
    }

    #[test]
    fn transposed_images_stacked_payloads_decode() {
        // U rows = texels, S·V rows = (view, light): FMF with channel-interleaved texel rows, and
        // DFMF per channel. The writer stores whatever matrices it is given.
        let dir = tempfile::tempdir().unwrap();
        let (views, lights) = dirs();
        let (w, h, k) = (4usize, 2usize, 3usize);
        let (nl, n_lv, n_xy) = (lights.len(), views.len() * lights.len(), w * h);
        for kind in [PayloadKind::Fmf { extended: false }, PayloadKind::Dfmf] {
            let fmf = matches!(kind, PayloadKind::Fmf { .. });
            let (u, sxv) = if fmf {
                (vec![vals(3 * n_xy * k, 5)], vec![vals(n_lv * k, 6)])
            } else {
                let u = (0..3).map(|c| vals(n_xy * k, 7 + c)).collect();
                (u, (0..3).map(|c| vals(n_lv * k, 17 + c)).collect())
            };
            let f = FactorisedBtf {
                kind,
                color: ColorModel::Rgb,
                drr: false,
                version: 2,
                cosine_flag: 1,
                rgb_scale: [1.0; 3],
                rotations: false,
                scalar_size: 4,
                views: views.clone(),
                lights: lights.clone(),
                width: w,
                height: h,
                components: vec![k; if fmf { 1 } else { 3 }],
                u,
                sxv,
            };
            let p = dir.path().join("t.btf");
            f.write(&p).unwrap();
            let btf = load_btf(&p).unwrap();
            for (v, l, x, y) in [(0, 0, 0, 0), (1, 2, 3, 1), (1, 1, 2, 0), (0, 2, 1, 1)] {
                let xy = y * w + x;
                let lv = v * nl + l;
                for c in 0..3 {
                    let (ui, urow, si) = if fmf { (0, xy * 3 + c, 0) } else { (c, xy, c) };
                    let want: f64 = (0..k)
                        .map(|j| f.u[ui][urow * k + j] * f.sxv[si][lv * k + j])
                        .sum();
                    let got = btf.texel(v, l, x, y)[c];
                    let want = want.max(0.0) as f32;
                    assert!(
                        (got - want).abs() <= 1e-5 + want * 1e-3,
                        "{kind:?}: {got} vs {want}"
                    );
                }
            }
        }
    }

    #[test]
    fn colour_models_follow_the_btflib_formulas() {
        // Hand-evaluated inverses (btflib `undecorrelate`), independent of `to_rgb`'s code paths.
        let close = |a: [f32; 3], b: [f32; 3]| a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-5);
        assert!(close(
            ColorModel::YCoCg.decode([0.5, 0.1, 0.2]),
            [0.4, 0.7, 0.2]
        ));
        let pca = ColorModel::Pca {
            mean: [1.0, 2.0, 3.0],
            // Column-major M: rgb_j = Σ_i v_i M(i, j) + mean_j; M(0,1) = 2 is file element 3.
            matrix: [1.0, 0.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        };
        assert!(close(pca.decode([1.0, 1.0, 1.0]), [2.0, 5.0, 4.0]));
        let y = (0.5f32).ln();
        // Y = exp(ln 0.5) − ε, U = 0.2 · (Y + ε) = 0.1, V = −0.4 · 0.5 = −0.2.
        let got = ColorModel::YlogUdivYVdivY.decode([y, 0.2, -0.4]);
        let yy = 0.5 - DRR_EPS;
        let want = [yy - 0.2 * 1.13983, yy - 0.039465 + 0.11612, yy + 0.203211];
        assert!(close(got, want), "{got:?}");
        assert!(close(
            ColorModel::LogRgb.decode([0.0, y, 0.0]),
            [1.0 - DRR_EPS, 0.5 - DRR_EPS, 1.0 - DRR_EPS]
        ));
    }

    #[test]
    fn truncated_and_corrupt_files_are_clear_errors() {
        let dir = tempfile::tempdir().unwrap();
        let good = fmf(2, 0, true, true, 4).to_bytes();
        let p = dir.path().join("bad.btf");
        let err = |bytes: &[u8]| {
            std::fs::write(&p, bytes).unwrap();
            let e = load_btf(&p).unwrap_err().to_string();
            assert!(e.contains("bad.btf"), "{e}");
            e
        };
        // Every truncation point fails cleanly (never panics).
        for cut in (0..good.len()).step_by(7) {
            err(&good[..cut]);
        }
        assert!(err(&good[..good.len() - 1]).contains("truncated"));
        let mut long = good.clone();
        long.extend_from_slice(&[0; 3]);
        assert!(err(&long).contains("trailing"));
        assert!(err(b"!PVF06FC and so on").contains("not supported"));
        assert!(err(b"GIF89a").contains("not a UBO2014"));
        // Absurd view count: refused from the file length, no huge allocation.
        let sig = "!FMF12FCER".len();
        let size = u32::from_le_bytes(good[sig..sig + 4].try_into().unwrap()) as usize;
        let mut huge = good.clone();
        huge[sig + size..sig + size + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(err(&huge).contains("view count"));
        // Wrong header size field.
        let mut hs = good.clone();
        hs[sig] ^= 1;
        err(&hs);
        // Random byte flips anywhere never panic.
        for i in (0..good.len()).step_by(13) {
            let mut b = good.clone();
            b[i] ^= 0xA5;
            std::fs::write(&p, &b).unwrap();
            let _ = load_btf(&p);
        }
    }
}
