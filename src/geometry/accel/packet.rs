//! Closest-hit traversal of sixteen rays at once, for coherent rays (a row of camera rays):
//! one 16-lane slab test per child box and one 16-lane test per leaf triangle instead of
//! sixteen one-ray traversals, as Embree's packet traversal serves Mitsuba's camera rays.
//!
//! Each lane gets exactly the hit the one-ray traversal ([`super::traverse`]) gives it: the
//! same box and triangle arithmetic per lane (same operations in the same order, no fused
//! multiply-adds) and the same rule for equal distances (the lowest packet slot wins), so the
//! order in which the packet visits nodes, which differs from any one ray's, cannot change a
//! hit. Only rays whose direction components have the same signs share a packet traversal (the
//! near and far planes of every box are then the same for all lanes); the caller traces a
//! mixed packet one ray at a time.

use super::node::{FAR_SCALE, Node8, WIDTH};
use super::stack::Stack;
use super::traverse::SlotHit;
use super::tri::{LANES, TriPack};
#[cfg(target_arch = "x86_64")]
use crate::math::simd::f8::Avx8;
use crate::math::simd::f8::{F8, Sse8};
use crate::math::simd::{Isa, Level};

/// Rays per packet.
pub(super) const RAYS: usize = 16;

/// Sixteen lanes as two eight-lane halves (lanes 0–7, 8–15): the AVX2 and baseline builds.
#[derive(Clone, Copy)]
struct P<V>([V; 2]);

impl<V: F8> P<V> {
    /// `f` on both halves.
    #[inline(always)]
    fn zip(self, b: P<V>, f: impl Fn(V, V) -> V) -> P<V> {
        P([f(self.0[0], b.0[0]), f(self.0[1], b.0[1])])
    }
    #[inline(always)]
    fn load(a: &[f32; RAYS]) -> P<V> {
        let (lo, hi) = a.split_at(8);
        P([
            V::load(lo.try_into().expect("8 lanes")),
            V::load(hi.try_into().expect("8 lanes")),
        ])
    }
    #[inline(always)]
    fn splat(x: f32) -> P<V> {
        P([V::splat(x); 2])
    }
    #[inline(always)]
    fn sub(self, b: P<V>) -> P<V> {
        self.zip(b, V::sub)
    }
    #[inline(always)]
    fn mul(self, b: P<V>) -> P<V> {
        self.zip(b, V::mul)
    }
    /// `self > b ? self : b` per lane (x86 maxps: `b` when either is NaN).
    #[inline(always)]
    fn max(self, b: P<V>) -> P<V> {
        self.zip(b, V::max)
    }
    /// `self < b ? self : b` per lane (x86 minps: `b` when either is NaN).
    #[inline(always)]
    fn min(self, b: P<V>) -> P<V> {
        self.zip(b, V::min)
    }
    /// Bit l set where lane l of `self` ≤ that of `b` (false on NaN).
    #[inline(always)]
    fn le(self, b: P<V>) -> u32 {
        V::bitmask(self.0[0].le(b.0[0])) | V::bitmask(self.0[1].le(b.0[1])) << 8
    }
    /// Lane `l`.
    #[inline(always)]
    fn lane(self, l: usize) -> f32 {
        self.0[l / 8].to_array()[l % 8]
    }
}

/// A node to visit: its index, each lane's entry distance, and the lanes that entered it.
#[derive(Clone, Copy)]
struct Pending<V> {
    node: u32,
    t: P<V>,
    /// Entry distance of the first lane (the visiting order's key).
    key: f32,
    lanes: u32,
}

/// [`closest16`] over [`Avx8`] halves, compiled with AVX2 enabled.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn closest16_avx2(
    nodes: &[Node8],
    tris: &[TriPack],
    o: &[[f32; RAYS]; 3],
    d: &[[f32; RAYS]; 3],
    tmax: &[f32; RAYS],
    active: u32,
) -> Option<[SlotHit; RAYS]> {
    closest16::<Avx8>(nodes, tris, o, d, tmax, active)
}

/// Closest hits of the rays `o + t d` (lane l of each axis array) in (0, tmax[l]] for the lanes
/// set in `active`, or None if those rays' direction signs differ, with the traversal built for
/// `isa`. Lanes outside `active` come back as misses.
#[inline]
pub(super) fn run16(
    isa: Isa,
    nodes: &[Node8],
    tris: &[TriPack],
    o: &[[f32; RAYS]; 3],
    d: &[[f32; RAYS]; 3],
    tmax: &[f32; RAYS],
    active: u32,
) -> Option<[SlotHit; RAYS]> {
    match isa.level() {
        // SAFETY: an `Isa` of these levels is made only by `simd::isa()` / `Isa::available`,
        // which checked AVX2 on this CPU (AVX-512 implies it there).
        #[cfg(target_arch = "x86_64")]
        Level::Avx512 | Level::Avx2 => unsafe { closest16_avx2(nodes, tris, o, d, tmax, active) },
        _ => closest16::<Sse8>(nodes, tris, o, d, tmax, active),
    }
}

