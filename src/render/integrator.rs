//! Unidirectional path tracing with next-event estimation and MIS (power heuristic), following
//! Mitsuba 3's `path` integrator: max_depth counts path vertices (1 = emitters seen directly,
//! 2 = direct lighting, −1 = unbounded), Russian roulette from `rr_depth` with
//! q = min(max(throughput)·η², 0.95), and `hide_emitters` hiding what the camera sees directly
//! (area emitters are skipped by camera rays, the environment is black behind them).

// `!(x > 0.0)` deliberately also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::RenderScene;
use crate::bsdf::BsdfFlags;
use crate::geometry::accel::offset_origin;
use crate::geometry::accel::offset_origin_x;
use crate::geometry::shading::surface_interaction;
use crate::light::LightSampleX;
use crate::math::simd::wide::{Fx, Mx, V3x};
use crate::math::{Pcg32, Spectrum, Vec3};
use crate::scene::{DirectSettings, IntegratorSettings};
use crate::{Error, Result};

/// Counters a worker keeps while tracing (summed for progress and the final report).
#[derive(Clone, Copy, Debug, Default)]
pub struct TraceStats {
    /// Rays traced (camera, continuation and shadow rays).
    pub rays: u64,
}

/// Integrator parameters resolved from [`IntegratorSettings`].
#[derive(Clone, Copy, Debug)]
pub struct PathTracer {
    /// Longest path in vertices; `u32::MAX` for unbounded.
    pub max_depth: u32,
    pub rr_depth: u32,
    pub hide_emitters: bool,
    /// Next-event estimation on (the default). Off = pure BSDF sampling, used to cross-check MIS.
    pub nee: bool,
    /// Some: Mitsuba's `direct` integrator ([`super::direct`]) instead of path tracing.
    pub direct: Option<DirectSettings>,
}

impl PathTracer {
    /// Validates Mitsuba's settings.
    pub fn new(s: &IntegratorSettings) -> Result<PathTracer> {
        if s.max_depth < -1 {
            return Err(Error::Invalid(format!(
                "integrator max_depth = {} (must be ≥ −1)",
                s.max_depth
            )));
        }
        if s.rr_depth < 1 {
            return Err(Error::Invalid(format!(
                "integrator rr_depth = {} (must be ≥ 1)",
                s.rr_depth
            )));
        }
        Ok(PathTracer {
            max_depth: if s.max_depth < 0 {
                u32::MAX
            } else {
                s.max_depth as u32
            },
            rr_depth: s.rr_depth as u32,
            hide_emitters: s.hide_emitters,
            nee: true,
            direct: s.direct,
        })
    }

    /// Radiance arriving at `o` from direction `d` (unit) within distance `tmax`.
    pub fn li(
        &self,
        rs: &RenderScene,
        o: Vec3,
        d: Vec3,
        tmax: f32,
        rng: &mut Pcg32,
        stats: &mut TraceStats,
    ) -> Spectrum {
        if let Some(ds) = &self.direct {
            return super::direct::li(ds, self.hide_emitters, rs, o, d, tmax, rng, stats);
        }
        let mut result = Spectrum::ZERO;
        if self.max_depth == 0 {
            return result;
        }
        let meshes = &rs.scene.meshes;
        let lights = &rs.lights;
        let mut throughput = Spectrum::ONE;
        let mut eta = 1.0f32;
        let mut depth = 0u32;
        let mut prev_p = o;
        let mut prev_pdf = 1.0f32;
        let mut prev_delta = true;
        let mut ray_d = d;
        let (mut hit, mut ray_o) = camera_hit(rs, o, d, tmax, self.hide_emitters, stats);
        loop {
            let Some(h) = hit else {
                // Escaped: lights at infinity (hidden from the camera with hide_emitters).
                if !(depth == 0 && self.hide_emitters) {
                    for k in 0..lights.infinite_count() {
                        let (le, pdf_e) = lights.eval_infinite(k, ray_d);
                        let em_pdf = if prev_delta || !self.nee { 0.0 } else { pdf_e };
                        result += throughput * le * mis_weight(prev_pdf, em_pdf);
                    }
                }
                break;
            };
            let si = surface_interaction(meshes, ray_o, ray_d, &h);
            if lights.is_emissive(h.mesh) {
                let le = lights.area_radiance(meshes, &si);
                if le != Spectrum::ZERO {
                    let em_pdf = if prev_delta || !self.nee {
                        0.0
                    } else {
                        lights.pdf_area_hit(prev_p, &si)
                    };
                    result += throughput * le * mis_weight(prev_pdf, em_pdf);
                }
            }
            if depth.saturating_add(1) >= self.max_depth {
                break;
            }
            let mesh = &meshes[h.mesh as usize];
            let Some(bsdf) = rs.scene.bsdfs.get(mesh.bsdf as usize) else {
                break;
            };
            // The BSDF at this hit: the calls below share its per-hit state (a BTF
            // model's view lookup and texels).
            let bsdf = bsdf.at(&si);
            // ------------------------- emitter sampling -------------------------
            if self.nee && bsdf.flags().has(BsdfFlags::SMOOTH) {
                let u_sel = rng.next_f32();
                let u = rng.next_2d();
                if let Some(ls) = lights.sample(si.p, u_sel, u) {
                    let wo = si.to_local(ls.wi);
                    // One call for both: BSDFs with a per-hit lookup (BTF) share it.
                    let (f, bsdf_pdf) = bsdf.eval_for_light(&si, wo, ls.delta);
                    if f != Spectrum::ZERO
                        && ls.weight != Spectrum::ZERO
                        && !occluded(rs, &si, &ls, stats)
                    {
                        let mis = if ls.delta {
                            1.0
                        } else {
                            mis_weight(ls.pdf, bsdf_pdf)
                        };
                        result += throughput * f * ls.weight * mis;
                    }
                }
            }
            // -------------------------- BSDF sampling ---------------------------
            let u1 = rng.next_f32();
            let u2 = rng.next_2d();
            let Some((bs, weight)) = bsdf.sample(&si, u1, u2) else {
                break;
            };
            let wo_world = si.to_world(bs.wo);
            throughput *= weight;
            eta *= bs.eta;
            prev_p = si.p;
            prev_pdf = bs.pdf;
            prev_delta = bs.sampled.has(BsdfFlags::DELTA);
            depth += 1;
            let t_max = throughput.max_element();
            if depth >= self.rr_depth {
                let q = (t_max * eta * eta).min(0.95);
                if !(rng.next_f32() < q) {
                    break;
                }
                throughput /= q;
            }
            if !(t_max > 0.0) {
                break;
            }
            ray_o = offset_origin(si.p, si.n, wo_world);
            ray_d = wo_world;
            stats.rays += 1;
            hit = rs.accel.intersect(ray_o, ray_d, f32::INFINITY);
        }
        result
    }
}

