//! The per-thread pool of paths in flight, structure-of-arrays: one slot per path, each field a
//! contiguous array so the per-BSDF kernels read and write whole 16-lane rows. Allocated once
//! per tile pass; a few hundred slots keep the whole pool (≈ 50 KB) in L2.

use super::lane_stats::LANES;
use crate::geometry::accel::Hit;
use crate::math::{Pcg32, Spectrum, Vec3};

/// Slots `g·LANES .. (g+1)·LANES` of a per-slot array: one 16-lane group as a fixed-size row,
/// so a lane loop over it indexes without bounds checks.
#[inline(always)]
pub fn group<T>(v: &[T], g: usize) -> &[T; LANES] {
    v[g * LANES..][..LANES]
        .try_into()
        .expect("a slice of LANES elements")
}

/// [`group`], writable.
#[inline(always)]
pub fn group_mut<T>(v: &mut [T], g: usize) -> &mut [T; LANES] {
    (&mut v[g * LANES..][..LANES])
        .try_into()
        .expect("a slice of LANES elements")
}

/// Marks a free slot in [`PathPool::job`].
pub const FREE: u32 = u32::MAX;

/// Three f32 arrays (x, y, z) holding one vector per slot.
#[derive(Clone, Debug)]
pub struct Vec3s {
    pub x: Vec<f32>,
    pub y: Vec<f32>,
    pub z: Vec<f32>,
}

impl Vec3s {
    fn new(n: usize) -> Vec3s {
        Vec3s {
            x: vec![0.0; n],
            y: vec![0.0; n],
            z: vec![0.0; n],
        }
    }

    /// The vector of slot `i`.
    #[inline]
    pub fn get(&self, i: usize) -> Vec3 {
        Vec3::new(self.x[i], self.y[i], self.z[i])
    }

    /// Stores `v` in slot `i`.
    #[inline]
    pub fn set(&mut self, i: usize, v: Vec3) {
        self.x[i] = v.x;
        self.y[i] = v.y;
        self.z[i] = v.z;
    }

    /// The vectors of 16-lane group `g` (see [`group`]).
    #[inline(always)]
    pub fn group(&self, g: usize) -> Group3<'_> {
        Group3([group(&self.x, g), group(&self.y, g), group(&self.z, g)])
    }

    /// [`Vec3s::group`], writable.
    #[inline(always)]
    pub fn group_mut(&mut self, g: usize) -> Group3Mut<'_> {
        Group3Mut([
            group_mut(&mut self.x, g),
            group_mut(&mut self.y, g),
            group_mut(&mut self.z, g),
        ])
    }
}

/// One 16-lane group of a [`Vec3s`]: x, y, z rows.
pub struct Group3<'a>([&'a [f32; LANES]; 3]);

impl Group3<'_> {
    /// The vector of lane `l`.
    #[inline(always)]
    pub fn get(&self, l: usize) -> Vec3 {
        Vec3::new(self.0[0][l], self.0[1][l], self.0[2][l])
    }
}

/// One 16-lane group of a [`Vec3s`], writable.
pub struct Group3Mut<'a>([&'a mut [f32; LANES]; 3]);

impl Group3Mut<'_> {
    /// The vector of lane `l`.
    #[inline(always)]
    pub fn get(&self, l: usize) -> Vec3 {
        Vec3::new(self.0[0][l], self.0[1][l], self.0[2][l])
    }

    /// Stores `v` in lane `l`.
    #[inline(always)]
    pub fn set(&mut self, l: usize, v: Vec3) {
        (self.0[0][l], self.0[1][l], self.0[2][l]) = (v.x, v.y, v.z);
    }
}

/// What the shadow pass does for a slot's next-event estimate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shadow {
    /// No light contribution pending.
    None,
    /// Add the contribution without a test (degenerate zero-length shadow segment).
    Unoccluded,
    /// Trace the any-hit ray (`shadow_o`, `shadow_d`, `shadow_t`), add the contribution if clear.
    Test,
}