#[inline(always)]
fn closest16<V: F8>(
    nodes: &[Node8],
    tris: &[TriPack],
    o: &[[f32; RAYS]; 3],
    d: &[[f32; RAYS]; 3],
    tmax: &[f32; RAYS],
    active: u32,
) -> Option<[SlotHit; RAYS]> {
    let mut out = [SlotHit {
        slot: SlotHit::NONE,
        t: 0.0,
        u: 0.0,
        v: 0.0,
    }; RAYS];
    if nodes.is_empty() || active == 0 {
        return Some(out);
    }
    // As `RayBox::new`: 1/d per axis (glam's `Vec3::ONE / d`) and the near plane from its sign.
    let mut near = [0usize; 3];
    let mut inv_a = [[0f32; RAYS]; 3];
    for a in 0..3 {
        let mut neg = 0u32;
        for l in 0..RAYS {
            inv_a[a][l] = 1.0 / d[a][l];
            neg |= (inv_a[a][l].is_sign_negative() as u32) << l;
        }
        let neg = neg & active;
        if neg != 0 && neg != active {
            return None;
        }
        near[a] = 2 * a + (neg != 0) as usize;
    }
    let inv: [P<V>; 3] = std::array::from_fn(|a| P::<V>::load(&inv_a[a]));
    let o_a = o;
    let o: [P<V>; 3] = std::array::from_fn(|a| P::<V>::load(&o[a]));
    let mut best = P::<V>::load(tmax);
    let mut best_a = *tmax;
    let mut slot = [SlotHit::NONE; RAYS];
    let (mut bu, mut bv) = ([0f32; RAYS], [0f32; RAYS]);
    let zero = P::<V>::splat(0.0);
    let far_scale = P::<V>::splat(FAR_SCALE);
    let mut stack = Stack::<Pending<V>>::new();
    let mut cur = Pending {
        node: 0,
        t: zero,
        key: 0.0,
        lanes: active,
    };
    loop {
        let n = &nodes[cur.node as usize];
        let mut inner = [cur; WIDTH];
        let mut k = 0;
        for i in 0..WIDTH {
            if n.child[i] == u32::MAX {
                continue;
            }
            // `RayBox::test` for child i, per lane.
            let mut tn = zero;
            let mut tf = best;
            for a in 0..3 {
                let lo = P::<V>::splat(n.bounds[near[a]][i]);
                let hi = P::<V>::splat(n.bounds[near[a] ^ 1][i]);
                tn = lo.sub(o[a]).mul(inv[a]).max(tn);
                tf = hi.sub(o[a]).mul(inv[a]).min(tf);
            }
            let lanes = tn.le(tf.mul(far_scale)) & cur.lanes;
            if lanes == 0 {
                continue;
            }
            if n.leaves & (1 << i) == 0 {
                inner[k] = Pending {
                    node: n.child[i],
                    t: tn,
                    key: tn.lane(lanes.trailing_zeros() as usize),
                    lanes,
                };
                k += 1;
                continue;
            }
            // Leaf packets one ray at a time (`TriPack::intersect`, as the one-ray traversal
            // tests them): eight triangles per test, and the lanes' tests run side by side.
            let first = n.child[i] as usize;
            let mut m = lanes;
            while m != 0 {
                let l = m.trailing_zeros() as usize;
                m &= m - 1;
                let ro = [
                    V::splat(o_a[0][l]),
                    V::splat(o_a[1][l]),
                    V::splat(o_a[2][l]),
                ];
                let rd = [V::splat(d[0][l]), V::splat(d[1][l]), V::splat(d[2][l])];
                for (j, pack) in tris[first..first + n.count[i] as usize].iter().enumerate() {
                    let h = pack.intersect(&ro, &rd, best_a[l]);
                    let Some(k) = h.nearest() else {
                        continue;
                    };
                    let s = (LANES * (first + j) + k) as u32;
                    // (t ≤ the lane's best: nearer, or as near from a lower slot.)
                    if h.t[k] < best_a[l] || s < slot[l] {
                        best_a[l] = h.t[k];
                        slot[l] = s;
                        bu[l] = h.u[k];
                        bv[l] = h.v[k];
                    }
                }
            }
            best = P::<V>::load(&best_a);
        }
        // Nearest child (by its first lane's entry) next, the others stacked farthest first.
        if k > 0 {
            for a in 1..k {
                let e = inner[a];
                let mut j = a;
                while j > 0 && inner[j - 1].key < e.key {
                    inner[j] = inner[j - 1];
                    j -= 1;
                }
                inner[j] = e;
            }
            for e in &inner[..k - 1] {
                stack.push(*e);
            }
            cur = inner[k - 1];
            continue;
        }
        loop {
            let Some(e) = stack.pop() else {
                for l in 0..RAYS {
                    if slot[l] != SlotHit::NONE {
                        out[l] = SlotHit {
                            slot: slot[l],
                            t: best_a[l],
                            u: bu[l],
                            v: bv[l],
                        };
                    }
                }
                return Some(out);
            };
            // As the one-ray traversal drops a stacked node entered beyond its hit.
            let lanes = e.lanes & e.t.le(best);
            if lanes != 0 {
                cur = Pending { lanes, ..e };
                break;
            }
        }
    }
}
