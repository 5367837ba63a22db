//! The packet megakernel: one loop per thread over a pool of paths, each round
//! refill free lanes from the tile's next (sample, pixel) work items → closest-hit traversal, one
//! ray per lane → hidden-emitter pass-through → sort live lanes by BSDF → shade each BSDF's
//! batches of 16 in the SoA kernel ([`super::shade`]: emission with MIS, next-event estimation,
//! BSDF sampling, throughput, Russian roulette from each lane's own random stream) and escaped
//! rays lane by lane → one any-hit pass over all pending shadow rays → write finished radiance and
//! free those lanes.
//!
//! A lane does exactly what the scalar [`crate::render::integrator::Integrator::li`] does for the same (pixel, sample), in
//! the same order on the same random stream, so the two integrators agree sample by sample.

// `!(x > 0.0)` deliberately also rejects NaN, as in the scalar integrator.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::chunk::{Chunk, FilmSample};
use super::escaped::shade_escaped;
use super::lane_stats::{LANES, LaneStats};
use super::pool::{FREE, PathPool, Shadow, group, group_mut};
use super::refill::{Refill, start_paths};
use super::shade::shade_hits;
use crate::bsdf::batch::BsdfBatch;
use crate::geometry::accel::offset_origin;
use crate::geometry::shading::surface_interaction;
use crate::math::Spectrum;
use crate::render::RenderScene;
use crate::render::integrator::{TraceStats, film_sample_start};

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

/// Sort keys past the BSDF indices: escaped rays, then lanes that only move through a hidden
/// emitter this round.
const KEY_ESCAPED: usize = 0;

/// Reusable buffers of the megakernel (one per thread and tile pass, never per ray).
#[derive(Clone, Debug, Default)]
pub struct Scratch {
    /// Sort key of each BSDF index: 1 + the BSDF whose batches it joins (every `diffuse`, and
    /// every `twosided` of two, joins the first one, since the SoA diffuse stages read each
    /// lane's own albedo and side).
    batch_key: Vec<u32>,
    /// Live slots sorted by key.
    order: Vec<u32>,
    /// Sort key of each slot.
    key: Vec<u32>,
    /// Counting-sort bucket starts, and the fill cursors of the scatter.
    start: Vec<u32>,
    fill: Vec<u32>,
}

