//! The render of a window, as pbrt-v4's `ImageTileIntegrator::Render` owns it: passes of whole
//! sample indices over the film's tiles in parallel, each pass sized to take a fraction of the
//! checkpoint interval, checkpoints at that interval and on an interrupt, and progress. The
//! integrators (scalar path, `direct`, packet) are peers that trace one tile's samples; the
//! film ([`super::film`]) only accumulates. The CLI, the tests and the benches all render
//! through here, so there is one sample loop per integrator and one pass loop.

use super::checkpoint;
use super::film::RenderState;
use super::{IntegratorKind, RenderScene};
use crate::{Error, Result};
use rayon::prelude::*;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Where and how often an interruptible render saves its exact state.
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpointing {
    /// The checkpoint file (written atomically).
    pub path: PathBuf,
    /// Time between checkpoints; passes are sized to take about a quarter of it.
    pub interval: Duration,
    /// Identifies the scene and options, so a checkpoint never resumes another render.
    pub fingerprint: u64,
}

/// How a render is run (not what it computes: the image depends on none of these).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DriverOptions {
    /// Worker threads; None: one per core.
    pub threads: Option<usize>,
    /// Save checkpoints (None: an interrupted render just stops, its state kept in memory).
    pub checkpoint: Option<Checkpointing>,
}

/// How a call to [`render`] ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Every tile has all its samples.
    Complete,
    /// Stopped at a sample boundary because the interrupt flag was set (the checkpoint, if
    /// any, is written).
    Interrupted,
}

/// Most worker threads a render takes.
pub const MAX_THREADS: usize = 4096;

/// Longest pass in seconds when no checkpoint interval sizes it.
const MAX_PASS_SECONDS: f64 = 15.0;

/// Renders the rest of `state` with `rs` on `opts.threads` threads until it is complete or
/// `interrupt` is set. `progress` receives (pixel-samples, rays) as each tile finishes a
/// sample index. An interrupted render with checkpointing saves its state before returning.
pub fn render(
    rs: &RenderScene,
    state: &mut RenderState,
    opts: &DriverOptions,
    interrupt: &AtomicBool,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<Outcome> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(t) = opts.threads {
        if t == 0 || t > MAX_THREADS {
            return Err(Error::Invalid(format!(
                "{t} threads: must be in 1..={MAX_THREADS}"
            )));
        }
        builder = builder.num_threads(t);
    }
    let pool = builder
        .build()
        .map_err(|e| Error::Invalid(format!("cannot start the worker threads: {e}")))?;
    let interval = opts.checkpoint.as_ref().map(|c| c.interval);
    // Passes take ~1/4 of the checkpoint interval (at most MAX_PASS_SECONDS), so an interrupt
    // or a checkpoint waits at most that long.
    let target = interval.map_or(MAX_PASS_SECONDS, |i| {
        (i.as_secs_f64() / 4.0).min(MAX_PASS_SECONDS)
    });
    let spp = state.settings.spp();
    let mut last_ckpt = Instant::now();
    let mut k = 1u32;
    while !state.is_complete() && !interrupt.load(Ordering::SeqCst) {
        let t0 = Instant::now();
        let before = state.samples_done();
        pool.install(|| run_pass(rs, state, k, interrupt, progress));
        let dt = t0.elapsed().as_secs_f64().max(1e-3);
        let frac = (state.samples_done() - before) as f64 / state.samples_total().max(1) as f64;
        let per_spp = dt / (frac * spp as f64).max(1e-9);
        k = ((target / per_spp) as u32).clamp(1, 1 << 16);
        if let Some(c) = &opts.checkpoint
            && last_ckpt.elapsed() >= c.interval
            && !state.is_complete()
        {
            checkpoint::save(&c.path, state, c.fingerprint)?;
            last_ckpt = Instant::now();
        }
    }
    if state.is_complete() {
        return Ok(Outcome::Complete);
    }
    if let Some(c) = &opts.checkpoint {
        checkpoint::save(&c.path, state, c.fingerprint)?;
    }
    Ok(Outcome::Interrupted)
}

/// Renders all remaining samples of `state` on the current rayon pool, without checkpoints or
/// interruption: what tests and benches call.
pub fn render_all(rs: &RenderScene, state: &mut RenderState) {
    let go = AtomicBool::new(false);
    while !state.is_complete() {
        run_pass(rs, state, 1 << 20, &go, &|_, _| {});
    }
}

/// One pass: up to `k` more samples per pixel for every unfinished tile, in parallel over tiles
/// (on the current rayon pool), each tile traced by the scene's integrator. Stops early, at a
/// sample boundary of each tile, once `interrupt` is set.
pub fn run_pass(
    rs: &RenderScene,
    state: &mut RenderState,
    k: u32,
    interrupt: &AtomicBool,
    progress: &(dyn Fn(u64, u64) + Sync),
) {
    let s = state.settings;
    let filter = state.filter;
    state.tiles.par_iter_mut().for_each(|tile| {
        let end = s.spp().min(tile.done.saturating_add(k));
        match rs.integrator_kind() {
            IntegratorKind::Packet(opts) => {
                super::packet::render_tile(rs, opts, &s, &filter, tile, end, interrupt, progress)
            }
            IntegratorKind::Scalar => rs
                .integrator
                .render_tile(rs, &s, &filter, tile, end, interrupt, progress),
        }
    });
}
