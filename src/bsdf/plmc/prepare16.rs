//! [`PlmcBsdf::prepare`] of a whole packet batch at once: the 16 view directions located by one
//! 16-lane search ([`DirectionInterp::locate16`](crate::btf::directions::DirectionInterp::locate16)) instead of 16
//! scalar searches, whose data-dependent branches (single-triangle cell or not, which candidate
//! wins) mispredict about once per hit.

use super::bsdf::{PlmcBsdf, PlmcHit};
use super::lobes::HitLobes;
use crate::btf::locate16::LOCATE_LANES;
use crate::math::Vec2;
use std::mem::MaybeUninit;

/// Shading points of one [`PlmcBsdf::prepare16`] call (one per packet lane).
pub const PREPARE_LANES: usize = LOCATE_LANES;

impl PlmcBsdf {
    /// [`PlmcBsdf::prepare`] of the shading points whose local ω_i is `(wx[l], wy[l], wz[l])`
    /// and uv `(u[l], v[l])`, for the lanes `l` whose bit is set in `lanes`, with the same index
    /// prefetches: the lanes where `prepare` returns a hit (all but those below the horizon)
    /// get it, to the bit, written in lane order to `hits[j]` with the lane in `lane[j]`;
    /// returns how many. Written in place: a packet's 16 hits are ~6 KB, which a returned
    /// array copied twice per batch. Lanes not in `lanes` may hold anything.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    pub fn prepare16(
        &self,
        [wx, wy, wz]: [&[f32; PREPARE_LANES]; 3],
        [u, v]: [&[f32; PREPARE_LANES]; 2],
        lanes: u16,
        hits: &mut [MaybeUninit<PlmcHit>; PREPARE_LANES],
        lane: &mut [u8; PREPARE_LANES],
    ) -> usize {
        let m = &**self.material();
        if lanes == 0 {
            return 0;
        }
        // Only the lanes whose hit is kept are searched (`prepare`'s test: NaN z passes it).
        let kept = (0..PREPARE_LANES)
            .filter(|&l| lanes & (1 << l) != 0 && !(wz[l] <= 0.0))
            .fold(0u16, |k, l| k | 1 << l);
        let located = m.views.locate16_lanes(wx, wy, kept);
        // Nearest texels of all 16 lanes at once where the CPU has AVX2 or AVX-512 (lanes not
        // in `lanes` are computed too: plain arithmetic on whatever they hold).
        #[cfg(target_arch = "x86_64")]
        let near = (!self.bilinear
            && m.isa.level() >= crate::math::simd::Level::Avx2
            && nearest16_fits(m.width, m.height))
        .then(|| {
            // SAFETY: `simd::isa()` gives `Level::Avx2` or above only on CPUs with AVX2.
            unsafe { nearest16(self.uv_scale, m.width, m.height, u, v) }
        });
        #[cfg(not(target_arch = "x86_64"))]
        let near: Option<[u32; PREPARE_LANES]> = None;
        let span = m.index_span();
        let mut n_hits = 0;
        for l in 0..PREPARE_LANES {
            // `prepare`'s test: NaN z passes it, as there.
            if kept & (1 << l) == 0 {
                continue;
            }
            let uv = Vec2::new(u[l], v[l]);
            // `texels` (inlined here for the nearest texel: its 64-byte result, returned
            // through memory, stalled the loads that read it back).
            let (texels, n) = if let Some(near) = &near {
                ([(near[l] as usize, 1.0), (0, 0.0), (0, 0.0), (0, 0.0)], 1)
            } else if self.bilinear {
                self.texels(uv)
            } else {
                let (x, y) = self.texel(uv);
                ([(y * m.width + x, 1.0), (0, 0.0), (0, 0.0), (0, 0.0)], 1)
            };
            let (t, w) = located.lane(l);
            let (vi, vw) = m.views.interpolation(t, w);
            if self.prefetch {
                for &(texel, _) in &texels[..n] {
                    span.prefetch_views(texel, vi);
                }
            }
            hits[n_hits] = MaybeUninit::new(PlmcHit {
                vi,
                vw,
                texels,
                n: n as u8,
                lobes: HitLobes::default(),
            });
            lane[n_hits] = l as u8;
            n_hits += 1;
        }
        // The lobes after every lane's prefetch was issued (they read those index entries).
        for h in &mut hits[..n_hits] {
            // SAFETY: the loop above wrote entries 0..n_hits.
            let h = unsafe { h.assume_init_mut() };
            if let Some(lobes) = m.hit_lobes(h.vi, h.vw, &h.texels[..h.n as usize]) {
                h.lobes = lobes;
            }
        }
        n_hits
    }
}

/// True if [`nearest16`]'s 32-bit arithmetic is exact for a `width` × `height` material: both
/// sides at most 2^24 (every `n − 1` an exact f32) and every texel index below 2^31.
#[cfg(target_arch = "x86_64")]
fn nearest16_fits(width: usize, height: usize) -> bool {
    width <= 1 << 24 && height <= 1 << 24 && width.checked_mul(height).is_some_and(|t| t <= 1 << 31)
}

/// [`PlmcBsdf::texel`] of 16 uv points as texel indices `y · width + x`, to the bit, in two
/// passes of 8 AVX2 lanes (one build for AVX2 and AVX-512 CPUs: a 16-lane pass would save a
/// handful of instructions per 16 hits): per axis `((c · scale − ⌊c · scale⌋) · n)` clamped
/// to [0, n − 1] before the truncation instead of after it (the same integer for every input:
/// NaN and negatives give 0 both ways, `vmaxps` returning its second operand, 0, for a NaN
/// first one; +∞ and values past n − 1 give n − 1, `n − 1` being an exact f32 by
/// [`nearest16_fits`]); the rounding-mode floor (`vroundps` toward −∞) is `floor_fast`'s value
/// for every f32.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn nearest16(
    scale: f32,
    width: usize,
    height: usize,
    u: &[f32; PREPARE_LANES],
    v: &[f32; PREPARE_LANES],
) -> [u32; PREPARE_LANES] {
    use core::arch::x86_64::*;
    debug_assert!(nearest16_fits(width, height));
    let axis = |c: __m256, n: usize| {
        let s = _mm256_mul_ps(c, _mm256_set1_ps(scale));
        let fl = _mm256_floor_ps(s);
        let x = _mm256_mul_ps(_mm256_sub_ps(s, fl), _mm256_set1_ps(n as f32));
        let x = _mm256_max_ps(x, _mm256_setzero_ps());
        _mm256_cvttps_epi32(_mm256_min_ps(x, _mm256_set1_ps((n - 1) as f32)))
    };
    let mut out = [0u32; PREPARE_LANES];
    for h in 0..PREPARE_LANES / 8 {
        // SAFETY: 8-float loads of `u` and `v` and an 8-u32 store to `out`, at 8 h < 16.
        unsafe {
            let x = axis(_mm256_loadu_ps(u.as_ptr().add(8 * h)), width);
            let y = axis(_mm256_loadu_ps(v.as_ptr().add(8 * h)), height);
            let t = _mm256_add_epi32(_mm256_mullo_epi32(y, _mm256_set1_epi32(width as i32)), x);
            _mm256_storeu_si256(out.as_mut_ptr().add(8 * h) as *mut __m256i, t);
        }
    }
    out
}
