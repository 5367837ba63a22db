//! The 8-wide BVH node (SoA f32 child bounds) and its 8-lane slab test, generic over the lane
//! type ([`F8`]): one ymm operation per step in the AVX2 traversal, two SSE ones in the baseline.

use crate::math::Vec3;
use crate::math::simd::f8::F8;

/// Child slots per node.
pub(super) const WIDTH: usize = 8;

/// 1 + 2γ₃ (pbrt's conservative slab test): the far slab distance is scaled up by this so that
/// rounding in (b − o)·(1/d) never rejects a box the ray passes through.
pub(super) const FAR_SCALE: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// One node of the 8-wide BVH: child bounds as SoA lanes, then child links. 256 bytes, four
/// cache lines. Empty slots have inverted infinite bounds and are never hit.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(super) struct Node8 {
    /// [min x, max x, min y, max y, min z, max z] of the eight children.
    pub bounds: [[f32; WIDTH]; 6],
    /// Internal child: index into the node array. Leaf child: first packet of the leaf.
    pub child: [u32; WIDTH],
    /// 0 for an internal child (or an empty slot), else the number of packets of the leaf
    /// (leaves hold at most three packets, so 16 bits are plenty).
    pub count: [u16; WIDTH],
    /// Per leaf slot, the later leaf slots whose packet is the same (one-packet leaves share
    /// packets, see `flatten`): a ray that tests the packet for this slot skips them.
    pub dup: [u8; WIDTH],
    /// Bit i set if slot i is a leaf: the traversal splits the entered slots with one AND.
    pub leaves: u8,
}

impl Node8 {
    /// A node with every slot empty (inverted infinite bounds, never entered).
    pub const EMPTY: Node8 = Node8 {
        bounds: [
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
        ],
        child: [u32::MAX; WIDTH],
        count: [0; WIDTH],
        dup: [0; WIDTH],
        leaves: 0,
    };

    /// Makes slot `slot` a leaf of `packets` packets starting at packet `first`.
    pub fn set_leaf(&mut self, slot: usize, first: u32, packets: usize) {
        self.child[slot] = first;
        self.count[slot] = u16::try_from(packets).expect("a BVH leaf of over 65 535 packets");
        self.leaves |= 1 << slot;
    }

    /// Fills `dup` from the leaf slots' packets: later one-packet leaves of the same packet.
    pub fn link_shared_packets(&mut self) {
        for i in 0..WIDTH {
            self.dup[i] = 0;
            if self.count[i] != 1 {
                continue;
            }
            for j in i + 1..WIDTH {
                if self.count[j] == 1 && self.child[j] == self.child[i] {
                    self.dup[i] |= 1 << j;
                }
            }
        }
    }
}

/// Per-ray constants of the slab test, splatted into the lane type `V`.
pub(super) struct RayBox<V> {
    /// Ray origin, one vector per axis.
    pub o: [V; 3],
    /// Reciprocal direction (±∞ for zero components), one vector per axis.
    pub inv: [V; 3],
    /// Index of the near plane in `Node8::bounds` per axis (0/1 + 2·axis), from the sign of 1/d.
    pub near: [usize; 3],
}

impl<V: F8> RayBox<V> {
    /// The slab-test constants of the ray `o + t d`.
    #[inline(always)]
    pub fn new(o: Vec3, d: Vec3) -> RayBox<V> {
        let inv = Vec3::ONE / d;
        let near = |a: usize, x: f32| 2 * a + x.is_sign_negative() as usize;
        RayBox {
            o: [V::splat(o.x), V::splat(o.y), V::splat(o.z)],
            inv: [V::splat(inv.x), V::splat(inv.y), V::splat(inv.z)],
            near: [near(0, inv.x), near(1, inv.y), near(2, inv.z)],
        }
    }

    /// Entry distances of the eight children and the mask of those entered within [0, tmax].
    /// NaN slab distances (origin on a slab plane of a zero direction component) are ignored:
    /// SSE/AVX max/min return the second operand when either is NaN, which is the running
    /// bound.
    #[inline(always)]
    pub fn test(&self, n: &Node8, tmax: f32) -> ([f32; WIDTH], u32) {
        let mut tn = V::splat(0.0);
        let mut tf = V::splat(tmax);
        for a in 0..3 {
            let lo = V::load(&n.bounds[self.near[a]]);
            let hi = V::load(&n.bounds[self.near[a] ^ 1]);
            tn = lo.sub(self.o[a]).mul(self.inv[a]).max(tn);
            tf = hi.sub(self.o[a]).mul(self.inv[a]).min(tf);
        }
        let mask = V::bitmask(tn.le(tf.mul(V::splat(FAR_SCALE))));
        (tn.to_array(), mask)
    }
}
