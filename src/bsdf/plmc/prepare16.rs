//! [`PlmcBsdf::prepare`] of a whole packet batch at once: the 16 view directions located by one
//! 16-lane search ([`DirectionInterp::locate16`](crate::btf::directions::DirectionInterp::locate16)) instead of 16
//! scalar searches, whose data-dependent branches (single-triangle cell or not, which candidate
//! wins) mispredict about once per hit.

use super::bsdf::{PlmcBsdf, PlmcHit};
use crate::btf::locate16::LOCATE_LANES;
use crate::math::Vec2;

/// Shading points of one [`PlmcBsdf::prepare16`] call (one per packet lane).
pub const PREPARE_LANES: usize = LOCATE_LANES;

impl PlmcBsdf {
    /// [`PlmcBsdf::prepare`] of the shading points whose local ω_i is `(wx[l], wy[l], wz[l])`
    /// and uv `(u[l], v[l])`, for the lanes `l` whose bit is set in `lanes`: hit `l` is what
    /// `prepare` returns for that point, to the bit (None below the horizon and for lanes not in
    /// `lanes`), with the same index prefetches. Lanes not in `lanes` may hold anything.
    pub fn prepare16(
        &self,
        [wx, wy, wz]: [&[f32; PREPARE_LANES]; 3],
        [u, v]: [&[f32; PREPARE_LANES]; 2],
        lanes: u16,
    ) -> [Option<PlmcHit>; PREPARE_LANES] {
        let m = &**self.material();
        let mut out = [None; PREPARE_LANES];
        if lanes == 0 {
            return out;
        }
        let located = m.views.locate16(wx, wy);
        let (index, entry, entries) = m.index_span();
        let nv = m.n_views;
        for (l, o) in out.iter_mut().enumerate() {
            // `prepare`'s test: NaN z passes it, as there.
            if lanes & (1 << l) == 0 || wz[l] <= 0.0 {
                continue;
            }
            let uv = Vec2::new(u[l], v[l]);
            // `texels` (inlined here for the nearest texel: its 64-byte result, returned
            // through memory, stalled the loads that read it back).
            let (texels, n) = if self.bilinear {
                self.texels(uv)
            } else {
                let (x, y) = self.texel(uv);
                ([(y * m.width + x, 1.0), (0, 0.0), (0, 0.0), (0, 0.0)], 1)
            };
            let (t, w) = located.lane(l);
            let (vi, vw) = m.views.interpolation(t, w);
            if self.prefetch {
                // `PlmcMaterial::prefetch_views` without its per-call dispatch on the layout.
                for &(texel, _) in &texels[..n] {
                    for v in vi {
                        let i = texel.wrapping_mul(nv).wrapping_add(v as usize);
                        if (v as usize) < nv && i < entries {
                            prefetch(index + i * entry);
                        }
                    }
                }
            }
            *o = Some(PlmcHit {
                vi,
                vw,
                texels,
                n: n as u8,
            });
        }
        out
    }
}

/// Starts loading the cache line of `addr` (a hint: never faults).
#[inline(always)]
fn prefetch(addr: usize) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch never faults, whatever the address.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(addr as *const i8)
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = addr;
}