/// Traces every work item of `chunk` and writes each path's radiance and film position to
/// `out[j]`.
#[allow(clippy::too_many_arguments)]
pub fn trace_chunk(
    rs: &RenderScene,
    opts: PacketOptions,
    chunk: &Chunk,
    pool: &mut PathPool,
    scratch: &mut Scratch,
    out: &mut [FilmSample],
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
    let mut fill = Refill::default();
    let isa = crate::math::simd::isa();
    let bsdfs = &rs.scene.bsdfs;
    let first_diffuse = bsdfs.iter().position(BsdfBatch::shares_diffuse_batch);
    scratch.batch_key.clear();
    scratch
        .batch_key
        .extend(
            bsdfs
                .iter()
                .enumerate()
                .map(|(k, b)| match BsdfBatch::shares_diffuse_batch(b) {
                    true => 1 + first_diffuse.unwrap_or(k) as u32,
                    false => 1 + k as u32,
                }),
        );
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
                        // No path: the film position alone, drawn as the refill draws it.
                        let (s, p) = (j / npix, j % npix);
                        let (x, y) = (chunk.x0 + p % chunk.w, chunk.y0 + p / chunk.w);
                        let (_, fx, fy) = film_sample_start(
                            chunk.seed,
                            chunk.film_width,
                            x,
                            y,
                            (chunk.sample0 + s) as u64,
                        );
                        out[j as usize] = FilmSample {
                            l: Spectrum::ZERO,
                            pos: [fx, fy],
                        };
                        continue;
                    }
                    // Claimed now, started 16 at a time.
                    pool.job[i] = j;
                    if fill.push(i, j) {
                        start_paths(isa, rs, chunk, pool, &mut fill, out, stats);
                    }
                }
            }
        }
        start_paths(isa, rs, chunk, pool, &mut fill, out, stats);
        // ------------- traversal, and each live slot's sort key (counted) -------------
        scratch.start.iter_mut().for_each(|c| *c = 0);
        let mut live = 0u64;
        for g in 0..pool.len() / LANES {
            let (ray_o, ray_d) = (pool.ray_o.group(g), pool.ray_d.group(g));
            let (tmax, job) = (group(&pool.ray_t, g), group(&pool.job, g));
            let (pass, depth) = (group(&pool.passthrough, g), group(&pool.depth, g));
            let hits = group_mut(&mut pool.hit, g);
            let traced = group_mut(&mut pool.traced, g);
            let keys = group_mut(&mut scratch.key, g);
            // Lanes that hit a hidden emitter.
            let mut through = 0u32;
            let mut n = 0;
            for l in 0..LANES {
                if job[l] == FREE {
                    continue;
                }
                n += 1;
                let hit = if traced[l] {
                    traced[l] = false;
                    hits[l]
                } else if pass[l] && !(tmax[l] > 0.0) {
                    None
                } else {
                    rs.accel.intersect(ray_o.get(l), ray_d.get(l), tmax[l])
                };
                hits[l] = hit;
                let k = match hit {
                    None => KEY_ESCAPED as u32,
                    Some(h) => {
                        if pt.hide_emitters && depth[l] == 0 && rs.lights.is_emissive(h.mesh) {
                            // Moved on below, once this group's rows are released.
                            through |= 1 << l;
                            key_skip
                        } else {
                            // In range: RenderScene::new checked every mesh's BSDF index.
                            scratch.batch_key[rs.scene.meshes[h.mesh as usize].bsdf as usize]
                        }
                    }
                };
                keys[l] = k;
                scratch.start[k as usize + 1] += 1;
            }
            while through != 0 {
                let l = through.trailing_zeros() as usize;
                through &= through - 1;
                pass_through_emitter(rs, pool, g * LANES + l, stats);
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
        // ------------------------- sort live lanes by BSDF -------------------------
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
            lanes.shade_active += (b - a) as u64;
            lanes.shade_issued += (b - a).div_ceil(LANES) as u64 * LANES as u64;
            let slots = &scratch.order[a..b];
            match k.checked_sub(1) {
                None => shade_escaped(isa, rs, pool, slots),
                Some(bsdf) => {
                    let bsdf = &rs.scene.bsdfs[bsdf];
                    for batch in slots.chunks(LANES) {
                        shade_hits(isa, rs, bsdf, pool, batch, stats);
                    }
                }
            }
        }
        // ------------- batched any-hit shadow pass; write finished paths, free -------------
        for g in 0..pool.len() / LANES {
            let (shadow, st) = (group_mut(&mut pool.shadow, g), group(&pool.shadow_t, g));
            let (shadow_o, shadow_d) = (pool.shadow_o.group(g), pool.shadow_d.group(g));
            let (shadow_c, mut result) = (pool.shadow_c.group(g), pool.result.group_mut(g));
            let (job, ending) = (group_mut(&mut pool.job, g), group_mut(&mut pool.ending, g));
            for l in 0..LANES {
                let clear = match shadow[l] {
                    Shadow::None => false,
                    Shadow::Unoccluded => true,
                    Shadow::Test => !rs.accel.occluded(shadow_o.get(l), shadow_d.get(l), st[l]),
                };
                if clear {
                    result.set(l, result.get(l) + shadow_c.get(l));
                }
                shadow[l] = Shadow::None;
                if job[l] != FREE && ending[l] {
                    out[job[l] as usize].l = result.get(l);
                    job[l] = FREE;
                    ending[l] = false;
                }
            }
        }
    }
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
