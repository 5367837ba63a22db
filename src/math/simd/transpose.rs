//! Register transposes, 16 × 16 f32 in AVX-512 registers and 8 × 8 in AVX registers: they turn
//! loaded records (one per query) into structure-of-arrays lanes (one register per field) with
//! row loads and shuffles instead of one gather per field.

use core::arch::x86_64::*;

/// Transposes 16 rows of 16 f32 in registers: afterwards `r[e]` holds element e of every input
/// row (lane i = row i). Unpacks within 128-bit blocks, then two rounds of block shuffles.
///
/// # Safety
/// The CPU must have AVX-512F (callers are `avx512f` functions or hold a detection token).
#[target_feature(enable = "avx512f")]
#[inline]
pub fn transpose16(r: &mut [__m512; 16]) {
    let pd = _mm512_castps_pd;
    let ps = _mm512_castpd_ps;
    let mut t = [_mm512_setzero_ps(); 16];
    for i in 0..8 {
        t[2 * i] = _mm512_unpacklo_ps(r[2 * i], r[2 * i + 1]);
        t[2 * i + 1] = _mm512_unpackhi_ps(r[2 * i], r[2 * i + 1]);
    }
    // u[4 i + m], block k: element 4 k + m of rows 4 i .. 4 i + 3.
    let mut u = [_mm512_setzero_ps(); 16];
    for i in 0..4 {
        u[4 * i] = ps(_mm512_unpacklo_pd(pd(t[4 * i]), pd(t[4 * i + 2])));
        u[4 * i + 1] = ps(_mm512_unpackhi_pd(pd(t[4 * i]), pd(t[4 * i + 2])));
        u[4 * i + 2] = ps(_mm512_unpacklo_pd(pd(t[4 * i + 1]), pd(t[4 * i + 3])));
        u[4 * i + 3] = ps(_mm512_unpackhi_pd(pd(t[4 * i + 1]), pd(t[4 * i + 3])));
    }
    for m in 0..4 {
        let (a, b, c, d) = (u[m], u[4 + m], u[8 + m], u[12 + m]);
        let x0 = _mm512_shuffle_f32x4::<0x44>(a, b);
        let x1 = _mm512_shuffle_f32x4::<0xEE>(a, b);
        let y0 = _mm512_shuffle_f32x4::<0x44>(c, d);
        let y1 = _mm512_shuffle_f32x4::<0xEE>(c, d);
        r[m] = _mm512_shuffle_f32x4::<0x88>(x0, y0);
        r[4 + m] = _mm512_shuffle_f32x4::<0xDD>(x0, y0);
        r[8 + m] = _mm512_shuffle_f32x4::<0x88>(x1, y1);
        r[12 + m] = _mm512_shuffle_f32x4::<0xDD>(x1, y1);
    }
}

/// Transposes 8 rows of 8 f32 in AVX registers: afterwards `r[e]` holds element e of every
/// input row (lane i = row i). Unpacks and shuffles within 128-bit blocks, then one round of
/// block permutes.
///
/// # Safety
/// The CPU must have AVX (callers are `avx2` functions or hold a detection token).
#[target_feature(enable = "avx")]
#[inline]
pub fn transpose8(r: &mut [__m256; 8]) {
    let mut t = [_mm256_setzero_ps(); 8];
    for i in 0..4 {
        t[2 * i] = _mm256_unpacklo_ps(r[2 * i], r[2 * i + 1]);
        t[2 * i + 1] = _mm256_unpackhi_ps(r[2 * i], r[2 * i + 1]);
    }
    // u[4 h + m], block k: element 4 k + m of rows 4 h .. 4 h + 3.
    let mut u = [_mm256_setzero_ps(); 8];
    for h in 0..2 {
        let (a, b, c, d) = (t[4 * h], t[4 * h + 1], t[4 * h + 2], t[4 * h + 3]);
        u[4 * h] = _mm256_shuffle_ps::<0x44>(a, c);
        u[4 * h + 1] = _mm256_shuffle_ps::<0xEE>(a, c);
        u[4 * h + 2] = _mm256_shuffle_ps::<0x44>(b, d);
        u[4 * h + 3] = _mm256_shuffle_ps::<0xEE>(b, d);
    }
    for m in 0..4 {
        r[m] = _mm256_permute2f128_ps::<0x20>(u[m], u[4 + m]);
        r[4 + m] = _mm256_permute2f128_ps::<0x31>(u[m], u[4 + m]);
    }
}
