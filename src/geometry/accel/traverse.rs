//! Front-to-back traversal of the 8-wide BVH, compiled three times: over [`Avx8`] (one ymm
//! register per 8-lane step) with AVX2 enabled and with AVX-512 VL enabled (32 registers, picked
//! when `simd::isa()` reports AVX-512), and in the baseline build over [`Sse8`] (two SSE
//! halves), so a baseline (SSE2) binary still runs 8-wide code on AVX2 machines.
//!
//! Not `isa_dispatch!`: that macro compiles one body for every ISA, while here the body's
//! lane type differs per build (explicit AVX intrinsics only exist in the AVX2 one).

#[cfg(target_arch = "x86_64")]
use super::lanes::Avx8;
use super::lanes::{F8, Sse8};
use super::node::{Node8, PACKETS_BITS, RayBox, WIDTH, prefetch_node};
use super::stack::{Entry, Stack};
use super::tri::{LANES, TriPack, prefetch_packet};
use crate::math::Vec3;
use crate::math::simd::{Isa, Level};

/// A traversal result: the triangle slot (packet · LANES + lane; [`SlotHit::NONE`] if nothing
/// was hit), t, b1, b2. Sixteen bytes, so it comes back in two registers: the 20-byte
/// `Option<(u32, f32, f32, f32)>` it replaces was returned through the stack, and the caller's
/// wider reloads of the callee's 4-byte stores missed store forwarding (2.6 % of a Cornell-box
/// render on one instruction).
#[derive(Clone, Copy, Debug)]
pub(super) struct SlotHit {
    pub slot: u32,
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

impl SlotHit {
    /// The slot of "no hit".
    pub const NONE: u32 = u32::MAX;

    /// No hit.
    const MISS: SlotHit = SlotHit {
        slot: SlotHit::NONE,
        t: 0.0,
        u: 0.0,
        v: 0.0,
    };

    /// True if a triangle was hit.
    #[inline(always)]
    pub fn is_hit(&self) -> bool {
        self.slot != SlotHit::NONE
    }
}

/// Closest hit (`ANY` = false) or any hit (`ANY` = true) in (0, tmax] of `o + t d` among
/// `tris` under `nodes` (root first), with the traversal built for `isa` (callers pass
/// `simd::isa()` or, in tests, what it allows).
#[inline]
pub(super) fn run<const ANY: bool>(
    isa: Isa,
    nodes: &[Node8],
    tris: &[TriPack],
    o: Vec3,
    d: Vec3,
    tmax: f32,
) -> SlotHit {
    match isa.level() {
        // SAFETY: an `Isa` of these levels is made only by `simd::isa()` / `Isa::available`,
        // which checked AVX2 on this CPU (AVX-512 implies it there).
        // (AVX-512 VL as well: std caches the CPUID answer, one load per ray.)
        #[cfg(target_arch = "x86_64")]
        Level::Avx512 if std::arch::is_x86_feature_detected!("avx512vl") => unsafe {
            run_avx512::<ANY>(nodes, tris, o, d, tmax)
        },
        // SAFETY: as above, AVX2 checked.
        #[cfg(target_arch = "x86_64")]
        Level::Avx512 | Level::Avx2 => unsafe { run_avx2::<ANY>(nodes, tris, o, d, tmax) },
        _ => traverse::<ANY, Sse8>(nodes, tris, o, d, tmax),
    }
}

/// [`traverse`] over [`Avx8`] lanes, compiled with AVX2 enabled.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn run_avx2<const ANY: bool>(
    nodes: &[Node8],
    tris: &[TriPack],
    o: Vec3,
    d: Vec3,
    tmax: f32,
) -> SlotHit {
    traverse::<ANY, Avx8>(nodes, tris, o, d, tmax)
}

/// [`traverse`] over [`Avx8`] lanes, compiled with AVX-512 (VL) enabled: the same ymm
/// operations, but EVEX-encoded with 32 vector registers instead of 16, so the per-ray
/// constants stay in registers instead of being reloaded from the stack at every node.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,avx512f,avx512vl")]
fn run_avx512<const ANY: bool>(
    nodes: &[Node8],
    tris: &[TriPack],
    o: Vec3,
    d: Vec3,
    tmax: f32,
) -> SlotHit {
    traverse::<ANY, Avx8>(nodes, tris, o, d, tmax)
}

