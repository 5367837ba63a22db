//! Sixteen PLM-C evaluations per pass, one per AVX-512 lane (u8 cluster indices, with
//! polynomials): the batched form of `avx512::eval` for the packet integrator, where the
//! emitter samples of a whole BSDF batch are evaluated together. Where the single-query kernel
//! puts one query's 3 views × 3 channels in 12 lanes and runs one dependent chain (index load →
//! record loads → log2 → exp2 → polynomial → decode) per query, here every lane is a different
//! query: the 9 (view, channel) chains of 16 queries are independent, so their latencies and
//! their cache misses (one index entry and 9 lobe records per query, random texels) overlap.
//!
//! Loads: the index entries and the bound `y_max` by 16-lane gathers; the lobe records (32
//! bytes each) and polynomial rows by whole-record loads put side by side and turned into lanes
//! by 16 × 16 register transposes, not gathered field by field: a 16-lane gather is microcoded
//! on AMD Zen 4 and costs several times 16 row loads plus their share of a transpose, and a
//! pass reads 45 record fields (docs/architecture.md, "Speed: PLM-C against diffuse").
//!
//! Same arithmetic as `avx512::eval`, operation by operation (the same fused multiply-adds in
//! the same order, the same clamps with the same operand order, its log2/exp2): each lane's
//! result is the single-query kernel's to the last bit (tested in `tests.rs`).

use super::avx512::{Tables, lobe_value, map_decode, splat};
use crate::math::simd::transpose::transpose16;
use core::arch::x86_64::*;
use core::mem::MaybeUninit;

use super::query::{BATCH, BatchQuery as Query};

// One lane per query, 16 × 16 transposes.
const _: () = assert!(BATCH == 16);
// One query is one 16-float row.
const _: () = assert!(std::mem::size_of::<Query>() == 64);

/// True if every table offset of `t` fits the 32-bit gather indices (always for the UBO2003
/// and UBO2014 direction sets at any texture size up to 2^31 / views index entries).
pub fn fits(t: &Tables) -> bool {
    let m = i32::MAX as usize;
    t.index.len() <= m
        && t.records.len() * 8 <= m
        && t.polys.len() * 16 <= m
        && t.y_max.len() * 4 <= m
}

