//! Sixteen PLM-C evaluations per call on AVX2 + FMA (u8 cluster indices, with polynomials): the
//! AVX-512 batch kernel (`batch.rs`) for CPUs without AVX-512, one query per lane of an 8-lane
//! register, 8 queries per pass. Every lane is a different query, so the 9 (view, channel)
//! chains (index entry → lobe record → log2 → exp2 → polynomial → decode) of 8 queries are
//! independent and their latencies and cache misses overlap, where the generic kernel runs one
//! query's chain at a time on 4-lane registers (R, G, B, pad) and spends most of its
//! instructions on shuffles.
//!
//! Loads: index entries, lobe records (32 bytes), polynomial rows (64 bytes) and bounds are
//! read whole per query (bounds-checked slices) and turned into lanes by 8 × 8 register
//! transposes: AVX2 gathers are microcoded on AMD Zen and slower than the row loads.
//!
//! Same arithmetic as `avx512::eval` and the generic kernel, operation by operation (the same
//! fused multiply-adds in the same order, the same clamps with the same operand order, the
//! fused log2/exp2 of `math::simd::approx`): each lane is the single-query kernel's result to
//! the last bit (tested in `tests.rs`).

use super::FLUSH;
use super::query::{BATCH, BatchQuery as Query, Tables};
use crate::math::simd::approx::{fused_exp2_8, fused_log2_8};
use crate::math::simd::transpose::transpose8;
use core::arch::x86_64::*;
use core::mem::MaybeUninit;

/// Queries per pass: one per lane of an AVX register.
const LANES: usize = 8;
// One query is two 8-float rows; a batch is whole passes.
const _: () = assert!(std::mem::size_of::<Query>() == 64 && BATCH.is_multiple_of(LANES));

/// The lobes `[ρ, Dx, Dy, Dz, n]` at the light direction `w`: Y = ρ · b^n with b = D·w, 0 where
/// b ≤ 0 or Y < FLUSH (`avx512::lobe_value` on 8 lanes).
#[target_feature(enable = "avx2,fma")]
#[inline]
fn lobe_value(l: &[__m256; 5], w: [__m256; 3]) -> __m256 {
    let s = _mm256_set1_ps;
    let [rho, dx, dy, dz, n] = *l;
    let b = _mm256_fmadd_ps(dz, w[2], _mm256_fmadd_ps(dy, w[1], _mm256_mul_ps(dx, w[0])));
    let lg = fused_log2_8(_mm256_max_ps(b, s(1e-30)));
    let pw = fused_exp2_8(_mm256_max_ps(_mm256_mul_ps(n, lg), s(-100.0)));
    let y = _mm256_mul_ps(rho, pw);
    let keep = _mm256_and_ps(
        _mm256_cmp_ps::<_CMP_GT_OQ>(b, _mm256_setzero_ps()),
        _mm256_cmp_ps::<_CMP_GT_OQ>(y, s(FLUSH)),
    );
    _mm256_and_ps(keep, y)
}

/// Clamp to `y_max`, the polynomial `a_0..a_4` (Estrin), clamp to `out_max`, then to linear
/// (`avx512::map_decode` on 8 lanes).
#[target_feature(enable = "avx2,fma")]
#[inline]
fn map_decode(y: __m256, y_max: __m256, a: &[__m256; 5], out_max: __m256, srgb: bool) -> __m256 {
    let s = _mm256_set1_ps;
    let zero = _mm256_setzero_ps();
    let x = _mm256_min_ps(y, y_max);
    let x2 = _mm256_mul_ps(x, x);
    let lo = _mm256_fmadd_ps(a[1], x, a[0]);
    let hi = _mm256_fmadd_ps(a[4], x2, _mm256_fmadd_ps(a[3], x, a[2]));
    let y = _mm256_min_ps(_mm256_fmadd_ps(hi, x2, lo), out_max);
    if srgb {
        let v = _mm256_max_ps(y, zero);
        let lin = _mm256_mul_ps(v, s(1.0 / 12.92));
        let base = _mm256_max_ps(
            _mm256_mul_ps(_mm256_add_ps(v, s(0.055)), s(1.0 / 1.055)),
            s(1e-30),
        );
        let pow = fused_exp2_8(_mm256_mul_ps(s(2.4), fused_log2_8(base)));
        let small = _mm256_cmp_ps::<_CMP_LE_OS>(v, s(0.04045));
        _mm256_blendv_ps(pow, lin, small)
    } else {
        _mm256_max_ps(y, zero)
    }
}

