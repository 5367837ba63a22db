//! The packet megakernel: one loop per thread over a pool of paths, each round
//! refill free lanes from the tile's next (sample, pixel) work items → closest-hit traversal, one
//! ray per lane → hidden-emitter pass-through → sort live lanes by BSDF → shade each BSDF batch
//! (escape / emission with MIS, next-event estimation, BSDF sampling, throughput, Russian
//! roulette from each lane's own random stream) → one any-hit pass over all pending shadow rays →
//! write finished radiance and free those lanes.
//!
//! A lane does exactly what the scalar [`PathTracer::li`] does for the same (pixel, sample), in
//! the same order on the same random stream, so the two integrators agree sample by sample; every
//! BSDF and light is evaluated per lane through the scalar code (the batched kernels replace
//! these fallbacks one BSDF at a time).

// `!(x > 0.0)` deliberately also rejects NaN, as in the scalar integrator.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::lanes::{LANES, LaneStats};
use super::pool::{FREE, PathPool, Shadow};
use super::shade::shade_triangles;
use crate::bsdf::{BsdfAt, BsdfFlags, BsdfSample};
use crate::geometry::SurfaceInteraction;
use crate::geometry::accel::offset_origin;
use crate::geometry::shading::surface_interaction;
use crate::light::LightSample;
use crate::math::{Pcg32, Spectrum, Vec2, Vec3};
use crate::render::RenderScene;
use crate::render::integrator::{PathTracer, TraceStats, mis_weight, shadow_segment};

/// How the pool is run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PacketOptions {
    /// Paths in flight per thread (a multiple of [`LANES`]).
    pub pool: usize,
    /// Refill a finished lane at once with the next camera path (on), or only when all 16 lanes
    /// of its packet have finished (off: how Dr.Jit's megakernel runs a packet).
    pub refill: bool,
}

impl Default for PacketOptions {
    fn default() -> PacketOptions {
        PacketOptions {
            pool: 256,
            refill: true,
        }
    }
}

/// The work of one call: `samples` consecutive sample indices from `sample0` for every pixel
/// of the `w`×`h` rectangle at (`x0`, `y0`); work item j = sample-offset · w·h + pixel.
#[derive(Clone, Copy, Debug)]
pub struct Chunk {
    pub x0: u32,
    pub y0: u32,
    pub w: u32,
    pub h: u32,
    pub sample0: u32,
    pub samples: u32,
    /// Full film width (pixel index = y · width + x) and the render's seed.
    pub film_width: u32,
    pub seed: u64,
}

/// Sort keys past the BSDF indices: escaped rays, then lanes that only move through a hidden
/// emitter this round.
const KEY_ESCAPED: usize = 0;

/// Reusable buffers of the megakernel (one per thread and tile pass, never per ray).
#[derive(Clone, Debug, Default)]
pub struct Scratch {
    /// Live slots sorted by key.
    order: Vec<u32>,
    /// Sort key of each slot.
    key: Vec<u32>,
    /// Counting-sort bucket starts, and the fill cursors of the scatter.
    start: Vec<u32>,
    fill: Vec<u32>,
}

