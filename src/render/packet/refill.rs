//! Starting camera paths in the pool 16 at a time: the free slots a round refills are
//! collected with their work items, and their random streams (seeded from (seed, pixel,
//! sample)), film positions (written to the chunk's output for the film's filter) and camera rays are computed in SoA by the twins of the scalar
//! code ([`Pcg32x::for_samples`], [`ProjectiveCamera::ray_x`](crate::render::camera::ProjectiveCamera::ray_x)),
//! so each lane starts with the bits [`crate::render::integrator::Integrator::li`]'s path does.

use super::chunk::{Chunk, FilmSample};
use super::lane_stats::LANES;
use super::pool::PathPool;
use crate::math::Pcg32x;
use crate::math::simd::f16::F16;
use crate::render::RenderScene;
use crate::render::integrator::TraceStats;

/// Free slots claimed this round and the work items they take, up to [`LANES`] at a time.
#[derive(Clone, Copy, Debug, Default)]
pub struct Refill {
    slot: [usize; LANES],
    job: [u32; LANES],
    n: usize,
}

impl Refill {
    /// Queues work item `job` (sample-major index into the chunk) for slot `slot`; returns true
    /// once [`LANES`] are queued, when the caller must [`start_paths`].
    #[inline]
    pub fn push(&mut self, slot: usize, job: u32) -> bool {
        self.slot[self.n] = slot;
        self.job[self.n] = job;
        self.n += 1;
        self.n == LANES
    }
}

crate::isa_dispatch! {
    /// Starts the queued camera paths in their slots (the scalar refill's state for each) and
    /// empties the queue.
    pub fn start_paths(
        rs: &RenderScene,
        chunk: &Chunk,
        pool: &mut PathPool,
        fill: &mut Refill,
        out: &mut [FilmSample],
        stats: &mut TraceStats,
    ) -> () = start;
}

#[inline(always)]
fn start(
    rs: &RenderScene,
    chunk: &Chunk,
    pool: &mut PathPool,
    fill: &mut Refill,
    out: &mut [FilmSample],
    stats: &mut TraceStats,
) {
    let n = fill.n;
    if n == 0 {
        return;
    }
    let npix = chunk.w * chunk.h;
    let mut pixel = [0u64; LANES];
    let mut sample = [0u64; LANES];
    let (mut px, mut py) = ([0.0f32; LANES], [0.0f32; LANES]);
    // Lanes past n repeat the last item; their results are dropped.
    for l in 0..LANES {
        let j = fill.job[l.min(n - 1)];
        let (s, p) = (j / npix, j % npix);
        let (x, y) = (chunk.x0 + p % chunk.w, chunk.y0 + p / chunk.w);
        pixel[l] = y as u64 * chunk.film_width as u64 + x as u64;
        sample[l] = (chunk.sample0 + s) as u64;
        px[l] = x as f32;
        py[l] = y as f32;
    }
    let mut rng = Pcg32x::for_samples(chunk.seed, &pixel, &sample);
    let all = [true; LANES];
    let fx = F16(px) + F16(rng.next_f32(&all));
    let fy = F16(py) + F16(rng.next_f32(&all));
    // The thin lens's aperture sample: the next 2-D dimension, as the scalar path draws it.
    let (ux, uy) = if rs.camera.needs_aperture_sample() {
        let ux = F16(rng.next_f32(&all));
        (ux, F16(rng.next_f32(&all)))
    } else {
        (F16::splat(0.5), F16::splat(0.5))
    };
    let (o, d, tmax) = rs.camera.ray_x(fx, fy, ux, uy);
    // The row's camera rays traced together where a packet pays (the traversal stage takes
    // their hits as found), else one by one there.
    let mut hits = [None; LANES];
    let traced = rs.accel.packets_pay()
        && rs.accel.intersect16(
            &[o.x.0, o.y.0, o.z.0],
            &[d.x.0, d.y.0, d.z.0],
            &tmax.0,
            u32::MAX >> (32 - n),
            &mut hits,
        );
    for l in 0..n {
        out[fill.job[l] as usize].pos = [fx.0[l], fy.0[l]];
        pool.start(
            fill.slot[l],
            fill.job[l],
            rng.lane(l),
            o.get(l),
            d.get(l),
            tmax.0[l],
        );
        if traced {
            pool.hit[fill.slot[l]] = hits[l];
            pool.traced[fill.slot[l]] = true;
        }
    }
    stats.rays += n as u64;
    fill.n = 0;
}
