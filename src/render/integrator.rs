//! What the integrators share: their resolved settings ([`Integrator`]), trace counters, the
//! camera's first hit, shadow segments and the MIS power heuristic, each with the `_x` twin
//! the packet kernel runs. The integrators themselves are peers that trace a tile's samples:
//! the scalar path tracer ([`super::path`], the test oracle), Mitsuba's `direct`
//! ([`super::direct`]) and the packet kernel ([`super::packet`]).

// `!(x > 0.0)` deliberately also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::RenderScene;
use crate::geometry::accel::offset_origin;
use crate::geometry::accel::offset_origin_x;
use crate::geometry::shading::surface_interaction;
use crate::light::LightSampleX;
use crate::math::simd::f16::{F16, M16, V3x};
use crate::math::{Pcg32, Vec3};
use crate::scene::{DirectSettings, IntegratorSettings};
use crate::{Error, Result};

/// Counters a worker keeps while tracing (summed for progress and the final report).
#[derive(Clone, Copy, Debug, Default)]
pub struct TraceStats {
    /// Rays traced (camera, continuation and shadow rays).
    pub rays: u64,
}

/// The scene's integrator with its parameters resolved from [`IntegratorSettings`]: Mitsuba's
/// `path` ([`super::path`]) or, with [`Integrator::direct`] set, its `direct` ([`super::direct`]);
/// the packet kernel runs the `path` one lane by lane.
#[derive(Clone, Copy, Debug)]
pub struct Integrator {
    /// Longest path in vertices; `u32::MAX` for unbounded.
    pub max_depth: u32,
    pub rr_depth: u32,
    pub hide_emitters: bool,
    /// Next-event estimation on (the default). Off = pure BSDF sampling, used to cross-check MIS.
    pub nee: bool,
    /// Some: Mitsuba's `direct` integrator ([`super::direct`]) instead of path tracing.
    pub direct: Option<DirectSettings>,
}

impl Integrator {
    /// Validates Mitsuba's settings.
    pub fn new(s: &IntegratorSettings) -> Result<Integrator> {
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
        Ok(Integrator {
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
}

/// The random stream of sample `sample` of film pixel (`x`, `y`) and the film position it
/// draws first, jittered uniformly inside the pixel: where every integrator starts a camera path
/// (the packet refill's SoA twin is `Pcg32x::for_samples` plus two draws).
#[inline]
pub fn film_sample_start(
    seed: u64,
    film_width: u32,
    x: u32,
    y: u32,
    sample: u64,
) -> (Pcg32, f32, f32) {
    let pixel = y as u64 * film_width as u64 + x as u64;
    let mut rng = Pcg32::for_sample(seed, pixel, sample);
    let fx = x as f32 + rng.next_f32();
    let fy = y as f32 + rng.next_f32();
    (rng, fx, fy)
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
pub(super) fn shadow_segment_from_x(p: V3x, n: V3x, ls: &LightSampleX) -> (V3x, V3x, F16, M16) {
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
    let ok = len.gt(F16::splat(0.0));
    (
        so,
        V3x::select(infinite, ls.wi, to.div(len)),
        F16::select(infinite, F16::splat(f32::INFINITY), len * (1.0 - 1e-4)),
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
pub fn mis_weight_x(pdf_a: F16, pdf_b: F16) -> F16 {
    let a = pdf_a * pdf_a;
    let b = pdf_b * pdf_b;
    let w = a / (a + b);
    F16::select(w.is_finite(), w, F16::splat(0.0))
}

/// Power heuristic with β = 2; 0 where undefined (Mitsuba's `mis_weight`).
#[inline]
pub fn mis_weight(pdf_a: f32, pdf_b: f32) -> f32 {
    let a = pdf_a * pdf_a;
    let b = pdf_b * pdf_b;
    let w = a / (a + b);
    if w.is_finite() { w } else { 0.0 }
}
