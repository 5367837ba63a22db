//! Unidirectional path tracing with next-event estimation and MIS (power heuristic), one path
//! at a time, following Mitsuba 3's `path` integrator: max_depth counts path vertices
//! (1 = emitters seen directly, 2 = direct lighting, −1 = unbounded), Russian roulette from
//! `rr_depth` with q = min(max(throughput)·η², 0.95), and `hide_emitters` hiding what the camera
//! sees directly (area emitters are skipped by camera rays, the environment is black behind
//! them). The packet kernel replays it lane by lane and is tested against it bit for bit.

// `!(x > 0.0)` deliberately also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::RenderScene;
use super::film::{RenderSettings, Tile};
use super::integrator::{
    Integrator, TraceStats, camera_hit, film_sample_start, mis_weight, occluded,
};
use crate::bsdf::BsdfFlags;
use crate::geometry::accel::offset_origin;
use crate::geometry::shading::surface_interaction;
use crate::math::filter::Filter;
use crate::math::{Pcg32, Spectrum, Vec2, Vec3};
use std::sync::atomic::{AtomicBool, Ordering};

impl Integrator {
    /// Adds samples `tile.done..end` (relative to `s.spp_begin`) to `tile`, one path at a time
    /// in (sample, row, column) order; stops at a sample boundary once `interrupt` is set and
    /// reports each completed sample index (pixel-samples, rays) to `progress`.
    #[allow(clippy::too_many_arguments)]
    pub fn render_tile(
        &self,
        rs: &RenderScene,
        s: &RenderSettings,
        filter: &Filter,
        tile: &mut Tile,
        end: u32,
        interrupt: &AtomicBool,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) {
        let mut extra = Vec::new();
        while tile.done < end {
            if interrupt.load(Ordering::Relaxed) {
                return;
            }
            let mut stats = TraceStats::default();
            let mut invalid = 0;
            let sample = (s.spp_begin + tile.done) as u64;
            for ty in 0..tile.h {
                for tx in 0..tile.w {
                    let (px, py) = (tile.x0 + tx, tile.y0 + ty);
                    let (mut rng, fx, fy) = film_sample_start(s.seed, s.width, px, py, sample);
                    let (o, d, tmax) = rs.camera.sample_ray_rng(fx, fy, &mut rng);
                    let l = self.li(rs, o, d, tmax, &mut rng, &mut stats);
                    extra.clear();
                    extra.resize(tile.extra_channels, 0.0);
                    if !extra.is_empty() {
                        super::channels::sample_values(rs, s, px, py, sample, l, &mut extra);
                    }
                    if !tile.add_sample_with(s, filter, px, py, fx, fy, l, &extra) {
                        invalid += 1;
                    }
                }
            }
            tile.sample_done(stats.rays, invalid);
            progress((tile.w * tile.h) as u64, stats.rays);
        }
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
        self.li_observed(rs, o, d, tmax, rng, stats, &mut |_| {})
    }

    /// [`Integrator::li`] (the same value and random numbers) that reports every BSDF sample
    /// and every radiance contribution of the path to `observe`, for tools that ask where an
    /// estimate's large values come from (the Mitsuba `direct` integrator reports nothing).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn li_observed(
        &self,
        rs: &RenderScene,
        o: Vec3,
        d: Vec3,
        tmax: f32,
        rng: &mut Pcg32,
        stats: &mut TraceStats,
        observe: &mut impl FnMut(PathEvent),
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
                        let value = throughput * le * mis_weight(prev_pdf, em_pdf);
                        observe(PathEvent::Emitted { depth, value });
                        result += value;
                    }
                }
                break;
            };
            let si = surface_interaction(meshes, ray_o, ray_d, &h);
            if lights.is_emissive(h.mesh) {
                let le = lights.area_radiance(&si);
                if le != Spectrum::ZERO {
                    let em_pdf = if prev_delta || !self.nee {
                        0.0
                    } else {
                        lights.pdf_area_hit(prev_p, &si)
                    };
                    let value = throughput * le * mis_weight(prev_pdf, em_pdf);
                    observe(PathEvent::Emitted { depth, value });
                    result += value;
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
                        let value = throughput * f * ls.weight * mis;
                        observe(PathEvent::EmitterSampled {
                            depth,
                            bsdf: mesh.bsdf,
                            wi: si.wi,
                            value,
                        });
                        result += value;
                    }
                }
            }
            // -------------------------- BSDF sampling ---------------------------
            let u1 = rng.next_f32();
            let u2 = rng.next_2d();
            let Some((bs, weight)) = bsdf.sample(&si, u1, u2) else {
                break;
            };
            observe(PathEvent::BsdfSampled {
                depth,
                bsdf: mesh.bsdf,
                wi: si.wi,
                uv: si.uv,
                wo: bs.wo,
                u1,
                pdf: bs.pdf,
                weight,
            });
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

/// One step of a path as [`Integrator::li_observed`] reports it (directions in the vertex's
/// local shading frame, `depth` = the vertex's index along the path, 0 at the camera hit).
#[derive(Clone, Copy, Debug)]
pub enum PathEvent {
    /// Radiance of an emitter that a camera ray or a BSDF-sampled ray hit, MIS weighted, times
    /// the path throughput (`depth`: the vertex the ray left from + 1).
    Emitted { depth: u32, value: Spectrum },
    /// Next-event estimation at vertex `depth`: radiance added, MIS weighted, times the
    /// throughput; `bsdf` indexes `Scene::bsdfs`, `wi` is the outgoing (view) direction.
    EmitterSampled {
        depth: u32,
        bsdf: u32,
        wi: Vec3,
        value: Spectrum,
    },
    /// The BSDF sample that continues the path from vertex `depth` (surface uv `uv`): the lobe
    /// number `u1` it was drawn with, its direction, density and weight f·cos/pdf.
    BsdfSampled {
        depth: u32,
        bsdf: u32,
        wi: Vec3,
        uv: Vec2,
        wo: Vec3,
        u1: f32,
        pdf: f32,
        weight: Spectrum,
    },
}