/// Traces every work item of `chunk` and writes each path's radiance to `out[j]`.
#[allow(clippy::too_many_arguments)]
pub fn trace_chunk(
    rs: &RenderScene,
    opts: PacketOptions,
    chunk: &Chunk,
    pool: &mut PathPool,
    scratch: &mut Scratch,
    out: &mut [Spectrum],
    stats: &mut TraceStats,
    lanes: &mut LaneStats,
) {
    let pt = &rs.integrator;
    let npix = chunk.w * chunk.h;
    let njobs = chunk.samples * npix;
    debug_assert_eq!(out.len(), njobs as usize);
    debug_assert!(pool.len().is_multiple_of(LANES));
    let nkeys = rs.scene.bsdfs.len() + 2;
    let key_skip = nkeys as u32 - 1;
    scratch.key.resize(pool.len(), 0);
    scratch.start.resize(nkeys + 1, 0);
    let mut next = 0u32;
    let isa = crate::math::simd::isa();
    loop {
        // --------------------------------- refill ---------------------------------
        for g in 0..pool.len() / LANES {
            let slots = g * LANES..(g + 1) * LANES;
            if !opts.refill && slots.clone().any(|i| pool.job[i] != FREE) {
                continue;
            }
            for i in slots {
                while pool.job[i] == FREE && next < njobs {
                    let j = next;
                    next += 1;
                    if pt.max_depth == 0 {
                        out[j as usize] = Spectrum::ZERO;
                        continue;
                    }
                    let s = j / npix;
                    let p = j % npix;
                    let (px, py) = (chunk.x0 + p % chunk.w, chunk.y0 + p / chunk.w);
                    let pixel = py as u64 * chunk.film_width as u64 + px as u64;
                    let mut rng = Pcg32::for_sample(chunk.seed, pixel, (chunk.sample0 + s) as u64);
                    let fx = px as f32 + rng.next_f32();
                    let fy = py as f32 + rng.next_f32();
                    let (o, d, tmax) = rs.camera.ray(fx, fy);
                    stats.rays += 1;
                    pool.start(i, j, rng, o, d, tmax);
                }
            }
        }
        // ------------------------------- traversal --------------------------------
        let mut live = 0u64;
        for g in 0..pool.len() / LANES {
            let mut n = 0;
            for i in g * LANES..(g + 1) * LANES {
                if pool.job[i] == FREE {
                    continue;
                }
                n += 1;
                pool.hit[i] = if pool.passthrough[i] && !(pool.ray_t[i] > 0.0) {
                    None
                } else {
                    rs.accel
                        .intersect(pool.ray_o.get(i), pool.ray_d.get(i), pool.ray_t[i])
                };
            }
            if n > 0 {
                lanes.issued += LANES as u64;
                lanes.active += n;
                live += n;
            }
        }
        if live == 0 {
            debug_assert_eq!(next, njobs);
            break;
        }
        lanes.steps += 1;
        // --------------------- sort live lanes by BSDF (counting) ---------------------
        scratch.start.iter_mut().for_each(|c| *c = 0);
        for i in 0..pool.len() {
            if pool.job[i] == FREE {
                continue;
            }
            let k = match pool.hit[i] {
                None => KEY_ESCAPED as u32,
                Some(h) => {
                    if pt.hide_emitters && pool.depth[i] == 0 && rs.lights.is_emissive(h.mesh) {
                        pass_through_emitter(rs, pool, i, stats);
                        key_skip
                    } else {
                        // In range: RenderScene::new checked every mesh's BSDF index.
                        1 + rs.scene.meshes[h.mesh as usize].bsdf
                    }
                }
            };
            scratch.key[i] = k;
            scratch.start[k as usize + 1] += 1;
        }
        for k in 0..nkeys {
            scratch.start[k + 1] += scratch.start[k];
        }
        scratch.order.resize(scratch.start[nkeys] as usize, 0);
        scratch.fill.clone_from(&scratch.start);
        for i in 0..pool.len() {
            if pool.job[i] != FREE {
                let k = scratch.key[i] as usize;
                scratch.order[scratch.fill[k] as usize] = i as u32;
                scratch.fill[k] += 1;
            }
        }
        // ------------------------------ shade by BSDF ------------------------------
        for k in 0..key_skip as usize {
            let (a, b) = (scratch.start[k] as usize, scratch.start[k + 1] as usize);
            if a == b {
                continue;
            }
            // Triangle lanes of a BSDF run the SoA kernel; the rest (analytic spheres and
            // escaped rays) are shaded lane by lane through the scalar code.
            let bsdf = k.checked_sub(1).map(|b| &rs.scene.bsdfs[b]);
            let bucket = &mut scratch.order[a..b];
            let split = match bsdf {
                Some(_) => partition(bucket, |i| is_triangle_hit(rs, pool, i)),
                None => 0,
            };
            let (soa, rest) = bucket.split_at(split);
            lanes.shade_active += (b - a) as u64;
            lanes.shade_issued +=
                (soa.len().div_ceil(LANES) + rest.len().div_ceil(LANES)) as u64 * LANES as u64;
            if let Some(bsdf) = bsdf {
                for slots in soa.chunks(LANES) {
                    shade_triangles(isa, rs, bsdf, pool, slots, stats);
                }
            }
            for slots in rest.chunks(LANES) {
                shade_batch(rs, pt, pool, slots, stats);
            }
        }
        // ------------------------- batched any-hit shadow pass -------------------------
        for i in 0..pool.len() {
            let clear = match pool.shadow[i] {
                Shadow::None => continue,
                Shadow::Unoccluded => true,
                Shadow::Test => {
                    !rs.accel
                        .occluded(pool.shadow_o.get(i), pool.shadow_d.get(i), pool.shadow_t[i])
                }
            };
            if clear {
                let r = pool.result.get(i) + pool.shadow_c.get(i);
                pool.result.set(i, r);
            }
            pool.shadow[i] = Shadow::None;
        }
        // ------------------------ write finished paths, free ------------------------
        for i in 0..pool.len() {
            if pool.job[i] != FREE && pool.ending[i] {
                out[pool.job[i] as usize] = pool.result.get(i);
                pool.job[i] = FREE;
                pool.ending[i] = false;
            }
        }
    }
}

