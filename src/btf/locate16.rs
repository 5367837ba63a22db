//! Sixteen direction locations at once: [`DirectionInterp::locate`] for 16 disk points, one per
//! AVX-512 lane. The lookup grid's single-candidate cells (most cells: the test-free fast path
//! of the scalar search) are read by one gather of the cell table, their triangles' geometry by
//! gathers of the 64-byte triangle records, and the barycentric weights computed lane-wise with
//! the scalar code's operations in its order (no fused multiply-adds), so every lane is the
//! scalar result to the last bit. Lanes whose cell lists several candidates take the scalar
//! search (a masked slow path). Without AVX-512 every lane takes the scalar search.

use super::directions::DirectionInterp;

/// Lanes of one batched location (one AVX-512 register of f32).
pub const LOCATE_LANES: usize = 16;

/// Sixteen located disk points, structure of arrays: lane i is what
/// [`DirectionInterp::locate`] returns for point i (triangle, unclamped barycentric weights).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Located16 {
    /// Triangle index per lane.
    pub tri: [u32; LOCATE_LANES],
    /// Unclamped barycentric weight k of lane i is `w[k][i]`.
    pub w: [[f32; LOCATE_LANES]; 3],
}

impl Located16 {
    /// Lane `i` in the form [`DirectionInterp::locate`] returns.
    #[inline]
    pub fn lane(&self, i: usize) -> (usize, [f32; 3]) {
        (
            self.tri[i] as usize,
            [self.w[0][i], self.w[1][i], self.w[2][i]],
        )
    }
}

impl DirectionInterp {
    /// [`DirectionInterp::locate`] of the 16 disk points `(qx[i], qy[i])`, lane by lane the
    /// same bits; AVX-512 gathers where the CPU has it (detected when the interpolator was
    /// built), else the scalar search per lane.
    #[inline]
    pub fn locate16(&self, qx: &[f32; LOCATE_LANES], qy: &[f32; LOCATE_LANES]) -> Located16 {
        #[cfg(target_arch = "x86_64")]
        if self.avx512 {
            // SAFETY: `avx512` is set only if this CPU has AVX-512F (checked at construction).
            return unsafe { self.locate16_avx512(qx, qy) };
        }
        self.locate16_scalar(qx, qy)
    }

    /// The scalar search per lane (the reference, and the path of CPUs without AVX-512).
    pub fn locate16_scalar(&self, qx: &[f32; LOCATE_LANES], qy: &[f32; LOCATE_LANES]) -> Located16 {
        let mut out = Located16 {
            tri: [0; LOCATE_LANES],
            w: [[0.0; LOCATE_LANES]; 3],
        };
        for i in 0..LOCATE_LANES {
            let (t, w) = self.locate([qx[i], qy[i]]);
            out.tri[i] = t as u32;
            for k in 0..3 {
                out.w[k][i] = w[k];
            }
        }
        out
    }

