//! The one-lobe Lafortune model Y = ρ·max(0, D·u)^n of one (view, texel, channel), and its 8-byte
//! stored form.

use crate::math::Vec3;
use half::f16;

/// Lafortune parameters `[ρ, Dx, Dy, Dz, n]`.
pub type Lobe = [f32; 5];

/// A lobe with zero albedo (the fit of an all-zero signal).
pub const ZERO_LOBE: Lobe = [0.0, 0.0, 0.0, 1.0, 1.0];

/// Evaluates one lobe for the light direction `u` (base clamped at 0).
#[inline]
pub fn eval(p: &Lobe, u: Vec3) -> f32 {
    let b = p[1] * u.x + p[2] * u.y + p[3] * u.z;
    if b <= 0.0 { 0.0 } else { p[0] * b.powf(p[4]) }
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
