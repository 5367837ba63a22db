//! Sixteen direction locations at once: [`DirectionInterp::locate`] for 16 disk points, one per
//! AVX-512 lane. Per lookup-grid cell a table lists its first 4 candidate triangles in the
//! scalar search's order (cells of at most 4 hold about 98 % of UBO2003 directions, 95 % of
//! UBO2014's, uniform over the hemisphere); two gathers read them, 16 loads of the 64-byte
//! triangle records and a 16 × 16 transpose their geometry, and the search runs lane-wise: the barycentric weights with
//! the scalar code's operations in its order (no fused multiply-adds), the same comparisons and
//! early exits as masks, so every lane is the scalar result to the last bit. Lanes of cells with
//! more candidates, or that meet a NaN weight, take the scalar search (a masked slow path).
//! Without AVX-512 every lane takes the scalar search.

use super::directions::DirectionInterp;
#[cfg(target_arch = "x86_64")]
use super::directions::{CANDS, NO_CANDS};
#[cfg(target_arch = "x86_64")]
use crate::math::simd::Level;
#[cfg(target_arch = "x86_64")]
use crate::math::simd::transpose::{transpose8, transpose16};

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
    /// Every lane triangle 0 with weights 0 (what the kernels start from).
    const ZERO: Located16 = Located16 {
        tri: [0; LOCATE_LANES],
        w: [[0.0; LOCATE_LANES]; 3],
    };

    /// Sets lane `i` to a [`DirectionInterp::locate`] result.
    #[inline]
    fn set_lane(&mut self, i: usize, (t, w): (usize, [f32; 3])) {
        self.tri[i] = t as u32;
        for k in 0..3 {
            self.w[k][i] = w[k];
        }
    }

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
        self.locate16_lanes(qx, qy, u16::MAX)
    }

    /// [`DirectionInterp::locate16`] of the lanes whose bit is set in `lanes`; the other lanes
    /// hold unspecified triangles and weights (a caller's unused lanes then never take the
    /// scalar search of an over-full cell).
    #[inline]
    pub fn locate16_lanes(
        &self,
        qx: &[f32; LOCATE_LANES],
        qy: &[f32; LOCATE_LANES],
        lanes: u16,
    ) -> Located16 {
        let mut out = Located16::ZERO;
        #[cfg(target_arch = "x86_64")]
        match self.level {
            // SAFETY: `simd::isa()` gives `Level::Avx512` only on CPUs with AVX-512F.
            Level::Avx512 => return unsafe { self.locate16_avx512(qx, qy, lanes) },
            Level::Avx2 => {
                for half in 0..2 {
                    // SAFETY: `simd::isa()` gives `Level::Avx2` only on CPUs with AVX2.
                    unsafe { self.locate8_avx2(qx, qy, lanes, half, &mut out) };
                }
                return out;
            }
            Level::Portable => {}
        }
        for i in (0..LOCATE_LANES).filter(|&i| lanes & (1 << i) != 0) {
            out.set_lane(i, self.locate([qx[i], qy[i]]));
        }
        out
    }

    /// The scalar search per lane (the reference, and the path of CPUs without AVX2).
    pub fn locate16_scalar(&self, qx: &[f32; LOCATE_LANES], qy: &[f32; LOCATE_LANES]) -> Located16 {
        let mut out = Located16::ZERO;
        for i in 0..LOCATE_LANES {
            out.set_lane(i, self.locate([qx[i], qy[i]]));
        }
        out
    }

    /// The gather kernel: the search over cells of up to [`CANDS`] candidates lane-wise, the
    /// scalar search for the other lanes (and any lane that meets a NaN weight).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn locate16_avx512(
        &self,
        qx: &[f32; LOCATE_LANES],
        qy: &[f32; LOCATE_LANES],
        lanes: u16,
    ) -> Located16 {
        use core::arch::x86_64::*;
        let grid = self.grid;
        assert!(self.cands.len() == (grid * grid) as usize);
        let mut out = Located16::ZERO;
        // SAFETY: loads of the two input arrays (16 f32 each); the candidate gathers read u32
        // 2·cell and 2·cell + 1 of `cands` (grid² entries of 2 u32) with cell < grid² (clamped
        // below); the row loads read the 64-byte record t, t a cell's candidate
        // (< tris.len() by construction of `cands`) or 0 on over-full cells' lanes; the stores
        // go to `out`'s arrays of 16.
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
            // The cell's 4 candidates as 2 u32 of 2 u16 each.
            const _: () = assert!(CANDS == 4);
            let table = self.cands.as_ptr() as *const i32;
            let pair = _mm512_slli_epi32::<1>(cell);
            let lo = _mm512_i32gather_epi32::<4>(pair, table);
            let hi =
                _mm512_i32gather_epi32::<4>(_mm512_add_epi32(pair, _mm512_set1_epi32(1)), table);
            let low16 = _mm512_set1_epi32(0xffff);
            let cand = [
                _mm512_and_si512(lo, low16),
                _mm512_srli_epi32::<16>(lo),
                _mm512_and_si512(hi, low16),
                _mm512_srli_epi32::<16>(hi),
            ];
            // Over-full cells (marked NO_CANDS): scalar search; their lanes read triangle 0.
            let full = _mm512_cmpeq_epi32_mask(cand[0], _mm512_set1_epi32(NO_CANDS as i32));
            let cand = cand.map(|c| _mm512_mask_mov_epi32(c, full, _mm512_setzero_si512()));
            let base = self.tris.as_ptr() as *const f32;
            // TriGeom::weights of triangles `t`: the 16 records (64 bytes, aligned) loaded and
            // transposed, so that register f holds word f of every lane's record: p = a, b, c
            // at 0..6, e = c − b, a − c, b − a at 6..12, 1/(2A) at 12;
            // w = (e_x · (q_y − o_y) − e_y · (q_x − o_x)) · 1/(2A), the scalar operations.
            let weights = |t: __m512i| {
                let mut idx = [0u32; LOCATE_LANES];
                _mm512_storeu_si512(idx.as_mut_ptr() as *mut _, t);
                let mut r = [zero; 16];
                for (r, &t) in r.iter_mut().zip(&idx) {
                    *r = _mm512_load_ps(base.add(t as usize * 16));
                }
                transpose16(&mut r);
                let weight = |e: usize, o: usize| {
                    let l = _mm512_mul_ps(r[e], _mm512_sub_ps(y, r[o + 1]));
                    let rr = _mm512_mul_ps(r[e + 1], _mm512_sub_ps(x, r[o]));
                    _mm512_mul_ps(_mm512_sub_ps(l, rr), r[12])
                };
                [weight(6, 2), weight(8, 4), weight(10, 0)]
            };
            // f32::min of non-NaN values (NaN lanes leave for the scalar search).
            let min3 = |w: [__m512; 3]| _mm512_min_ps(_mm512_min_ps(w[0], w[1]), w[2]);
            let nan = |w: [__m512; 3]| {
                _mm512_cmp_ps_mask::<_CMP_UNORD_Q>(w[0], w[1])
                    | _mm512_cmp_ps_mask::<_CMP_UNORD_Q>(w[2], w[2])
            };
            // The scalar search, lane-wise: the first candidate; stop if it contains q; else
            // each next one that raises the smallest weight replaces it, stopping once inside.
            let mut best_t = cand[0];
            let mut best_w = weights(cand[0]);
            let mut best_min = min3(best_w);
            let mut slow = full | nan(best_w);
            let mut done = _mm512_cmp_ps_mask::<_CMP_GE_OQ>(best_min, zero);
            for c in &cand[1..] {
                // Repeats of the first candidate pad the list: nothing to test.
                let need = !done & !slow & _mm512_cmpneq_epi32_mask(*c, cand[0]);
                if need == 0 {
                    continue;
                }
                let w = weights(*c);
                let m = min3(w);
                slow |= need & nan(w);
                let better = _mm512_mask_cmp_ps_mask::<_CMP_GT_OQ>(need, m, best_min);
                best_t = _mm512_mask_mov_epi32(best_t, better, *c);
                for k in 0..3 {
                    best_w[k] = _mm512_mask_mov_ps(best_w[k], better, w[k]);
                }
                best_min = _mm512_mask_mov_ps(best_min, better, m);
                done |= better & _mm512_cmp_ps_mask::<_CMP_GE_OQ>(m, zero);
            }
            for k in 0..3 {
                _mm512_storeu_ps(out.w[k].as_mut_ptr(), best_w[k]);
            }
            _mm512_storeu_si512(out.tri.as_mut_ptr() as *mut _, best_t);
            // Lanes of over-full cells or NaN weights: the exact scalar search (wanted lanes).
            let mut slow = slow & lanes;
            while slow != 0 {
                let i = slow.trailing_zeros() as usize;
                slow &= slow - 1;
                out.set_lane(i, self.locate([qx[i], qy[i]]));
            }
        }
        out
    }
}