/// Moves the slots for which `keep` holds to the front of `v` (in no particular order) and
/// returns how many there are.
fn partition(v: &mut [u32], keep: impl Fn(usize) -> bool) -> usize {
    let mut k = 0;
    for j in 0..v.len() {
        if keep(v[j] as usize) {
            v.swap(j, k);
            k += 1;
        }
    }
    k
}

/// True if slot `i`'s ray hit a triangle (not an analytic sphere).
#[inline]
fn is_triangle_hit(rs: &RenderScene, pool: &PathPool, i: usize) -> bool {
    pool.hit[i].is_some_and(|h| rs.scene.meshes[h.mesh as usize].sphere.is_none())
}

/// A camera ray hit an area emitter with `hide_emitters`: continue the same ray behind it
/// (Mitsuba's skip_area_emitters), without shading.
fn pass_through_emitter(rs: &RenderScene, pool: &mut PathPool, i: usize, stats: &mut TraceStats) {
    let Some(h) = pool.hit[i] else { return };
    let (ray_o, ray_d) = (pool.ray_o.get(i), pool.ray_d.get(i));
    let si = surface_interaction(&rs.scene.meshes, ray_o, ray_d, &h);
    let travelled = (si.p - pool.cam_o.get(i)).length();
    pool.ray_o.set(i, offset_origin(si.p, si.n, ray_d));
    pool.ray_t[i] = pool.cam_t[i] - travelled;
    pool.passthrough[i] = true;
    stats.rays += 1;
}

/// A lane between the phases of its shading round: what the front half (through drawing the
/// emitter sample) leaves for emitter evaluation, BSDF sampling and the continuation ray.
struct Pending<'a> {
    slot: usize,
    si: SurfaceInteraction,
    /// The lane's BSDF at `si`, with its per-hit state.
    bsdf: BsdfAt<'a>,
    rng: Pcg32,
    /// The emitter sample of next-event estimation, if one was drawn.
    light: Option<LightSample>,
    /// BSDF-sampling inputs, drawn after the emitter sample was evaluated.
    u1: f32,
    u2: Vec2,
}

