//! Writing factorised UBO2014 `.btf` files from given factors: the test data of the reader and of
//! the bad-input tests. No command writes `.btf` (that needs a factorisation of the measured
//! data, which btfpt does not compute; `convert` writes `.btfc` or UBO2003 folders).

use super::{ColorModel, PayloadKind};
use crate::btf::DirectionSet;
use crate::{Error, Result};
use half::f16;
use std::path::Path;

/// Everything needed to write a factorised `.btf` from its factors (test data). A PCA colour
/// model's matrix is written row by row, as btflib writes it.
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
    /// Per-channel scale of the header (readers report it, none applies it).
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
