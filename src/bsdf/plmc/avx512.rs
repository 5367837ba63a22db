//! The PLM-C kernel (u8 cluster indices, nearest texel, with polynomials) on 16-lane AVX-512
//! registers: the 3 views × (R, G, B, pad) are lanes `4 a + c` of one register (lanes 12..15
//! unused), so every stage of the dependent chain (Lafortune base, log2, exp2, polynomial,
//! decode) is one instruction for all 9 values instead of three (SSE/AVX2 4-wide), and
//! AVX-512F's `vgetexp`/`vgetmant`/`vscalef` replace the integer bit tricks of the F4 exp2 and
//! log2 (`math::simd::approx`: `fused_exp2_16`, `fused_log2_16`).
//!
//! Same arithmetic as the AVX2+FMA build of the generic kernel, operation by operation (same
//! series, same evaluation order, fused multiply-adds at the same places; `vgetmant`/`vgetexp`
//! and `vscalef` are exact): the results agree with it to the last bit on normal inputs, and
//! with the SSE2 build to float rounding.
//!
//! About 170 instructions per evaluation (the generic AVX2 build: ~890, mostly shuffles,
//! spills and bounds checks of the 4-wide lanes).

use super::FLUSH;
pub(super) use super::query::Tables;
use crate::math::simd::approx::{fused_exp2_16, fused_log2_16};
use core::arch::x86_64::*;

/// Lane `4 a + c` of the coefficient `a_j` gathers lane `3 j + c` of view a's interpolated row:
/// from the first operand for a = 0, the second (+16) for a = 1; lanes 8..10 (a = 2) are
/// permuted from the third row in a second, masked step that reads the low 4 bits.
const fn perm(j: i32) -> [i32; 16] {
    let b = 3 * j;
    [
        b,
        b + 1,
        b + 2,
        0,
        16 + b,
        17 + b,
        18 + b,
        16,
        b,
        b + 1,
        b + 2,
        0,
        0,
        0,
        0,
        0,
    ]
}
static PERM: [[i32; 16]; 5] = [perm(0), perm(1), perm(2), perm(3), perm(4)];
/// Lanes of the third view (8, 9, 10).
const VIEW2: __mmask16 = 0x0700;

#[target_feature(enable = "avx512f,avx2,fma")]
#[inline]
pub(super) fn splat(x: f32) -> __m512 {
    _mm512_set1_ps(x)
}

/// The lobes `[ρ, Dx, Dy, Dz, n]` at the light direction `w` (x, y, z lanes): Y = ρ · b^n with
/// b = D·w, 0 where b ≤ 0 or Y < FLUSH (see `eval_views`). Shared by the single-query and the
/// 16-query kernel, so their lanes agree to the bit.
#[target_feature(enable = "avx512f,avx2,fma")]
#[inline]
pub(super) fn lobe_value(l: [__m512; 5], w: [__m512; 3]) -> __m512 {
    let [rho, dx, dy, dz, n] = l;
    let b = _mm512_fmadd_ps(dz, w[2], _mm512_fmadd_ps(dy, w[1], _mm512_mul_ps(dx, w[0])));
    let lg = fused_log2_16(_mm512_max_ps(b, splat(1e-30)));
    let pw = fused_exp2_16(_mm512_max_ps(_mm512_mul_ps(n, lg), splat(-100.0)));
    let y = _mm512_mul_ps(rho, pw);
    let zero = _mm512_setzero_ps();
    let keep = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(b, zero)
        & _mm512_cmp_ps_mask::<_CMP_GT_OQ>(y, splat(FLUSH));
    _mm512_maskz_mov_ps(keep, y)
}