/// B (cosine-baked, linear RGB, nearest texel) of up to [`BATCH`] queries into `out`
/// (`out.len() == q.len()`). Panics if a view, light or texel is out of range or the tables do
/// not [`fit`] 32-bit offsets.
#[target_feature(enable = "avx512f,avx2,fma")]
pub fn eval(t: &Tables, q: &[Query], out: &mut [[f32; 3]]) {
    let n = q.len();
    assert!(n <= BATCH && out.len() == n);
    if n == 0 {
        return;
    }
    let (nv, nl, k) = (t.n_views, t.n_lights, t.k);
    assert!(fits(t));
    assert!(t.records.len() == nv * 3 * k && t.polys.len() == nv * nl);
    assert!(t.out_max.len() == nv * nl && t.y_max.len() == nv);
    assert!(k <= 256 && nv > 0);
    let texels = t.index.len() / nv;
    // SAFETY: the query rows are whole `BatchQuery`s (64 bytes, repr(C), no padding). Every
    // table address is in bounds by the checks below and above: index entry
    // texel·nv + v < index.len(); record ((3v + c)·k + i)·8 + 0..8 with i < k (u8 indices are
    // < k by model validation, and k ≤ 256), read whole by 32-byte aligned loads (`LobeRec` is
    // 32-byte aligned); polynomial row v·nl + l < polys.len() (64-byte
    // aligned rows of 16 f32); bound rows v·nl + l < out_max.len() and v < y_max.len() (4 f32
    // each). Gather offsets fit i32 ([`fits`]). The stores go to locals; `lobes` and `coef`
    // are read only after every element was written (see there).
    unsafe {
        let ci = |x: i32| _mm512_set1_epi32(x);
        // The queries as lanes: each 64-byte query is one row (lanes past n repeat query 0:
        // valid addresses, results dropped), one 16 × 16 transpose makes field f of every
        // query register f (`BatchQuery` is repr(C): texel, vi, vw, li, lw, wo).
        let mut fields = [_mm512_setzero_ps(); 16];
        for (l, row) in fields.iter_mut().enumerate() {
            *row = _mm512_loadu_ps(&q[if l < n { l } else { 0 }] as *const Query as *const f32);
        }
        transpose16(&mut fields);
        let int = _mm512_castps_si512;
        let tex = int(fields[0]);
        let v = [int(fields[1]), int(fields[2]), int(fields[3])];
        let vw = [fields[4], fields[5], fields[6]];
        let (wx, wy, wz) = (fields[13], fields[14], fields[15]);
        // The only checks on the queries, all 16 lanes (unsigned: texel < texels, each view
        // < nv and light < nl); every address below is derived from these.
        let ge = |x: __m512i, bound: usize| _mm512_cmpge_epu32_mask(x, ci(bound as i32));
        let bad =
            ge(tex, texels) | (0..3).fold(0, |m, a| m | ge(v[a], nv) | ge(int(fields[7 + a]), nl));
        assert!(
            bad == 0,
            "PLM-C batch: a texel, view or light index out of range"
        );
        let gf = |base: *const f32, off: __m512i| _mm512_i32gather_ps::<4>(off, base as *const _);
        let index = t.index.as_ptr() as *const i32;
        let rec = t.records.as_ptr() as *const f32;
        let poly = t.polys.as_ptr() as *const f32;
        let omax = t.out_max.as_ptr() as *const f32;
        let ymax = t.y_max.as_ptr() as *const f32;
        let zero = _mm512_setzero_ps();
        // y of view a, channel c, then the blend of the views.
        let mut y = [[zero; 3]; 3];
        // Every load that depends on the texel is issued first, in program order: the 3 index
        // entries (usually DRAM misses for a large material), then the 9 lobe records, so that
        // the misses of all 16 queries are in flight together instead of view by view. The
        // record offsets go through memory: each lane's records are read by scalar-addressed
        // 32-byte loads, two (view, channel) pairs per 16 × 16 transpose.
        let mut ent = [_mm512_setzero_si512(); 3];
        for a in 0..3 {
            let off = _mm512_add_epi32(_mm512_mullo_epi32(tex, ci(nv as i32)), v[a]);
            ent[a] = _mm512_i32gather_epi32::<4>(off, index as *const _);
        }
        // Lobe field f of (view a, channel c): `lobes[a][c][f]`, every one written by the
        // transposes below (left uninitialised until then: zeroing it cost a 2.5 KB memset).
        let mut lobes = MaybeUninit::<[[[__m512; 5]; 3]; 3]>::uninit();
        let lobe_at = lobes.as_mut_ptr() as *mut __m512;
        // Record offsets (f32 units) of the 9 (view, channel) lobes per lane.
        let mut offs = [[0i32; BATCH]; 9];
        for a in 0..3 {
            let rbase = _mm512_mullo_epi32(v[a], ci(3 * k as i32));
            let e = ent[a];
            let cls = [
                _mm512_and_si512(e, ci(0xff)),
                _mm512_and_si512(_mm512_srli_epi32::<8>(e), ci(0xff)),
                _mm512_and_si512(_mm512_srli_epi32::<16>(e), ci(0xff)),
            ];
            for c in 0..3 {
                let r = _mm512_add_epi32(_mm512_add_epi32(rbase, ci((c * k) as i32)), cls[c]);
                _mm512_storeu_si512(
                    offs[3 * a + c].as_mut_ptr() as *mut _,
                    _mm512_slli_epi32::<3>(r),
                );
            }
        }
        // Two (view, channel) pairs g0, g1 per transpose: row l holds lane l's record of g0
        // (floats 0..8) and of g1 (8..16); after the transpose field f of g0 is `rows[f]`, of
        // g1 `rows[8 + f]` (the ninth pair alone, its upper half zero).
        for p in 0..5 {
            let (g0, g1) = (2 * p, (2 * p + 1).min(8));
            let mut rows = [zero; 16];
            for (l, row) in rows.iter_mut().enumerate() {
                let lo = _mm512_zextpd256_pd512(_mm256_load_pd(
                    rec.add(offs[g0][l] as usize) as *const f64
                ));
                *row = _mm512_castpd_ps(if g1 == g0 {
                    lo
                } else {
                    _mm512_insertf64x4::<1>(
                        lo,
                        _mm256_load_pd(rec.add(offs[g1][l] as usize) as *const f64),
                    )
                });
            }
            transpose16(&mut rows);
            // (Pair g = 3 a + c is `lobes[a][c]`: fields 5 g .. 5 g + 5 in order.)
            for f in 0..5 {
                lobe_at.add(5 * g0 + f).write(rows[f]);
                if g1 != g0 {
                    lobe_at.add(5 * g1 + f).write(rows[8 + f]);
                }
            }
        }
        // Every pair g0 = 0, 2, 4, 6, 8 and g1 = 1, 3, 5, 7 was written above.
        let lobes = lobes.assume_init_ref();
        // Per query, the light-interpolated polynomial row of each view (w0·r0, + w1·r1, + w2·r2
        // on whole 16-float rows, as the single-query kernel) and the 3 views' output bounds
        // (largest of the 3 lights'); then 16 × 16 transposes make them lanes: coefficient
        // a_j of channel c is `coef[a][3 j + c]`, the bound of view a, channel c `bounds[4 a + c]`.
        // Whole-row loads and shuffles instead of 16-lane gathers (5 × as many loads).
        // (`coef` left uninitialised until the loop below writes each of its 3 × 16 rows:
        // zeroing it cost a 3 KB memset.)
        let mut coef_rows = MaybeUninit::<[[__m512; 16]; 3]>::uninit();
        let coef_at = coef_rows.as_mut_ptr() as *mut __m512;
        let mut bounds = [zero; 16];
        for l in 0..BATCH {
            let s = &q[if l < n { l } else { 0 }];
            let (sw0, sw1, sw2) = (splat(s.lw[0]), splat(s.lw[1]), splat(s.lw[2]));
            let mut om = [_mm_setzero_ps(); 4];
            for a in 0..3 {
                let base = s.vi[a] as usize * nl;
                let row = |b: usize| _mm512_load_ps(poly.add((base + s.li[b] as usize) * 16));
                let r = _mm512_mul_ps(sw0, row(0));
                let r = _mm512_fmadd_ps(sw1, row(1), r);
                coef_at
                    .add(16 * a + l)
                    .write(_mm512_fmadd_ps(sw2, row(2), r));
                let bound = |b: usize| _mm_loadu_ps(omax.add((base + s.li[b] as usize) * 4));
                om[a] = _mm_max_ps(_mm_max_ps(bound(0), bound(1)), bound(2));
            }
            bounds[l] = _mm512_insertf32x4::<2>(
                _mm512_insertf32x4::<1>(_mm512_zextps128_ps512(om[0]), om[1]),
                om[2],
            );
        }
        // Rows a = 0..3, lanes l = 0..BATCH (= 16) were all written above.
        let coef = coef_rows.assume_init_mut();
        for c in coef.iter_mut() {
            transpose16(c);
        }
        transpose16(&mut bounds);
        for a in 0..3 {
            let v = v[a];
            for c in 0..3 {
                let cf = [0, 1, 2, 3, 4].map(|j| coef[a][3 * j + c]);
                let y_max = gf(
                    ymax,
                    _mm512_add_epi32(_mm512_slli_epi32::<2>(v), ci(c as i32)),
                );
                let yy = lobe_value(lobes[a][c], [wx, wy, wz]);
                y[a][c] = map_decode(yy, y_max, &cf, bounds[4 * a + c], t.srgb);
            }
        }
        // Blend the views: vw0·y0, + vw1·y1, + vw2·y2 (the single-query kernel's order).
        let [v0, v1, v2] = vw;
        let mut res = [[0f32; BATCH]; 3];
        for c in 0..3 {
            let o = _mm512_mul_ps(v0, y[0][c]);
            let o = _mm512_fmadd_ps(v1, y[1][c], o);
            let o = _mm512_fmadd_ps(v2, y[2][c], o);
            _mm512_storeu_ps(res[c].as_mut_ptr(), o);
        }
        for (l, o) in out.iter_mut().enumerate() {
            *o = [res[0][l], res[1][l], res[2][l]];
        }
    }
}