/// Lanes of one AVX2 pass of [`DirectionInterp::locate16`].
#[cfg(target_arch = "x86_64")]
const HALF: usize = LOCATE_LANES / 2;

impl DirectionInterp {
    /// The AVX2 kernel for lanes `8 half .. 8 half + 8` of `out`: `locate16_avx512`'s search
    /// on 8 lanes, the same operations in the same order (so the scalar search's bits). The
    /// candidates are read per lane from the cell table, the triangle records by row loads and
    /// two 8 × 8 transposes.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn locate8_avx2(
        &self,
        qx: &[f32; LOCATE_LANES],
        qy: &[f32; LOCATE_LANES],
        lanes: u16,
        half: usize,
        out: &mut Located16,
    ) {
        use core::arch::x86_64::*;
        let o = HALF * half;
        let grid = self.grid;
        // SAFETY: 8 f32 loads from the lanes o..o + 8 of arrays of 16.
        let (x, y) = unsafe {
            (
                _mm256_loadu_ps(qx[o..o + HALF].as_ptr()),
                _mm256_loadu_ps(qy[o..o + HALF].as_ptr()),
            )
        };
        let one = _mm256_set1_ps(1.0);
        let half_ = _mm256_set1_ps(0.5);
        let g = _mm256_set1_ps(grid as f32);
        let top = _mm256_set1_ps((grid - 1) as f32);
        let zero = _mm256_setzero_ps();
        // The cell as `locate16_avx512` computes it (clamped before the cast).
        let cell_of = |q: __m256| {
            let c = _mm256_mul_ps(_mm256_mul_ps(_mm256_add_ps(q, one), half_), g);
            _mm256_cvttps_epi32(_mm256_min_ps(_mm256_max_ps(c, zero), top))
        };
        let cell = _mm256_add_epi32(
            _mm256_mullo_epi32(cell_of(y), _mm256_set1_epi32(grid as i32)),
            cell_of(x),
        );
        let mut cells = [0u32; HALF];
        // SAFETY: a store of 8 u32 to an array of 8.
        unsafe { _mm256_storeu_si256(cells.as_mut_ptr() as *mut _, cell) };
        // The cells' candidates per lane; over-full cells (NO_CANDS) read triangle 0 and take
        // the scalar search.
        let mut cand = [[0u32; HALF]; CANDS];
        let mut full = 0u32;
        for (l, &c) in cells.iter().enumerate() {
            let c = self.cands[c as usize];
            if c[0] == NO_CANDS {
                full |= 1 << l;
            } else {
                for k in 0..CANDS {
                    cand[k][l] = c[k] as u32;
                }
            }
        }
        // TriGeom::weights of the lanes' triangles `t`: the 8 records (64 bytes, aligned) as
        // two 8 × 8 transposes, word f of every record in register f (see `locate16_avx512`).
        let weights = |t: &[u32; HALF]| {
            let mut r = [[zero; HALF]; 2];
            for (l, &t) in t.iter().enumerate() {
                let p = &self.tris[t as usize] as *const super::directions::TriGeom as *const f32;
                // SAFETY: a `TriGeom` is 16 f32, 64-byte aligned: two aligned 8-float loads.
                unsafe {
                    r[0][l] = _mm256_load_ps(p);
                    r[1][l] = _mm256_load_ps(p.add(8));
                }
            }
            transpose8(&mut r[0]);
            transpose8(&mut r[1]);
            let f = |i: usize| r[i / 8][i % 8];
            let weight = |e: usize, o: usize| {
                let l = _mm256_mul_ps(f(e), _mm256_sub_ps(y, f(o + 1)));
                let rr = _mm256_mul_ps(f(e + 1), _mm256_sub_ps(x, f(o)));
                _mm256_mul_ps(_mm256_sub_ps(l, rr), f(12))
            };
            [weight(6, 2), weight(8, 4), weight(10, 0)]
        };
        let bits = |m: __m256| _mm256_movemask_ps(m) as u32;
        let min3 = |w: [__m256; 3]| _mm256_min_ps(_mm256_min_ps(w[0], w[1]), w[2]);
        let nan = |w: [__m256; 3]| {
            bits(_mm256_cmp_ps::<_CMP_UNORD_Q>(w[0], w[1]))
                | bits(_mm256_cmp_ps::<_CMP_UNORD_Q>(w[2], w[2]))
        };
        // A lane mask from its bits (lane l all ones where bit l is set).
        let lane_bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        let mask_of = |m: u32| {
            let b = _mm256_and_si256(_mm256_set1_epi32(m as i32), lane_bits);
            _mm256_castsi256_ps(_mm256_cmpeq_epi32(b, lane_bits))
        };
        // The scalar search, lane-wise (as `locate16_avx512`).
        let load = |c: &[u32; HALF]| {
            // SAFETY: a load of 8 u32 from an array of 8.
            unsafe { _mm256_loadu_si256(c.as_ptr() as *const _) }
        };
        let first = load(&cand[0]);
        let mut best_t = _mm256_castsi256_ps(first);
        let mut best_w = weights(&cand[0]);
        let mut best_min = min3(best_w);
        let mut slow = full | nan(best_w);
        let mut done = bits(_mm256_cmp_ps::<_CMP_GE_OQ>(best_min, zero));
        for c in &cand[1..] {
            let cv = load(c);
            // Repeats of the first candidate pad the list: nothing to test.
            let repeat = bits(_mm256_castsi256_ps(_mm256_cmpeq_epi32(cv, first)));
            let need = !done & !slow & !repeat & 0xff;
            if need == 0 {
                continue;
            }
            let w = weights(c);
            let m = min3(w);
            slow |= need & nan(w);
            let better = need & bits(_mm256_cmp_ps::<_CMP_GT_OQ>(m, best_min));
            let bm = mask_of(better);
            best_t = _mm256_blendv_ps(best_t, _mm256_castsi256_ps(cv), bm);
            for k in 0..3 {
                best_w[k] = _mm256_blendv_ps(best_w[k], w[k], bm);
            }
            best_min = _mm256_blendv_ps(best_min, m, bm);
            done |= better & bits(_mm256_cmp_ps::<_CMP_GE_OQ>(m, zero));
        }
        // SAFETY: stores of 8 lanes to lanes o..o + 8 of arrays of 16.
        unsafe {
            for k in 0..3 {
                _mm256_storeu_ps(out.w[k][o..o + HALF].as_mut_ptr(), best_w[k]);
            }
            _mm256_storeu_ps(out.tri[o..o + HALF].as_mut_ptr() as *mut f32, best_t);
        }
        // Lanes of over-full cells or NaN weights: the exact scalar search (wanted lanes).
        let mut slow = slow & (lanes >> o) as u32 & 0xff;
        while slow != 0 {
            let i = o + slow.trailing_zeros() as usize;
            slow &= slow - 1;
            out.set_lane(i, self.locate([qx[i], qy[i]]));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::btf::DirectionSet;
    use crate::math::Pcg32;
    use crate::math::frame::from_spherical;
    use crate::math::simd::Level;

    /// `check_level` at every kernel level this CPU runs (AVX-512, AVX2, scalar).
    fn check(ip: &DirectionInterp, points: &[[f32; 2]]) -> usize {
        let top = crate::math::simd::isa().level();
        assert_eq!(ip.level, top);
        let fast = check_level(ip, points);
        for level in [Level::Avx2, Level::Portable] {
            if level < top {
                let mut lower = ip.clone();
                lower.level = level;
                assert_eq!(check_level(&lower, points), fast);
            }
        }
        fast
    }

    /// `locate16` (and `locate16_lanes` on its lanes) against `locate` lane by lane, bit for
    /// bit (NaN weights: both NaN), over `points` in chunks of 16; returns how many lanes hit a
    /// cell searched lane-wise.
    fn check_level(ip: &DirectionInterp, points: &[[f32; 2]]) -> usize {
        let mut fast = 0;
        for chunk in points.chunks(LOCATE_LANES) {
            let (mut qx, mut qy) = ([0f32; LOCATE_LANES], [0f32; LOCATE_LANES]);
            for i in 0..LOCATE_LANES {
                let p = chunk[i % chunk.len()];
                (qx[i], qy[i]) = (p[0], p[1]);
            }
            let got = ip.locate16(&qx, &qy);
            let scalar = ip.locate16_scalar(&qx, &qy);
            // A subset of the lanes, varying from chunk to chunk: those lanes are the same.
            let lanes = 0b1010_0110_0101_1001u16.rotate_left(fast as u32);
            let part = ip.locate16_lanes(&qx, &qy, lanes);
            let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
            for i in 0..LOCATE_LANES {
                let (t, w) = ip.locate([qx[i], qy[i]]);
                let wanted = (lanes >> i & 1 == 1).then(|| part.lane(i));
                for (gt, gw) in [got.lane(i), scalar.lane(i)].into_iter().chain(wanted) {
                    assert!(
                        gt == t && (0..3).all(|k| same(gw[k], w[k])),
                        "({}, {}): batched {:?}, locate {:?}",
                        qx[i],
                        qy[i],
                        (gt, gw),
                        (t, w)
                    );
                }
                let c = ip.cands[ip.cell_of([qx[i], qy[i]])];
                if i < chunk.len() && c[0] != super::super::directions::NO_CANDS {
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
                // Directions uniform in θ, φ (the first 4000 points): mostly lane-wise.
                let pts = &adversarial(set, &ip, &mut rng)[..4000];
                let fast = check(&ip, pts);
                assert!(fast > 4000 * 9 / 10, "{fast} of 4000");
            }
            let pts = adversarial(set, &ip, &mut rng);
            let fast = check(&ip, &pts);
            // The lane-wise search ran, and (the standard sets) cells left to the scalar search.
            assert!(fast > pts.len() / 10, "{fast} of {}", pts.len());
            if k < 2 {
                assert!(fast < pts.len(), "{fast} of {}", pts.len());
            }
        }
    }
}