/// Shades up to [`LANES`] slots of one BSDF batch phase by phase: every lane's front half
/// (surface interaction, per-hit BSDF state with its prefetches, emitter sample), then every
/// lane's emitter evaluation, then every lane's BSDF sample and continuation. Each lane does the
/// scalar integrator's steps in the scalar order on its own random stream, so the results are
/// the same bits as lane-by-lane shading; the phases let the memory loads one lane's per-hit
/// state starts (a measured BTF's texel) land while the other lanes work, instead of stalling
/// the evaluation right after.
fn shade_batch(
    rs: &RenderScene,
    pt: &PathTracer,
    pool: &mut PathPool,
    slots: &[u32],
    stats: &mut TraceStats,
) {
    debug_assert!(slots.len() <= LANES);
    let mut lanes: [Option<Pending>; LANES] = Default::default();
    for (p, &i) in lanes.iter_mut().zip(slots) {
        *p = shade_front(rs, pt, pool, i as usize);
    }
    // Emitter evaluation. The lanes of a batch share one BSDF: a fitted BTF's evaluations run
    // as one batch (16 per pass of its kernel), the others lane by lane.
    let plmc = lanes.iter().flatten().find_map(|p| match p.bsdf {
        BsdfAt::Plmc(b, _) => Some(b),
        BsdfAt::Stateless(_) => None,
    });
    let mut evals = [None; LANES];
    if let Some(b) = plmc {
        let mut hits = [None; LANES];
        let mut n = 0;
        let mut at = [0usize; LANES];
        let mut wo = [Vec3::ZERO; LANES];
        let mut want = [false; LANES];
        for (l, p) in lanes.iter().enumerate() {
            if let Some(Pending {
                light: Some(ls),
                bsdf: BsdfAt::Plmc(_, h),
                si,
                ..
            }) = p
            {
                hits[n] = Some(*h);
                at[n] = l;
                wo[n] = si.to_local(ls.wi);
                want[n] = !ls.delta;
                n += 1;
            }
        }
        if let Some(first) = hits[0] {
            let hits = hits.map(|h| h.unwrap_or(first));
            let mut out = [(Spectrum::ZERO, 0.0); LANES];
            b.eval_pdf_batch(&hits[..n], &wo[..n], &want[..n], &mut out[..n]);
            for j in 0..n {
                evals[at[j]] = Some(out[j]);
            }
        }
    }
    for (p, e) in lanes.iter().zip(evals) {
        if let Some(p) = p {
            next_event(pool, p, e, stats);
        }
    }
    for p in lanes.iter_mut() {
        if let Some(p) = p.take() {
            let sampled = p.bsdf.sample(&p.si, p.u1, p.u2);
            shade_back(pt, pool, p.slot, &p.si, p.rng, sampled, stats);
        }
    }
}

/// The loop body up to BSDF sampling, without evaluating the emitter sample: escape, emission
/// with MIS, the depth limit, the per-hit BSDF state, the emitter sample (its random numbers
/// first, as in the scalar loop) and the BSDF-sampling numbers. None = the lane ends this round.
fn shade_front<'a>(
    rs: &'a RenderScene,
    pt: &PathTracer,
    pool: &mut PathPool,
    i: usize,
) -> Option<Pending<'a>> {
    let meshes = &rs.scene.meshes;
    let lights = &rs.lights;
    let (ray_o, ray_d) = (pool.ray_o.get(i), pool.ray_d.get(i));
    let depth = pool.depth[i];
    let throughput = pool.throughput.get(i);
    let mut result = pool.result.get(i);
    let (prev_pdf, prev_delta) = (pool.prev_pdf[i], pool.prev_delta[i]);
    let Some(h) = pool.hit[i] else {
        // Escaped: lights at infinity (hidden from the camera with hide_emitters).
        if !(depth == 0 && pt.hide_emitters) {
            for k in 0..lights.infinite_count() {
                let (le, pdf_e) = lights.eval_infinite(k, ray_d);
                let em_pdf = if prev_delta || !pt.nee { 0.0 } else { pdf_e };
                result += throughput * le * mis_weight(prev_pdf, em_pdf);
            }
        }
        pool.result.set(i, result);
        pool.ending[i] = true;
        return None;
    };
    let si = surface_interaction(meshes, ray_o, ray_d, &h);
    if lights.is_emissive(h.mesh) {
        let le = lights.area_radiance(meshes, &si);
        if le != Spectrum::ZERO {
            let em_pdf = if prev_delta || !pt.nee {
                0.0
            } else {
                lights.pdf_area_hit(pool.prev_p.get(i), &si)
            };
            result += throughput * le * mis_weight(prev_pdf, em_pdf);
        }
    }
    pool.result.set(i, result);
    if depth.saturating_add(1) >= pt.max_depth {
        pool.ending[i] = true;
        return None;
    }
    let mesh = &meshes[h.mesh as usize];
    let Some(bsdf) = rs.scene.bsdfs.get(mesh.bsdf as usize) else {
        pool.ending[i] = true;
        return None;
    };
    let mut rng = pool.rng[i].clone();
    let bsdf = bsdf.at(&si);
    let mut light = None;
    if pt.nee && bsdf.flags().has(BsdfFlags::SMOOTH) {
        let u_sel = rng.next_f32();
        let u = rng.next_2d();
        light = lights.sample(si.p, u_sel, u);
    }
    // Evaluating the emitter sample draws no random numbers, so these follow at once.
    let u1 = rng.next_f32();
    let u2 = rng.next_2d();
    Some(Pending {
        slot: i,
        si,
        bsdf,
        rng,
        light,
        u1,
        u2,
    })
}