/// The mapping of lobe values `y`: clamp to `y_max`, the polynomial `a_0..a_4` (Estrin), clamp
/// to `out_max`, then to linear: `srgb_to_linear(max(0, ·))` as `srgb_to_linear_f4` for a model
/// fitted in sRGB, else `max(0, ·)`.
#[target_feature(enable = "avx512f,avx2,fma")]
#[inline]
pub(super) fn map_decode(
    y: __m512,
    y_max: __m512,
    a: &[__m512; 5],
    out_max: __m512,
    srgb: bool,
) -> __m512 {
    let zero = _mm512_setzero_ps();
    let x = _mm512_min_ps(y, y_max);
    let x2 = _mm512_mul_ps(x, x);
    let lo = _mm512_fmadd_ps(a[1], x, a[0]);
    let hi = _mm512_fmadd_ps(a[4], x2, _mm512_fmadd_ps(a[3], x, a[2]));
    let y = _mm512_min_ps(_mm512_fmadd_ps(hi, x2, lo), out_max);
    if srgb {
        let v = _mm512_max_ps(y, zero);
        let lin = _mm512_mul_ps(v, splat(1.0 / 12.92));
        let base = _mm512_max_ps(
            _mm512_mul_ps(_mm512_add_ps(v, splat(0.055)), splat(1.0 / 1.055)),
            splat(1e-30),
        );
        let pow = fused_exp2_16(_mm512_mul_ps(splat(2.4), fused_log2_16(base)));
        let small = _mm512_cmp_ps_mask::<_CMP_LE_OS>(v, splat(0.04045));
        _mm512_mask_blend_ps(small, pow, lin)
    } else {
        _mm512_max_ps(y, zero)
    }
}

/// Four f32 at `p` (16-byte aligned) in the low block of a register, the rest 0.
#[target_feature(enable = "avx512f,avx2,fma")]
#[inline]
unsafe fn block0(p: *const f32) -> __m512 {
    // SAFETY: the caller passes a readable, 16-byte aligned pointer.
    _mm512_zextps128_ps512(unsafe { _mm_load_ps(p) })
}

/// Blocks 0, 1, 2 from three 16-byte aligned pointers, block 3 zero.
#[target_feature(enable = "avx512f,avx2,fma")]
#[inline]
unsafe fn blocks3(p: [*const f32; 3]) -> __m512 {
    // SAFETY: the caller passes readable, 16-byte aligned pointers.
    unsafe {
        let z = block0(p[0]);
        let z = _mm512_insertf32x4::<1>(z, _mm_load_ps(p[1]));
        _mm512_insertf32x4::<2>(z, _mm_load_ps(p[2]))
    }
}

