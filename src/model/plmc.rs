//! The fitted model in memory (LM, PLM or PLM-C), exactly as stored in a `.plmc` file, and its
//! reconstruction at the measured directions.
//!
//! A reconstruction is `max(0, Σ_j a_j Y^j)` with `Y = ρ·max(0, D·u)^n` (LM: the polynomial is the
//! identity), in the model's [`ValueSpace`]: linear cosine-baked RGB (docs/conventions.md), or the sRGB
//! encoding for models fitted to 8-bit data in their stored encoding (then decoded with the sRGB
//! EOTF to give the BTF value).

use super::lobe::{self, Lobe, PackedLobe};
use super::polynomial::{self, Poly};
use super::{ModelKind, ValueSpace};
use crate::btf::DirectionSet;
use crate::{Error, Result};

/// The lobe parameters of one view.
#[derive(Clone, Debug, PartialEq)]
pub enum ViewParams {
    /// One lobe per texel and channel, `[texel][channel]`, texel = row · width + column.
    Texel(Vec<PackedLobe>),
    /// `k` lobes per channel `[cluster][channel]` and a cluster index per texel and channel
    /// `[texel][channel]` (indices < k).
    Clustered {
        k: usize,
        table: Vec<PackedLobe>,
        index: Vec<u16>,
    },
}

impl ViewParams {
    /// The lobe of texel `t`, channel `c`, packed.
    #[inline]
    pub fn packed(&self, t: usize, c: usize) -> PackedLobe {
        match self {
            ViewParams::Texel(l) => l[3 * t + c],
            ViewParams::Clustered { table, index, .. } => table[3 * index[3 * t + c] as usize + c],
        }
    }
}

/// A fitted model: LM, PLM or PLM-C for every measured view.
#[derive(Clone, Debug, PartialEq)]
pub struct PlmcModel {
    pub kind: ModelKind,
    pub views: DirectionSet,
    pub lights: DirectionSet,
    /// Texels per row of the parameter planes (= tile width).
    pub width: usize,
    /// Rows of the parameter planes (= tile height).
    pub height: usize,
    /// Requested clusters per view and channel (PLM-C), 0 otherwise.
    pub clusters: usize,
    /// Space of the model's values.
    pub space: ValueSpace,
    /// One entry per view.
    pub params: Vec<ViewParams>,
    /// `[view][light][channel]` coefficients a_0..a_4; empty for LM.
    pub polys: Vec<Poly>,
}

impl PlmcModel {
    /// The polynomial of (view, light, channel); the identity for LM.
    #[inline]
    pub fn poly(&self, view: usize, light: usize, channel: usize) -> Poly {
        if self.polys.is_empty() {
            polynomial::IDENTITY
        } else {
            self.polys[(view * self.lights.len() + light) * 3 + channel]
        }
    }

    /// Checks that all tables have the sizes the header implies and indices are in range.
    pub fn validate(&self) -> Result<()> {
        let texels = self.width * self.height;
        let bad = |m: String| Err(Error::Invalid(format!("inconsistent PLM-C model: {m}")));
        if self.params.len() != self.views.len() {
            return bad(format!(
                "{} view tables for {} views",
                self.params.len(),
                self.views.len()
            ));
        }
        let want_polys = if self.kind.has_polys() {
            self.views.len() * self.lights.len() * 3
        } else {
            0
        };
        if self.polys.len() != want_polys {
            return bad(format!(
                "{} polynomials, expected {want_polys}",
                self.polys.len()
            ));
        }
        for (v, p) in self.params.iter().enumerate() {
            match (self.kind, p) {
                (ModelKind::PlmC, ViewParams::Clustered { k, table, index }) => {
                    if table.len() != 3 * k || index.len() != 3 * texels {
                        return bad(format!("view {v}: table/index sizes"));
                    }
                    if *k > self.clusters.max(1) || index.iter().any(|&i| i as usize >= *k) {
                        return bad(format!("view {v}: cluster index out of range"));
                    }
                }
                (ModelKind::Lm | ModelKind::Plm, ViewParams::Texel(l)) => {
                    if l.len() != 3 * texels {
                        return bad(format!("view {v}: {} lobes for {texels} texels", l.len()));
                    }
                }
                _ => {
                    return bad(format!(
                        "view {v}: parameter layout does not match the model kind"
                    ));
                }
            }
        }
        Ok(())
    }

    /// Reconstructs all images of `view` at the measured light directions into `out` as linear
    /// values `[light][texel][rgb]` (the layout of `BtfSource::load_view`).
    pub fn reconstruct_view(&self, view: usize, out: &mut Vec<f32>) {
        let texels = self.width * self.height;
        let nl = self.lights.len();
        out.clear();
        out.resize(nl * texels * 3, 0.0);
        let params = &self.params[view];
        match params {
            ViewParams::Clustered { k, table, index } => {
                let lobes: Vec<Lobe> = table.iter().map(|p| p.unpack()).collect();
                let mut vals = vec![0.0f32; 3 * k];
                for l in 0..nl {
                    let u = self.lights.dirs[l];
                    for c in 0..3 {
                        let a = self.poly(view, l, c);
                        for j in 0..*k {
                            vals[3 * j + c] = self
                                .space
                                .to_linear(polynomial::eval(&a, lobe::eval(&lobes[3 * j + c], u)));
                        }
                    }
                    let img = &mut out[l * texels * 3..(l + 1) * texels * 3];
                    for (o, (&i, c)) in img.iter_mut().zip(index.iter().zip((0..3).cycle())) {
                        *o = vals[3 * i as usize + c];
                    }
                }
            }
            ViewParams::Texel(packed) => {
                let lobes: Vec<Lobe> = packed.iter().map(|p| p.unpack()).collect();
                for l in 0..nl {
                    let u = self.lights.dirs[l];
                    let a = [
                        self.poly(view, l, 0),
                        self.poly(view, l, 1),
                        self.poly(view, l, 2),
                    ];
                    let img = &mut out[l * texels * 3..(l + 1) * texels * 3];
                    for (i, o) in img.iter_mut().enumerate() {
                        *o = self
                            .space
                            .to_linear(polynomial::eval(&a[i % 3], lobe::eval(&lobes[i], u)));
                    }
                }
            }
        }
    }
}