/// Next-event estimation of a pending lane: evaluates its emitter sample and leaves the
/// shadow ray and its contribution pending for the batched any-hit pass.
/// `eval`: the BSDF's (f, pdf) for the emitter sample if a batched kernel made it already
/// (the pdf 0 for a delta light).
fn next_event(
    pool: &mut PathPool,
    p: &Pending,
    eval: Option<(Spectrum, f32)>,
    stats: &mut TraceStats,
) {
    let Some(ls) = &p.light else { return };
    let (si, bsdf, i) = (&p.si, &p.bsdf, p.slot);
    let (f, bsdf_pdf) = match eval {
        Some(e) => e,
        None => {
            let wo = si.to_local(ls.wi);
            bsdf.eval_for_light(si, wo, ls.delta)
        }
    };
    if f == Spectrum::ZERO || ls.weight == Spectrum::ZERO {
        return;
    }
    stats.rays += 1;
    let mis = if ls.delta {
        1.0
    } else {
        mis_weight(ls.pdf, bsdf_pdf)
    };
    pool.shadow_c
        .set(i, pool.throughput.get(i) * f * ls.weight * mis);
    pool.shadow[i] = match shadow_segment(si, ls) {
        Some((o, d, t)) => {
            pool.shadow_o.set(i, o);
            pool.shadow_d.set(i, d);
            pool.shadow_t[i] = t;
            Shadow::Test
        }
        None => Shadow::Unoccluded,
    };
}

/// The loop body after BSDF sampling (`sampled`, from the scalar code or a batched kernel):
/// throughput, Russian roulette on the lane's stream, the continuation ray.
fn shade_back(
    pt: &PathTracer,
    pool: &mut PathPool,
    i: usize,
    si: &SurfaceInteraction,
    mut rng: Pcg32,
    sampled: Option<(BsdfSample, Spectrum)>,
    stats: &mut TraceStats,
) {
    let mut throughput = pool.throughput.get(i);
    let Some((bs, weight)) = sampled else {
        pool.rng[i] = rng;
        pool.ending[i] = true;
        return;
    };
    let wo_world = si.to_world(bs.wo);
    throughput *= weight;
    let eta = pool.eta[i] * bs.eta;
    let depth = pool.depth[i] + 1;
    pool.eta[i] = eta;
    pool.prev_p.set(i, si.p);
    pool.prev_pdf[i] = bs.pdf;
    pool.prev_delta[i] = bs.sampled.has(BsdfFlags::DELTA);
    pool.depth[i] = depth;
    let t_max = throughput.max_element();
    let mut alive = true;
    if depth >= pt.rr_depth {
        let q = (t_max * eta * eta).min(0.95);
        if !(rng.next_f32() < q) {
            alive = false;
        } else {
            throughput /= q;
        }
    }
    pool.rng[i] = rng;
    pool.throughput.set(i, throughput);
    if !alive || !(t_max > 0.0) {
        pool.ending[i] = true;
        return;
    }
    pool.ray_o.set(i, offset_origin(si.p, si.n, wo_world));
    pool.ray_d.set(i, wo_world);
    pool.ray_t[i] = f32::INFINITY;
    pool.passthrough[i] = false;
    stats.rays += 1;
}