/// B (cosine-baked, linear RGB) of `texel` for the views `vi`/`vw` and the lights `li`/`lw`
/// around the light direction `wo`. Panics if a view, light or texel is out of range.
#[target_feature(enable = "avx512f,avx2,fma")]
#[allow(clippy::too_many_arguments)]
pub fn eval(
    t: &Tables,
    vi: [u32; 3],
    vw: [f32; 3],
    li: [u32; 3],
    lw: [f32; 3],
    wo: [f32; 3],
    texel: usize,
) -> [f32; 3] {
    let (nv, nl, k) = (t.n_views, t.n_lights, t.k);
    let vi = vi.map(|v| v as usize);
    let li = li.map(|l| l as usize);
    // The only checks: every address below is derived from these (and from cluster indices,
    // which the model validation keeps below k).
    assert!(vi.iter().all(|&v| v < nv) && li.iter().all(|&l| l < nl));
    assert!(t.index.len() >= nv && texel < t.index.len() / nv);
    assert!(t.records.len() == nv * 3 * k && t.polys.len() == nv * nl);
    assert!(t.out_max.len() == nv * nl && t.y_max.len() == nv);
    // SAFETY: every pointer is in bounds by the checks above: index entry texel·nv + v < len;
    // record (3v + c)·k + i with i < k (validated model); rows and bounds v·nl + l. All
    // element types are 16-byte aligned or larger (LobeRec 32, PolyRow 64, [f32; 4] rows read
    // as unaligned-safe loads below).
    unsafe {
        // Index entries of the 3 views, then the 9 lobe records: issued first, their misses
        // overlap with the polynomial interpolation below.
        let idx = vi.map(|v| *t.index.as_ptr().add(texel * nv + v));
        let rec = |a: usize, c: usize| -> *const f32 {
            t.records
                .as_ptr()
                .add((vi[a] * 3 + c) * k + idx[a][c] as usize) as *const f32
        };
        let lanes = |c: usize| blocks3([rec(0, c), rec(1, c), rec(2, c)]);
        let hi_lanes = |c: usize| blocks3([rec(0, c).add(4), rec(1, c).add(4), rec(2, c).add(4)]);
        let (zr, zg, zb) = (lanes(0), lanes(1), lanes(2));
        let (nr, ng, nb) = (hi_lanes(0), hi_lanes(1), hi_lanes(2));
        // Per 128-bit block, the 4 × 4 transpose of the records (R, G, B, 0) → ρ, Dx, Dy, Dz.
        let zero = _mm512_setzero_ps();
        let t0 = _mm512_unpacklo_ps(zr, zg);
        let t1 = _mm512_unpacklo_ps(zb, zero);
        let t2 = _mm512_unpackhi_ps(zr, zg);
        let t3 = _mm512_unpackhi_ps(zb, zero);
        let lo64 = |a: __m512, b: __m512| {
            _mm512_castpd_ps(_mm512_unpacklo_pd(_mm512_castps_pd(a), _mm512_castps_pd(b)))
        };
        let hi64 = |a: __m512, b: __m512| {
            _mm512_castpd_ps(_mm512_unpackhi_pd(_mm512_castps_pd(a), _mm512_castps_pd(b)))
        };
        let rho = lo64(t0, t1);
        let dx = hi64(t0, t1);
        let dy = lo64(t2, t3);
        let dz = hi64(t2, t3);
        let n = lo64(_mm512_unpacklo_ps(nr, ng), nb);

        // Light interpolation of the 3 views' polynomial rows (w0·r0, + w1·r1, + w2·r2).
        let (w0, w1, w2) = (splat(lw[0]), splat(lw[1]), splat(lw[2]));
        let row = |a: usize, b: usize| {
            _mm512_load_ps(t.polys.as_ptr().add(vi[a] * nl + li[b]) as *const f32)
        };
        let p = [0, 1, 2].map(|a| {
            let s = _mm512_mul_ps(w0, row(a, 0));
            let s = _mm512_fmadd_ps(w1, row(a, 1), s);
            _mm512_fmadd_ps(w2, row(a, 2), s)
        });
        let coef = |j: usize| {
            let ix = _mm512_loadu_si512(PERM[j].as_ptr() as *const _);
            let ab = _mm512_permutex2var_ps(p[0], ix, p[1]);
            _mm512_mask_permutexvar_ps(ab, VIEW2, ix, p[2])
        };
        let a = [coef(0), coef(1), coef(2), coef(3), coef(4)];
        let bound = |a: usize, b: usize| {
            _mm_loadu_ps(t.out_max.as_ptr().add(vi[a] * nl + li[b]) as *const f32)
        };
        let om = [0, 1, 2].map(|a| _mm_max_ps(_mm_max_ps(bound(a, 0), bound(a, 1)), bound(a, 2)));
        let out_max = _mm512_insertf32x4::<2>(
            _mm512_insertf32x4::<1>(_mm512_zextps128_ps512(om[0]), om[1]),
            om[2],
        );
        let ym = |a: usize| _mm_loadu_ps(t.y_max.as_ptr().add(vi[a]) as *const f32);
        let y_max = _mm512_insertf32x4::<2>(
            _mm512_insertf32x4::<1>(_mm512_zextps128_ps512(ym(0)), ym(1)),
            ym(2),
        );

        let w = [splat(wo[0]), splat(wo[1]), splat(wo[2])];
        let y = map_decode(
            lobe_value([rho, dx, dy, dz, n], w),
            y_max,
            &a,
            out_max,
            t.srgb,
        );
        // Blend the views: vw0·y0, + vw1·y1, + vw2·y2 (the generic kernel's order).
        let y0 = _mm512_castps512_ps128(y);
        let y1 = _mm512_extractf32x4_ps::<1>(y);
        let y2 = _mm512_extractf32x4_ps::<2>(y);
        let o = _mm_mul_ps(_mm_set1_ps(vw[0]), y0);
        let o = _mm_fmadd_ps(_mm_set1_ps(vw[1]), y1, o);
        let o = _mm_fmadd_ps(_mm_set1_ps(vw[2]), y2, o);
        let mut out = [0f32; 4];
        _mm_storeu_ps(out.as_mut_ptr(), o);
        [out[0], out[1], out[2]]
    }
}
