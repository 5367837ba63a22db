//! The packet path tracer: per thread, a pool of paths in structure-of-arrays run by one
//! megakernel loop with lane refill (`megakernel.rs`), fed from a tile's (sample, pixel) work
//! items. Paths finish out of order; their radiance lands in a per-chunk buffer indexed by
//! (sample, pixel) and is added to the tile's sums in sample order afterwards, so the image is
//! the same bytes as with any thread count, pass size, interruption or reconstruction filter — and, because each lane
//! replays the scalar integrator on the same random stream, the same samples as `--integrator
//! scalar` up to floating-point association in the batched kernels.

pub mod chunk;
pub mod escaped;
pub mod lane_stats;
pub mod megakernel;
pub mod pool;
pub mod refill;
pub mod shade;

pub use lane_stats::{LANES, LaneCounters, LaneStats};
pub use megakernel::PacketOptions;

use super::RenderScene;
use super::film::{RenderSettings, Tile};
use super::integrator::TraceStats;
use crate::math::filter::Filter;
use chunk::{Chunk, FilmSample};
use megakernel::{Scratch, trace_chunk};
use pool::PathPool;
use std::sync::atomic::{AtomicBool, Ordering};

/// Most sample indices traced in one chunk: bounds the output buffer (8 × 32² × 20 B = 160 KB)
/// and is the granularity at which an interrupt is honoured.
const CHUNK_SAMPLES: u32 = 8;

/// Adds samples `tile.done..end` (relative to `s.spp_begin`) to `tile` through `filter`, as the
/// scalar integrator's tile loop does ([`super::integrator::Integrator::render_tile`]): stops at
/// a sample boundary once `interrupt` is set, and reports each completed sample to `progress`.
#[allow(clippy::too_many_arguments)]
pub fn render_tile(
    rs: &RenderScene,
    opts: PacketOptions,
    s: &RenderSettings,
    filter: &Filter,
    tile: &mut Tile,
    end: u32,
    interrupt: &AtomicBool,
    progress: &(dyn Fn(u64, u64) + Sync),
) {
    let npix = (tile.w * tile.h) as usize;
    let mut pool = PathPool::new(opts.pool.max(LANES).next_multiple_of(LANES));
    let mut scratch = Scratch::default();
    let mut out = vec![FilmSample::default(); CHUNK_SAMPLES as usize * npix];
    let mut lane_stats = LaneStats::default();
    let mut extra = vec![0f32; tile.extra_channels];
    while tile.done < end {
        if interrupt.load(Ordering::Relaxed) {
            break;
        }
        let samples = CHUNK_SAMPLES.min(end - tile.done);
        let chunk = Chunk {
            x0: tile.x0,
            y0: tile.y0,
            w: tile.w,
            h: tile.h,
            sample0: s.spp_begin + tile.done,
            samples,
            film_width: s.width,
            seed: s.seed,
        };
        let mut stats = TraceStats::default();
        let out = &mut out[..samples as usize * npix];
        trace_chunk(
            rs,
            opts,
            &chunk,
            &mut pool,
            &mut scratch,
            out,
            &mut stats,
            &mut lane_stats,
        );
        // Accumulate in sample order, pixel order: exactly the scalar loop's additions.
        for (k, sample) in out.chunks_exact(npix).enumerate() {
            let mut invalid = 0;
            for (i, fs) in sample.iter().enumerate() {
                let (px, py) = (tile.x0 + i as u32 % tile.w, tile.y0 + i as u32 / tile.w);
                let [fx, fy] = fs.pos;
                if !extra.is_empty() {
                    let sample = (chunk.sample0 + k as u32) as u64;
                    super::channels::sample_values(rs, s, px, py, sample, fs.l, &mut extra);
                }
                if !tile.add_sample_with(s, filter, px, py, fx, fy, fs.l, &extra) {
                    invalid += 1;
                }
            }
            // The chunk's rays are booked with its first sample.
            let rays = if k == 0 { stats.rays } else { 0 };
            tile.sample_done(rays, invalid);
            progress(npix as u64, rays);
        }
    }
    rs.lanes.add(&lane_stats);
}
