//! Lane-utilisation counters of the packet integrator: how many of the SIMD lanes issued were
//! carrying a live path, in traversal (fixed 16-slot packets of the pool) and in shading
//! (per-BSDF batches after the sort). Counted per tile pass and summed atomically per render.

use std::sync::atomic::{AtomicU64, Ordering};

/// Lanes per packet: the AVX-512 width of f32, also the batch size of the shading kernels.
pub const LANES: usize = 16;

/// Counts of one worker (plain integers; no atomics on the hot path).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LaneStats {
    /// Megakernel iterations (one intersect + shade + shadow round over the pool).
    pub steps: u64,
    /// Traversal: 16 × packets with at least one live path, summed over steps.
    pub issued: u64,
    /// Traversal: live paths, summed over steps.
    pub active: u64,
    /// Shading: 16 × ⌈n/16⌉ per BSDF batch of n lanes, summed over steps.
    pub shade_issued: u64,
    /// Shading: lanes that reached a surface or escaped, summed over steps.
    pub shade_active: u64,
}

impl LaneStats {
    /// Active lanes / lanes issued in traversal (1 = every lane busy); 0 before any step.
    pub fn utilisation(&self) -> f64 {
        ratio(self.active, self.issued)
    }

    /// Active lanes / lanes issued in the per-BSDF shading batches.
    pub fn shade_utilisation(&self) -> f64 {
        ratio(self.shade_active, self.shade_issued)
    }
}

fn ratio(a: u64, b: u64) -> f64 {
    if b == 0 { 0.0 } else { a as f64 / b as f64 }
}

/// [`LaneStats`] summed over the workers of a render (shared, updated once per tile pass).
#[derive(Debug, Default)]
pub struct LaneCounters {
    steps: AtomicU64,
    issued: AtomicU64,
    active: AtomicU64,
    shade_issued: AtomicU64,
    shade_active: AtomicU64,
}

impl LaneCounters {
    /// Adds one worker's counts.
    pub fn add(&self, s: &LaneStats) {
        self.steps.fetch_add(s.steps, Ordering::Relaxed);
        self.issued.fetch_add(s.issued, Ordering::Relaxed);
        self.active.fetch_add(s.active, Ordering::Relaxed);
        self.shade_issued
            .fetch_add(s.shade_issued, Ordering::Relaxed);
        self.shade_active
            .fetch_add(s.shade_active, Ordering::Relaxed);
    }

    /// The totals so far.
    pub fn snapshot(&self) -> LaneStats {
        LaneStats {
            steps: self.steps.load(Ordering::Relaxed),
            issued: self.issued.load(Ordering::Relaxed),
            active: self.active.load(Ordering::Relaxed),
            shade_issued: self.shade_issued.load(Ordering::Relaxed),
            shade_active: self.shade_active.load(Ordering::Relaxed),
        }
    }
}