/// B (cosine-baked, linear RGB, nearest texel) of up to [`BATCH`] queries into `out`
/// (`out.len() == q.len()`), 8 per pass. Panics if a view, light or texel is out of range.
///
/// # Safety
/// The CPU must have AVX2 and FMA (`simd::isa()` at `Level::Avx2` or above).
#[target_feature(enable = "avx2,fma")]
pub fn eval(t: &Tables, q: &[Query], out: &mut [[f32; 3]]) {
    assert!(q.len() <= BATCH && out.len() == q.len());
    for (q, out) in q.chunks(LANES).zip(out.chunks_mut(LANES)) {
        eval8(t, q, out);
    }
}

/// One pass: up to 8 queries, lanes past `q.len()` repeat query 0 (results dropped).
#[target_feature(enable = "avx2,fma")]
fn eval8(t: &Tables, q: &[Query], out: &mut [[f32; 3]]) {
    let (nv, nl, k) = (t.n_views, t.n_lights, t.k);
    let zero = _mm256_setzero_ps();
    let query = |l: usize| &q[if l < q.len() { l } else { 0 }];
    // Every load that depends on the texel comes first: the 8 queries' 24 index entries, then
    // their 72 lobe records, so that their misses overlap. (The register arrays are left
    // uninitialised until every element is written: zeroing them cost a 4 KB memset a pass.)
    let mut ent = [[[0u8; 4]; 3]; LANES];
    for (l, e) in ent.iter_mut().enumerate() {
        let s = query(l);
        for a in 0..3 {
            let v = s.vi[a] as usize;
            assert!(v < nv, "PLM-C batch: view index out of range");
            e[a] = t.index[s.texel as usize * nv + v];
        }
    }
    let mut lobes = MaybeUninit::<[[[__m256; LANES]; 3]; 3]>::uninit();
    let lobe_at = lobes.as_mut_ptr() as *mut __m256;
    for (l, e) in ent.iter().enumerate() {
        let s = query(l);
        for a in 0..3 {
            let v = s.vi[a] as usize;
            for c in 0..3 {
                let r = &t.records[(3 * v + c) * k + e[a][c] as usize];
                // SAFETY: `LobeRec` is 8 f32, 32-byte aligned; element (a, c, l) of `lobes`.
                unsafe {
                    lobe_at
                        .add((3 * a + c) * LANES + l)
                        .write(_mm256_load_ps(r.0.as_ptr()))
                };
            }
        }
    }
    // SAFETY: every (a, c, l) was written above. (Borrowed in place: `assume_init` would copy
    // the arrays, a memcpy of 2.3 KB here and 2.3 KB below per pass.)
    let lobes = unsafe { lobes.assume_init_mut() };
    // Per lane and view: the light-interpolated polynomial row (w0·r0, + w1·r1, + w2·r2 on
    // whole rows, as the other kernels) as two halves, and the bounds (the 3 lights' largest
    // output, the view's Y bound) packed 3 per two halves.
    let mut coef = MaybeUninit::<[[[__m256; LANES]; 2]; 3]>::uninit();
    let coef_at = coef.as_mut_ptr() as *mut __m256;
    let mut bounds = MaybeUninit::<[[__m256; LANES]; 3]>::uninit();
    let bound_at = bounds.as_mut_ptr() as *mut __m256;
    for l in 0..LANES {
        let s = query(l);
        let (w0, w1, w2) = (
            _mm256_set1_ps(s.lw[0]),
            _mm256_set1_ps(s.lw[1]),
            _mm256_set1_ps(s.lw[2]),
        );
        let mut om = [_mm_setzero_ps(); 3];
        for a in 0..3 {
            let base = s.vi[a] as usize * nl;
            let row = |b: usize| {
                assert!(
                    (s.li[b] as usize) < nl,
                    "PLM-C batch: light index out of range"
                );
                let r = &t.polys[base + s.li[b] as usize].0;
                // SAFETY: `PolyRow` is 16 f32, 64-byte aligned: two aligned 8-float halves.
                unsafe {
                    [
                        _mm256_load_ps(r.as_ptr()),
                        _mm256_load_ps(r.as_ptr().add(8)),
                    ]
                }
            };
            let bound = |b: usize| {
                let r = &t.out_max[base + s.li[b] as usize];
                // SAFETY: a row of 4 f32.
                unsafe { _mm_loadu_ps(r.as_ptr()) }
            };
            let (r0, r1, r2) = (row(0), row(1), row(2));
            for h in 0..2 {
                let r = _mm256_mul_ps(w0, r0[h]);
                let r = _mm256_fmadd_ps(w1, r1[h], r);
                // SAFETY: element (a, h, l) of `coef`.
                unsafe {
                    coef_at
                        .add((2 * a + h) * LANES + l)
                        .write(_mm256_fmadd_ps(w2, r2[h], r))
                };
            }
            om[a] = _mm_max_ps(_mm_max_ps(bound(0), bound(1)), bound(2));
        }
        // SAFETY: rows of 4 f32 (`vi` < nv, checked above for every lane's query).
        let ym =
            s.vi.map(|v| unsafe { _mm_loadu_ps(t.y_max[v as usize].as_ptr()) });
        // SAFETY: elements (0, l), (1, l), (2, l) of `bounds`.
        unsafe {
            bound_at.add(l).write(_mm256_set_m128(om[1], om[0]));
            bound_at.add(LANES + l).write(_mm256_set_m128(ym[0], om[2]));
            bound_at
                .add(2 * LANES + l)
                .write(_mm256_set_m128(ym[2], ym[1]));
        }
    }
    // SAFETY: every (a, h, l) of `coef` and (i, l) of `bounds` was written above.
    let (coef, bounds) = unsafe { (coef.assume_init_mut(), bounds.assume_init_mut()) };
    // The queries' fields as lanes: row halves 0..8 and 8..16 (`BatchQuery` is repr(C):
    // texel, vi, vw, li, lw at 0..13, wo at 13..16).
    let mut fields = [[zero; LANES]; 2];
    for l in 0..LANES {
        let p = query(l) as *const Query as *const f32;
        // SAFETY: a `BatchQuery` is 16 f32 (64 bytes, repr(C), no padding).
        unsafe {
            fields[0][l] = _mm256_loadu_ps(p);
            fields[1][l] = _mm256_loadu_ps(p.add(8));
        }
    }
    for f in fields.iter_mut() {
        transpose8(f);
    }
    let vw = [fields[0][4], fields[0][5], fields[0][6]];
    let w = [fields[1][5], fields[1][6], fields[1][7]];
    for a in lobes.iter_mut() {
        for c in a.iter_mut() {
            transpose8(c);
        }
    }
    for a in coef.iter_mut() {
        for h in a.iter_mut() {
            transpose8(h);
        }
    }
    for b in bounds.iter_mut() {
        transpose8(b);
    }
    // Bound of view a, channel c: output bounds at 4 a + c, Y bounds at 12 + 4 a + c of the
    // three transposed sets read as one list of 24 registers.
    let bound = |i: usize| bounds[i / 8][i % 8];
    let mut y = [[zero; 3]; 3];
    for a in 0..3 {
        for c in 0..3 {
            // a_j of channel c is float 3 j + c of the row.
            let cf = [0, 1, 2, 3, 4].map(|j| coef[a][(3 * j + c) / 8][(3 * j + c) % 8]);
            let lobe = [0, 1, 2, 3, 4].map(|f| lobes[a][c][f]);
            let yy = lobe_value(&lobe, w);
            y[a][c] = map_decode(yy, bound(12 + 4 * a + c), &cf, bound(4 * a + c), t.srgb);
        }
    }
    // Blend the views: vw0·y0, + vw1·y1, + vw2·y2 (the single-query kernel's order).
    let mut res = [[0f32; LANES]; 3];
    for c in 0..3 {
        let o = _mm256_mul_ps(vw[0], y[0][c]);
        let o = _mm256_fmadd_ps(vw[1], y[1][c], o);
        let o = _mm256_fmadd_ps(vw[2], y[2][c], o);
        // SAFETY: a store of 8 f32 to an array of 8.
        unsafe { _mm256_storeu_ps(res[c].as_mut_ptr(), o) };
    }
    for (l, o) in out.iter_mut().enumerate() {
        *o = [res[0][l], res[1][l], res[2][l]];
    }
}
