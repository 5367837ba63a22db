//! The fitted model in memory (LM, PLM or PLM-C), exactly as stored in a `.plmc` file, and its
//! reconstruction at the measured directions.
//!
//! A reconstruction is `max(0, Σ_j a_j Y^j)` with `Y = ρ·max(0, D·u)^n` (LM: the polynomial is the
//! identity), in the model's [`ValueSpace`]: linear cosine-baked RGB (DESIGN §2), or the sRGB
//! encoding for models fitted to 8-bit data in their stored encoding (then decoded with the sRGB
//! EOTF to give the BTF value).

use super::lafortune::{self, Lobe};
use super::polynomial::{self, Poly};
use crate::btf::DirectionSet;
use crate::{Error, Result};
use half::f16;

/// Which model a file holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelKind {
    /// Per-texel one-lobe Lafortune, per view.
    Lm,
    /// LM plus a degree-4 polynomial per (view, light, channel).
    Plm,
    /// Clustered PLM: per view and channel a table of K lobes and an index image.
    PlmC,
}

impl ModelKind {
    /// The code stored in the file header.
    pub fn code(self) -> u8 {
        match self {
            ModelKind::Lm => 0,
            ModelKind::Plm => 1,
            ModelKind::PlmC => 2,
        }
    }
    /// Inverse of [`ModelKind::code`].
    pub fn from_code(c: u8) -> Option<Self> {
        match c {
            0 => Some(ModelKind::Lm),
            1 => Some(ModelKind::Plm),
            2 => Some(ModelKind::PlmC),
            _ => None,
        }
    }
    /// Lower-case name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::Lm => "lm",
            ModelKind::Plm => "plm",
            ModelKind::PlmC => "plmc",
        }
    }
    /// True if the model carries per-image polynomials.
    pub fn has_polys(self) -> bool {
        self != ModelKind::Lm
    }
}

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

/// A lobe as stored (8 bytes): ρ and n as f16 bits, D octahedrally encoded in two u16.
///
/// f16 ρ/n have 11 significant bits (relative error ≤ 2.4e-4); the octahedral D has an angular
/// error ≤ ~3e-5 rad, ten times finer than three f16 components would give in 2 bytes less, which
/// matters for sharp lobes (a b^n with n = 100 amplifies a direction error 100×).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PackedLobe {
    pub rho: u16,
    pub oct: [u16; 2],
    pub n: u16,
}

impl PackedLobe {
    /// Quantises a lobe (D is normalised; ρ and n are clamped to the f16 range).
    pub fn pack(l: &Lobe) -> Self {
        let rho = if l[0].is_finite() {
            l[0].clamp(0.0, 65504.0)
        } else {
            0.0
        };
        let n = if l[4].is_finite() {
            l[4].clamp(0.0, 65504.0)
        } else {
            1.0
        };
        let (mut x, mut y, z) = (l[1], l[2], l[3]);
        let s = x.abs() + y.abs() + z.abs();
        let (ox, oy) = if s > 0.0 && s.is_finite() {
            x /= s;
            y /= s;
            if z / s < 0.0 {
                let (fx, fy) = (x, y);
                (
                    (1.0 - fy.abs()) * fx.signum(),
                    (1.0 - fx.abs()) * fy.signum(),
                )
            } else {
                (x, y)
            }
        } else {
            (0.0, 0.0)
        };
        let q = |v: f32| (((v.clamp(-1.0, 1.0) + 1.0) * 0.5 * 65535.0).round()) as u16;
        PackedLobe {
            rho: f16::from_f32(rho).to_bits(),
            oct: [q(ox), q(oy)],
            n: f16::from_f32(n).to_bits(),
        }
    }

    /// Decodes to `[ρ, Dx, Dy, Dz, n]` with |D| = 1.
    pub fn unpack(&self) -> Lobe {
        let d = |c: u16| c as f32 / 65535.0 * 2.0 - 1.0;
        let (mut x, mut y) = (d(self.oct[0]), d(self.oct[1]));
        let z = 1.0 - x.abs() - y.abs();
        if z < 0.0 {
            let (fx, fy) = (x, y);
            x = (1.0 - fy.abs()) * fx.signum();
            y = (1.0 - fx.abs()) * fy.signum();
        }
        let len = (x * x + y * y + z * z).sqrt();
        [
            f16::from_bits(self.rho).to_f32(),
            x / len,
            y / len,
            z / len,
            f16::from_bits(self.n).to_f32(),
        ]
    }

    /// True if ρ and n decode to finite, non-negative numbers.
    pub fn is_valid(&self) -> bool {
        let r = f16::from_bits(self.rho);
        let n = f16::from_bits(self.n);
        r.is_finite() && n.is_finite() && r.to_f32() >= 0.0 && n.to_f32() >= 0.0
    }
}

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
                            vals[3 * j + c] = self.space.to_linear(polynomial::eval(
                                &a,
                                lafortune::eval(&lobes[3 * j + c], u),
                            ));
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
                            .to_linear(polynomial::eval(&a[i % 3], lafortune::eval(&lobes[i], u)));
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Pcg32;

    #[test]
    fn packed_lobes_round_trip_within_quantisation() {
        let mut rng = Pcg32::new(1, 1);
        for _ in 0..2000 {
            let th = rng.next_f32() * 3.0;
            let ph = rng.next_f32() * std::f32::consts::TAU;
            let l: Lobe = [
                rng.next_f32() * 5.0,
                th.sin() * ph.cos(),
                th.sin() * ph.sin(),
                th.cos(),
                0.1 + rng.next_f32() * 150.0,
            ];
            let p = PackedLobe::pack(&l);
            let u = p.unpack();
            assert!((u[0] - l[0]).abs() <= 5e-4 * l[0] + 1e-7);
            assert!((u[4] - l[4]).abs() <= 5e-4 * l[4]);
            let (a, b) = (
                [u[1] as f64, u[2] as f64, u[3] as f64],
                [l[1] as f64, l[2] as f64, l[3] as f64],
            );
            let cross = [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ];
            let sin = (cross.iter().map(|v| v * v).sum::<f64>()).sqrt();
            assert!(
                sin < 1e-4 && a.iter().zip(&b).map(|(x, y)| x * y).sum::<f64>() > 0.0,
                "{l:?} {u:?}"
            );
        }
    }
}