    /// The gather kernel: single-candidate cells lane-wise, the others by the scalar search.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn locate16_avx512(&self, qx: &[f32; LOCATE_LANES], qy: &[f32; LOCATE_LANES]) -> Located16 {
        use core::arch::x86_64::*;
        let grid = self.grid;
        // The cell table has one pad entry (a 4-byte gather at the last cell stays inside), the
        // triangle records are 16 words each: every offset below fits i32.
        assert!(self.cells.len() > (grid * grid) as usize);
        let mut out = Located16 {
            tri: [0; LOCATE_LANES],
            w: [[0.0; LOCATE_LANES]; 3],
        };
        // SAFETY: loads of the two input arrays (16 f32 each); the cell gather reads 4 bytes at
        // 2·cell with cell < grid² (clamped below), inside `cells` (grid² + 1 u16); the triangle
        // gathers read word f < 13 of record t, where t is a single-candidate cell's triangle
        // (< tris.len(), by construction of `cells`) or 0 on the other lanes; the stores go to
        // `out`'s arrays of 16.
        unsafe {
            let (x, y) = (_mm512_loadu_ps(qx.as_ptr()), _mm512_loadu_ps(qy.as_ptr()));
            let one = _mm512_set1_ps(1.0);
            let half = _mm512_set1_ps(0.5);
            let g = _mm512_set1_ps(grid as f32);
            let top = _mm512_set1_ps((grid - 1) as f32);
            let zero = _mm512_setzero_ps();
            // `((q + 1) · 0.5 · g) as i32` clamped to [0, grid − 1]: clamping the float first is
            // the same cell for every input (NaN: `max` returns its second operand, 0, as the
            // saturating cast gives 0; ±∞ and huge values clamp to the edges either way).
            let cell_of = |q: __m512| {
                let c = _mm512_mul_ps(_mm512_mul_ps(_mm512_add_ps(q, one), half), g);
                _mm512_cvttps_epi32(_mm512_min_ps(_mm512_max_ps(c, zero), top))
            };
            let cell = _mm512_add_epi32(
                _mm512_mullo_epi32(cell_of(y), _mm512_set1_epi32(grid as i32)),
                cell_of(x),
            );
            let entry = _mm512_and_si512(
                _mm512_i32gather_epi32::<2>(cell, self.cells.as_ptr() as *const i32),
                _mm512_set1_epi32(0xffff),
            );
            let single = _mm512_test_epi32_mask(entry, _mm512_set1_epi32(1));
            let t = _mm512_maskz_srli_epi32::<1>(single, entry);
            let rec = _mm512_slli_epi32::<4>(t);
            let base = self.tris.as_ptr() as *const f32;
            let field = |f: i32| {
                _mm512_i32gather_ps::<4>(_mm512_add_epi32(rec, _mm512_set1_epi32(f)), base)
            };
            // Record words: p = a, b, c at 0..6, e = c − b, a − c, b − a at 6..12, 1/(2A) at 12.
            let inv = field(12);
            // TriGeom::weights: (e_x · (q_y − o_y) − e_y · (q_x − o_x)) · inv.
            let weight = |e: i32, o: i32| {
                let l = _mm512_mul_ps(field(e), _mm512_sub_ps(y, field(o + 1)));
                let r = _mm512_mul_ps(field(e + 1), _mm512_sub_ps(x, field(o)));
                _mm512_mul_ps(_mm512_sub_ps(l, r), inv)
            };
            _mm512_storeu_ps(out.w[0].as_mut_ptr(), weight(6, 2));
            _mm512_storeu_ps(out.w[1].as_mut_ptr(), weight(8, 4));
            _mm512_storeu_ps(out.w[2].as_mut_ptr(), weight(10, 0));
            _mm512_storeu_si512(out.tri.as_mut_ptr() as *mut _, t);
            // Lanes of cells with several candidates: the exact scalar search.
            let mut slow = !single;
            while slow != 0 {
                let i = slow.trailing_zeros() as usize;
                slow &= slow - 1;
                let (t, w) = self.locate([qx[i], qy[i]]);
                out.tri[i] = t as u32;
                for k in 0..3 {
                    out.w[k][i] = w[k];
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::btf::DirectionSet;
    use crate::math::Pcg32;
    use crate::math::frame::from_spherical;

    /// `locate16` against `locate` lane by lane, bit for bit (NaN weights: both NaN), over
    /// `points` in chunks of 16; returns how many lanes hit a single-candidate cell.
    fn check(ip: &DirectionInterp, points: &[[f32; 2]]) -> usize {
        let mut fast = 0;
        for chunk in points.chunks(LOCATE_LANES) {
            let (mut qx, mut qy) = ([0f32; LOCATE_LANES], [0f32; LOCATE_LANES]);
            for i in 0..LOCATE_LANES {
                let p = chunk[i % chunk.len()];
                (qx[i], qy[i]) = (p[0], p[1]);
            }
            let got = ip.locate16(&qx, &qy);
            let scalar = ip.locate16_scalar(&qx, &qy);
            let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
            for i in 0..LOCATE_LANES {
                let (t, w) = ip.locate([qx[i], qy[i]]);
                for (gt, gw) in [got.lane(i), scalar.lane(i)] {
                    assert!(
                        gt == t && (0..3).all(|k| same(gw[k], w[k])),
                        "({}, {}): batched {:?}, locate {:?}",
                        qx[i],
                        qy[i],
                        (gt, gw),
                        (t, w)
                    );
                }
                if i < chunk.len() && ip.cells[ip.cell_of([qx[i], qy[i]])] & 1 == 1 {
                    fast += 1;
                }
            }
        }
        fast
    }

    /// Random, measured, on-edge, horizon, below-horizon, cell-boundary and non-finite points.
    fn adversarial(set: &DirectionSet, ip: &DirectionInterp, rng: &mut Pcg32) -> Vec<[f32; 2]> {
        let mut pts = Vec::new();
        for _ in 0..4000 {
            let d = from_spherical(
                rng.next_f32() * std::f32::consts::FRAC_PI_2,
                rng.next_f32() * std::f32::consts::TAU,
            );
            pts.push([d.x, d.y]);
        }
        // Exactly at the measured directions.
        pts.extend(set.dirs.iter().map(|d| [d.x, d.y]));
        // On and next to the triangles' edges: midpoints, random points along each edge, one
        // ulp either side.
        for t in 0..ip.num_triangles() {
            let p = ip.triangle_disk(t);
            for (a, b) in [(0, 1), (1, 2), (2, 0)] {
                for s in [0.5, rng.next_f32(), rng.next_f32()] {
                    let q = [
                        p[a][0] + s * (p[b][0] - p[a][0]),
                        p[a][1] + s * (p[b][1] - p[a][1]),
                    ];
                    pts.push(q);
                    pts.push([q[0].next_up(), q[1].next_down()]);
                    pts.push([q[0].next_down(), q[1].next_up()]);
                }
            }
        }
        // The horizon (θ = 90°), just beyond it, and below it (z < 0: the disk point of
        // (x, y, z) is the mirrored direction's), and outside the disk.
        for k in 0..720 {
            let phi = k as f32 * std::f32::consts::TAU / 720.0;
            let (s, c) = phi.sin_cos();
            for r in [1.0, 1.0f32.next_up(), 0.999, 1.02, 1.5, 3.0] {
                pts.push([r * c, r * s]);
            }
        }
        // Grid cell corners exactly, and the square's edges.
        let g = ip.grid;
        for k in 0..=g {
            let x = -1.0 + 2.0 * k as f32 / g as f32;
            let y = -1.0 + 2.0 * rng.next_f32();
            pts.extend([[x, y], [y, x], [x, x], [x, -x]]);
        }
        let odd = [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MAX,
            -f32::MAX,
            1e30,
            -1e30,
            -0.0,
            0.0,
            f32::MIN_POSITIVE,
            -1.0,
            1.0,
        ];
        for &a in &odd {
            for &b in &odd {
                pts.push([a, b]);
            }
        }
        pts
    }

    #[test]
    fn batched_location_is_the_scalar_location_bit_for_bit() {
        let mut rng = Pcg32::new(14, 16);
        let mut sets = vec![DirectionSet::ubo2003(), DirectionSet::ubo2014()];
        // Random sets (θ ≤ 85°) as in the interpolator's own tests.
        for _ in 0..8 {
            let n = 3 + (rng.next_f32() * 40.0) as usize;
            sets.push(DirectionSet::from_angles_deg(
                (0..n)
                    .map(|_| (rng.next_f32() * 85.0, rng.next_f32() * 360.0))
                    .collect(),
            ));
        }
        for (k, set) in sets.iter().enumerate() {
            let Ok(ip) = set.interpolator() else { continue };
            if k < 2 {
                // Uniform directions (the first 4000 points): mostly the gathered path.
                let pts = &adversarial(set, &ip, &mut rng)[..4000];
                let fast = check(&ip, pts);
                eprintln!("uniform {fast} of 4000");
                assert!(fast > 4000 / 2, "{fast} of 4000");
            }
            let pts = adversarial(set, &ip, &mut rng);
            let fast = check(&ip, &pts);
            // Both paths of the kernel ran: gathered lanes and scalar-search lanes (a set of 3
            // directions has one triangle: every cell is single).
            assert!(fast > 0 && fast <= pts.len(), "{fast} of {}", pts.len());
            if set.len() > 3 {
                assert!(fast < pts.len());
            }
        }
    }
}
