//! Front-to-back traversal of the 8-wide BVH, compiled twice: with AVX2 enabled over [`Avx8`]
//! (one ymm register per 8-lane step; picked when `simd::isa()` reports AVX2 or AVX-512) and
//! in the baseline build over [`Sse8`] (two SSE halves), so a baseline (SSE2) binary still
//! runs 8-wide code on AVX2 machines.
//!
//! Not `isa_dispatch!`: that macro compiles one body for every ISA, while here the body's
//! lane type differs per build (explicit AVX intrinsics only exist in the AVX2 one).

use super::node::{Node8, RayBox, WIDTH};
use super::stack::{Entry, Stack};
use super::tri::{LANES, TriPack};
use crate::math::Vec3;
#[cfg(target_arch = "x86_64")]
use crate::math::simd::f8::Avx8;
use crate::math::simd::f8::{F8, Sse8};
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

/// Front-to-back traversal. Closest hit (`ANY` = false): (triangle slot, t, b1, b2) of the
/// nearest hit; any hit (`ANY` = true): the first hit found. Leaf children are intersected
/// as soon as their box is entered (shrinking tmax); inner children are visited nearest
/// first and the others stacked with their entry distance, dropped on pop once a closer
/// hit is known.
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
        let (tn, mask) = rb.test(n, tmax);
        // Leaves first, in slot order, as soon as entered (shrinking tmax). One-packet leaves
        // share packets (`flatten`): a packet already tested at this node cannot give a new
        // hit (nothing farther than tmax counts, and its own hit would be found again as is),
        // so the later slots of the same packet are dropped.
        let mut leaves = mask & n.leaves as u32;
        while leaves != 0 {
            let i = leaves.trailing_zeros() as usize;
            leaves &= leaves - 1;
            leaves &= !(n.dup[i] as u32);
            let first = n.child[i] as usize;
            for (j, tri) in tris[first..first + n.count[i] as usize].iter().enumerate() {
                let h = tri.intersect(&rb.o, &da, tmax);
                let Some(lane) = h.nearest() else {
                    continue;
                };
                // Equal distances: the lowest slot wins, whatever the visiting order (as
                // the packet traversal decides).
                let slot = (LANES * (first + j) + lane) as u32;
                if !ANY && h.t[lane] == best.t && slot > best.slot {
                    continue;
                }
                best = SlotHit {
                    slot,
                    t: h.t[lane],
                    u: h.u[lane],
                    v: h.v[lane],
                };
                if ANY {
                    return best;
                }
                tmax = best.t;
            }
        }
        let mut inner = [Entry { node: 0, t: 0.0 }; WIDTH];
        let mut k = 0;
        let mut inners = mask & !(n.leaves as u32);
        while inners != 0 {
            let i = inners.trailing_zeros() as usize;
            inners &= inners - 1;
            inner[k] = Entry {
                node: n.child[i],
                t: tn[i],
            };
            k += 1;
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
                let e = inner[a];
                if e.t > tmax {
                    continue;
                }
                let mut j = m;
                while j > 0 && inner[j - 1].t < e.t {
                    inner[j] = inner[j - 1];
                    j -= 1;
                }
                inner[j] = e;
                m += 1;
            }
            m
        };
        if m > 0 {
            for e in &inner[..m - 1] {
                stack.push(*e);
            }
            node = inner[m - 1].node;
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
