//! Bonn UBO2014 `.btf` files: full-matrix-factorised payloads (FMF: `!FMF06FC`, `!FMF12FCE`;
//! DFMF: `!DFMF08FC`; each optionally followed by `R` = rotations in the header), decoded one view
//! at a time into linear, cosine-baked RGB (docs/conventions.md, docs/formats.md).
//!
//! Payload layout (as documented by the public `btf.hh` of zeroeffects/btf and Bonn's btflib):
//! the BTF matrix of one channel is U · (S·V)ᵀ. With "ABRDFs stacked" (the usual case) U has
//! one row per (view, light) pair, `row = view · nL + light`, and S·V one row per texel,
//! `row = y · width + x` (row 0 = first stored row; we do not flip). FMF factorises all channels
//! together (U rows interleave the channel fastest: `row = (view · nL + light) · 3 + c`, one shared
//! S·V); DFMF factorises each decorrelated channel separately and stores a colour model (YUV
//! variants, PCA with mean and matrix, YCoCg, log encodings) that is inverted on decode exactly as
//! btflib's `undecorrelate` does (PCA: rgb = v · M + mean, M stored row by row). The transposed
//! variant ("images stacked", U rows = texels) is accepted too. Scalars are f16, f32 or f64.
//! After the colour model (and FMF's log dynamic-range reduction), values are multiplied by
//! cos θ_l when the cosine flag is 0 (the data then lack the cosine) and clamped at 0
//! (factorisation ringing can go slightly negative). The header's per-channel RGB scale is not
//! applied, as in the reference readers (btflib reads it and never uses it, `btf.hh` skips it);
//! `btfpt info` shows it.
//!
//! Files: `header.rs` (the header and what it announces), `writer.rs` (writing factorised files,
//! for test data and interchange), this file (decoding the payload one view at a time).

mod header;
#[cfg(test)]
mod tests;
mod writer;

pub use header::{ColorModel, PayloadKind, Ubo2014Header};
pub use writer::FactorisedBtf;

use crate::btf::{BtfSource, DirectionSet, RawBtf, StoredEncoding};
use crate::io::bytes::Reader;
use crate::{Error, Result};
use half::f16;
use header::{DRR_EPS, KIND, parse_header};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

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
                    let factor = if h.cosine_flag == 0 { cos } else { 1.0 };
                    for px in img.chunks_exact_mut(3) {
                        let mut v = self.color.decode([px[0], px[1], px[2]]);
                        if self.drr {
                            v = v.map(|x| x.exp() - DRR_EPS);
                        }
                        for c in 0..3 {
                            let x = v[c] * factor;
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