/// Front-to-back traversal. Closest hit (`ANY` = false): (triangle slot, t, b1, b2) of the
/// nearest hit; any hit (`ANY` = true): the first hit found. At each node the entered children
/// are split into inner nodes and leaves, and the memory of all of them is prefetched before
/// any is used (the misses then overlap instead of following one another); the leaves are then
/// intersected in slot order (shrinking tmax), a packet shared by several entered leaves once
/// while tmax is unchanged; inner children are visited nearest first and the others stacked
/// with their entry distance, dropped on pop once a closer hit is known.
#[inline(always)]
fn traverse<const ANY: bool, V: F8>(
    nodes: &[Node8],
    tris: &[TriPack],
    o: Vec3,
    d: Vec3,
    tmax: f32,
) -> SlotHit {
    if nodes.is_empty() {
        return SlotHit::MISS;
    }
    let rb = RayBox::<V>::new(o, d);
    let da = [V::splat(d.x), V::splat(d.y), V::splat(d.z)];
    let mut tmax = tmax;
    let mut best = SlotHit::MISS;
    let mut stack = Stack::new();
    let mut node = 0u32;
    loop {
        let n = &nodes[node as usize];
        let (tn, mut mask) = rb.test(n, tmax);
        let mut inner = [Entry { node: 0, t: 0.0 }; WIDTH];
        let mut k = 0;
        let mut leaves = 0u32;
        while mask != 0 {
            // (`& 7`: the mask has eight bits; it spares the bounds checks.)
            let i = mask.trailing_zeros() as usize & (WIDTH - 1);
            mask &= mask - 1;
            let count = n.count[i];
            if count == 0 {
                let c = n.child[i];
                prefetch_node(nodes, c);
                inner[k & (WIDTH - 1)] = Entry { node: c, t: tn[i] };
                k += 1;
            } else {
                leaves |= 1 << i;
                let first = n.child[i] as usize;
                let packets = (count & PACKET_MASK) as usize;
                if let Some(ps) = tris.get(first..first + packets) {
                    for p in ps {
                        prefetch_packet(p);
                    }
                }
            }
        }
        // Packet groups (see `Node8::count`) tested since tmax last changed: testing one
        // again could only find the same hit.
        let mut tested = 0u32;
        while leaves != 0 {
            let i = leaves.trailing_zeros() as usize & (WIDTH - 1);
            leaves &= leaves - 1;
            let count = n.count[i];
            let group = 1u32 << (count >> PACKETS_BITS);
            if tested & group != 0 {
                continue;
            }
            tested |= group;
            let first = n.child[i] as usize;
            let packets = (count & PACKET_MASK) as usize;
            for (j, tri) in tris[first..first + packets].iter().enumerate() {
                let h = tri.intersect(&rb.o, &da, tmax);
                if h.mask == 0 {
                    continue;
                }
                // Nearest lane that hit (the lowest one on a tie).
                let mut m = h.mask;
                let mut lane = m.trailing_zeros() as usize;
                m &= m - 1;
                while m != 0 {
                    let l = m.trailing_zeros() as usize;
                    m &= m - 1;
                    if h.t[l] < h.t[lane] {
                        lane = l;
                    }
                }
                best = SlotHit {
                    slot: (LANES * (first + j) + lane) as u32,
                    t: h.t[lane],
                    u: h.u[lane],
                    v: h.v[lane],
                };
                if ANY {
                    return best;
                }
                tmax = best.t;
                // A packet tested before at a larger tmax may hold a lane at exactly this
                // distance, which a second test would now pick: only this group stays done.
                tested = group;
            }
        }
        // Any hit: no order to keep (tmax stays put until the first hit ends the search), so
        // the entered children are stacked as found, as Embree's occlusion traversal does.
        // Closest hit: sort them farthest first (insertion sort, at most eight), dropping those
        // entered beyond a hit found in a sibling leaf.
        let m = if ANY {
            k
        } else {
            let mut m = 0;
            for a in 0..k {
                let e = inner[a & (WIDTH - 1)];
                if e.t > tmax {
                    continue;
                }
                let mut j = m;
                while j > 0 && inner[(j - 1) & (WIDTH - 1)].t < e.t {
                    inner[j & (WIDTH - 1)] = inner[(j - 1) & (WIDTH - 1)];
                    j -= 1;
                }
                inner[j & (WIDTH - 1)] = e;
                m += 1;
            }
            m
        };
        if m > 0 {
            for e in &inner[..m - 1] {
                stack.push(*e);
            }
            node = inner[(m - 1) & (WIDTH - 1)].node;
            continue;
        }
        loop {
            match stack.pop() {
                Some(e) if e.t <= tmax => {
                    node = e.node;
                    break;
                }
                Some(_) => {}
                None => return best,
            }
        }
    }
}

/// Mask of a leaf's packet count in [`Node8::count`].
const PACKET_MASK: u32 = (1 << PACKETS_BITS) - 1;