/// The first hit of a camera ray from `o` along `d` within `tmax`; with `hide_emitters` area
/// emitters are passed through (Mitsuba's `skip_area_emitters`). Returns the hit and the origin
/// of the ray that found it.
pub(super) fn camera_hit(
    rs: &RenderScene,
    o: Vec3,
    d: Vec3,
    tmax: f32,
    hide_emitters: bool,
    stats: &mut TraceStats,
) -> (Option<crate::geometry::accel::Hit>, Vec3) {
    let (mut ray_o, mut ray_t) = (o, tmax);
    stats.rays += 1;
    let mut hit = rs.accel.intersect(ray_o, d, ray_t);
    if hide_emitters {
        while let Some(h) = hit {
            if !rs.lights.is_emissive(h.mesh) {
                break;
            }
            let si = surface_interaction(&rs.scene.meshes, ray_o, d, &h);
            let travelled = (si.p - o).length();
            ray_o = offset_origin(si.p, si.n, d);
            ray_t = tmax - travelled;
            stats.rays += 1;
            hit = if ray_t > 0.0 {
                rs.accel.intersect(ray_o, d, ray_t)
            } else {
                None
            };
        }
    }
    (hit, ray_o)
}

/// The shadow segment from the point `p` (unit geometric normal `n`) to the emitter sample
/// `ls`: (origin, unit direction, extent), both ends offset off their surfaces and the extent
/// shortened by 1e-4 (∞ toward lights at infinity); None for a zero-length segment, which
/// nothing can block. The packet kernel traces exactly this ray ([`shadow_segment_from_x`]).
#[inline(always)]
pub(super) fn shadow_segment_from(
    p: Vec3,
    n: Vec3,
    ls: &crate::light::LightSample,
) -> Option<(Vec3, Vec3, f32)> {
    let so = offset_origin(p, n, ls.wi);
    if !ls.dist.is_finite() {
        return Some((so, ls.wi, f32::INFINITY));
    }
    let target = if ls.n_geo != Vec3::ZERO {
        offset_origin(p + ls.wi * ls.dist, ls.n_geo, -ls.wi)
    } else {
        p + ls.wi * ls.dist
    };
    let to = target - so;
    let len = to.length();
    (len > 0.0).then(|| (so, to / len, len * (1.0 - 1e-4)))
}

/// [`shadow_segment_from`] per lane: (origin, direction, extent, valid); valid is false where
/// that returns None.
#[inline(always)]
pub(super) fn shadow_segment_from_x(p: V3x, n: V3x, ls: &LightSampleX) -> (V3x, V3x, Fx, Mx) {
    let so = offset_origin_x(p, n, ls.wi);
    let infinite = ls.dist.is_finite().not();
    let at = p.add(ls.wi.scale(ls.dist));
    let target = V3x::select(
        ls.n_geo.is_zero(),
        at,
        offset_origin_x(at, ls.n_geo, ls.wi.neg()),
    );
    let to = target.sub(so);
    let len = to.length();
    let ok = len.gt(Fx::splat(0.0));
    (
        so,
        V3x::select(infinite, ls.wi, to.div(len)),
        Fx::select(infinite, Fx::splat(f32::INFINITY), len * (1.0 - 1e-4)),
        infinite.or(ok),
    )
}

/// True if the shadow ray from `si` to the emitter sample `ls` is blocked (one ray counted).
pub(super) fn occluded(
    rs: &RenderScene,
    si: &crate::geometry::intersection::SurfaceInteraction,
    ls: &crate::light::LightSample,
    stats: &mut TraceStats,
) -> bool {
    stats.rays += 1;
    shadow_segment_from(si.p, si.n, ls).is_some_and(|(o, d, t)| rs.accel.occluded(o, d, t))
}

/// [`mis_weight`] per lane.
#[inline(always)]
pub fn mis_weight_x(pdf_a: Fx, pdf_b: Fx) -> Fx {
    let a = pdf_a * pdf_a;
    let b = pdf_b * pdf_b;
    let w = a / (a + b);
    Fx::select(w.is_finite(), w, Fx::splat(0.0))
}

/// Power heuristic with β = 2; 0 where undefined (Mitsuba's `mis_weight`).
#[inline]
pub fn mis_weight(pdf_a: f32, pdf_b: f32) -> f32 {
    let a = pdf_a * pdf_a;
    let b = pdf_b * pdf_b;
    let w = a / (a + b);
    if w.is_finite() { w } else { 0.0 }
}