/// The state of every path in flight, the scalar integrator's locals as arrays.
#[derive(Clone, Debug)]
pub struct PathPool {
    /// Work item (sample-major index into the chunk's output) of the slot, or [`FREE`].
    pub job: Vec<u32>,
    pub rng: Vec<Pcg32>,
    /// Current ray: origin, unit direction, extent.
    pub ray_o: Vec3s,
    pub ray_d: Vec3s,
    pub ray_t: Vec<f32>,
    /// Continuation of a camera ray through a hidden area emitter: trace only if `ray_t > 0`.
    pub passthrough: Vec<bool>,
    /// The camera ray's origin and extent (what remains after a hidden emitter is measured
    /// from them).
    pub cam_o: Vec3s,
    pub cam_t: Vec<f32>,
    /// Closest hit of the current ray (written by the traversal stage).
    pub hit: Vec<Option<Hit>>,
    /// The current ray is a camera ray already traced with its packet (`hit` holds its hit).
    pub traced: Vec<bool>,
    pub throughput: Vec3s,
    pub result: Vec3s,
    pub eta: Vec<f32>,
    /// Path vertices shaded so far.
    pub depth: Vec<u32>,
    /// Previous vertex, the pdf of the direction sampled there, and whether it was a delta lobe.
    pub prev_p: Vec3s,
    pub prev_pdf: Vec<f32>,
    pub prev_delta: Vec<bool>,
    /// The pending next-event estimate: what to do, the shadow ray and the contribution.
    pub shadow: Vec<Shadow>,
    pub shadow_o: Vec3s,
    pub shadow_d: Vec3s,
    pub shadow_t: Vec<f32>,
    pub shadow_c: Vec3s,
    /// The path ends once its pending shadow ray is resolved.
    pub ending: Vec<bool>,
}

impl PathPool {
    /// A pool of `n` free slots.
    pub fn new(n: usize) -> PathPool {
        PathPool {
            job: vec![FREE; n],
            rng: vec![Pcg32::new(0, 0); n],
            ray_o: Vec3s::new(n),
            ray_d: Vec3s::new(n),
            ray_t: vec![0.0; n],
            passthrough: vec![false; n],
            cam_o: Vec3s::new(n),
            cam_t: vec![0.0; n],
            hit: vec![None; n],
            traced: vec![false; n],
            throughput: Vec3s::new(n),
            result: Vec3s::new(n),
            eta: vec![1.0; n],
            depth: vec![0; n],
            prev_p: Vec3s::new(n),
            prev_pdf: vec![1.0; n],
            prev_delta: vec![true; n],
            shadow: vec![Shadow::None; n],
            shadow_o: Vec3s::new(n),
            shadow_d: Vec3s::new(n),
            shadow_t: vec![0.0; n],
            shadow_c: Vec3s::new(n),
            ending: vec![false; n],
        }
    }

    /// Number of slots.
    pub fn len(&self) -> usize {
        self.job.len()
    }

    /// True if the pool has no slots.
    pub fn is_empty(&self) -> bool {
        self.job.is_empty()
    }

    /// Starts a camera path in slot `i` (the scalar `li`'s initial state).
    pub fn start(&mut self, i: usize, job: u32, rng: Pcg32, o: Vec3, d: Vec3, tmax: f32) {
        self.job[i] = job;
        self.rng[i] = rng;
        self.ray_o.set(i, o);
        self.ray_d.set(i, d);
        self.ray_t[i] = tmax;
        self.passthrough[i] = false;
        self.cam_o.set(i, o);
        self.cam_t[i] = tmax;
        self.hit[i] = None;
        self.throughput.set(i, Spectrum::ONE);
        self.result.set(i, Spectrum::ZERO);
        self.eta[i] = 1.0;
        self.depth[i] = 0;
        self.prev_p.set(i, o);
        self.prev_pdf[i] = 1.0;
        self.prev_delta[i] = true;
        self.shadow[i] = Shadow::None;
        self.ending[i] = false;
    }
}
