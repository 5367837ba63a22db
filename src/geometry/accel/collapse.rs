//! The SAH-optimal grouping of obvhs's binary BVH into 8-wide nodes and packet leaves (the
//! dynamic program of Ylitie, Karras and Laine, "Efficient incoherent ray traversal on GPUs
//! through compressed wide BVHs", HPG 2017, with leaves priced in 8-lane packet tests).
//!
//! Per binary node n and slot budget i ≤ 8, C(n, i) is the least surface-area cost of n's
//! subtree given as at most i child slots of a wide node: n itself as one slot (a leaf, costing
//! area × ⌈triangles / 8⌉ packet tests, or a wide node, costing area × [`NODE_COST`] plus its
//! own eight slots), or the two children sharing the budget. Obvhs's own collapse prices every
//! triangle alike and leaves the wide grouping to a greedy pass; here both are chosen together.

use obvhs::bvh2::Bvh2;

use super::node::WIDTH;
use super::tri::LANES;

/// Binary subtrees of at most this many triangles may become one leaf (three packets): larger
/// leaves pay packet tests a deeper node would have culled, smaller ones leave wide nodes
/// half empty near the bottom of big meshes (`docs/architecture.md` has the sweep).
pub(super) const MAX_LEAF_TRIS: u32 = (3 * LANES) as u32;

/// Cost of one wide node's visit (its slab test of eight boxes, the sort of the entered
/// children and their stack pushes), in 8-lane packet tests.
pub(super) const NODE_COST: f32 = 3.0;

/// The chosen grouping: which binary nodes are slots of which wide node, and which slots are
/// leaves.
pub(super) struct WidePlan {
    /// Per binary node, per budget i = 2..=8 (index i − 1): the left child's share of the budget
    /// when the two children share it (0: the node is one slot for this budget).
    split: Vec<[u8; WIDTH]>,
    /// Per binary node: as one slot, the whole subtree is one leaf (else a wide node).
    leaf: Vec<bool>,
    /// Per binary node: its children's best sharing of a full wide node's eight slots.
    full: Vec<u8>,
}

impl WidePlan {
    /// Solves the grouping for `bvh2` bottom up (iterative post order; O(nodes × 8²)).
    pub fn new(bvh2: &Bvh2) -> WidePlan {
        let b = &bvh2.nodes;
        let n = b.len();
        let mut cost = vec![[0f32; WIDTH]; n];
        let mut count = vec![0u32; n];
        let mut split = vec![[0u8; WIDTH]; n];
        let mut leaf = vec![false; n];
        let mut full = vec![0u8; n];
        let mut stack: Vec<(u32, bool)> = Vec::with_capacity(64);
        if n > 0 {
            stack.push((0, false));
        }
        while let Some((i, done)) = stack.pop() {
            let i = i as usize;
            let node = &b[i];
            let area = node.aabb().half_area().max(0.0);
            if node.prim_count > 0 {
                count[i] = node.prim_count;
                leaf[i] = true;
                cost[i] = [area * node.prim_count.div_ceil(LANES as u32) as f32; WIDTH];
                continue;
            }
            let (l, r) = (node.first_index as usize, node.first_index as usize + 1);
            if !done {
                stack.push((i as u32, true));
                stack.push((r as u32, false));
                stack.push((l as u32, false));
                continue;
            }
            count[i] = count[l] + count[r];
            // dist[j − 1]: the children sharing j slots (j ≥ 2), and the left share.
            let mut dist = [f32::INFINITY; WIDTH];
            let mut share = [0u8; WIDTH];
            for j in 2..=WIDTH {
                for k in 1..j {
                    let c = cost[l][k - 1] + cost[r][j - k - 1];
                    if c < dist[j - 1] {
                        dist[j - 1] = c;
                        share[j - 1] = k as u8;
                    }
                }
            }
            let internal = area * NODE_COST + dist[WIDTH - 1];
            let as_leaf = if count[i] <= MAX_LEAF_TRIS {
                area * count[i].div_ceil(LANES as u32) as f32
            } else {
                f32::INFINITY
            };
            leaf[i] = as_leaf <= internal;
            let one = as_leaf.min(internal);
            full[i] = share[WIDTH - 1];
            cost[i][0] = one;
            for j in 2..=WIDTH {
                if dist[j - 1] < one {
                    cost[i][j - 1] = dist[j - 1];
                    split[i][j - 1] = share[j - 1];
                } else {
                    cost[i][j - 1] = one;
                }
            }
        }
        WidePlan { split, leaf, full }
    }

    /// Whether binary node `i`, as a slot, is a leaf of its whole subtree.
    #[inline]
    pub fn is_leaf(&self, i: u32) -> bool {
        self.leaf[i as usize]
    }

    /// Appends the slots of the wide node made from binary node `i` (at most eight; `i` itself
    /// if it is a leaf, so a one-leaf tree gets a root with one slot).
    pub fn slots(&self, bvh2: &Bvh2, i: u32, out: &mut Vec<u32>) {
        if self.leaf[i as usize] {
            out.push(i);
            return;
        }
        let f = bvh2.nodes[i as usize].first_index;
        let k = self.full[i as usize] as usize;
        self.share(bvh2, f, k, out);
        self.share(bvh2, f + 1, WIDTH - k, out);
    }

    /// Appends the at most `budget` slots binary node `i`'s subtree is given as.
    fn share(&self, bvh2: &Bvh2, i: u32, budget: usize, out: &mut Vec<u32>) {
        let k = self.split[i as usize][budget - 1] as usize;
        if k == 0 {
            out.push(i);
            return;
        }
        let f = bvh2.nodes[i as usize].first_index;
        self.share(bvh2, f, k, out);
        self.share(bvh2, f + 1, budget - k, out);
    }
}

/// Appends to `out` the primitive indices of binary node `i`'s subtree, left to right.
pub(super) fn subtree_prims(bvh2: &Bvh2, i: u32, out: &mut Vec<u32>) {
    let mut stack = vec![i];
    while let Some(j) = stack.pop() {
        let n = &bvh2.nodes[j as usize];
        if n.prim_count > 0 {
            let f = n.first_index as usize;
            out.extend_from_slice(&bvh2.primitive_indices[f..f + n.prim_count as usize]);
        } else {
            stack.push(n.first_index + 1);
            stack.push(n.first_index);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::build::{TriIds, binary_bvh};
    use super::*;
    use crate::geometry::Mesh;
    use crate::geometry::generate::sphere_displaced;
    use crate::math::Vec3;

    /// A bumpy sphere and a few far-flung triangles: a deep tree with nodes of every kind.
    fn meshes() -> Vec<Mesh> {
        let mut m = vec![sphere_displaced(
            Vec3::ZERO,
            1.0,
            20,
            40,
            false,
            true,
            |d| 0.2 * (9.0 * d.x).sin() * (4.0 * d.z).cos(),
        )];
        let mut rng = crate::math::Pcg32::new(5, 11);
        for _ in 0..40 {
            let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 8.0 - 4.0;
            m.push(Mesh {
                positions: vec![c, c + Vec3::X * 0.2, c + Vec3::Y * 0.3],
                indices: vec![[0, 1, 2]],
                ..Default::default()
            });
        }
        m
    }

    /// obvhs's binary tree over every triangle of `m` and its plan.
    fn planned_tree(m: &[Mesh]) -> (Bvh2, WidePlan) {
        let ids = TriIds::new_filtered(m, |_| true);
        let gids: Vec<u32> = (0..ids.total as u32).collect();
        let bvh2 = binary_bvh(&ids, &gids);
        let plan = WidePlan::new(&bvh2);
        (bvh2, plan)
    }

    fn area(bvh2: &Bvh2, i: u32) -> f32 {
        bvh2.nodes[i as usize].aabb().half_area().max(0.0)
    }

    fn count(bvh2: &Bvh2, i: u32) -> u32 {
        let mut v = Vec::new();
        subtree_prims(bvh2, i, &mut v);
        v.len() as u32
    }

    /// Surface-area cost of the wide tree rooted at binary node `i` whose slots `slots` gives.
    fn tree_cost(bvh2: &Bvh2, i: u32, slots: &dyn Fn(u32) -> (Vec<u32>, Vec<bool>)) -> f32 {
        let (kids, leaf) = slots(i);
        assert!(!kids.is_empty() && kids.len() <= WIDTH);
        let mut c = area(bvh2, i) * NODE_COST;
        for (&k, &is_leaf) in kids.iter().zip(&leaf) {
            c += if is_leaf {
                area(bvh2, k) * count(bvh2, k).div_ceil(LANES as u32) as f32
            } else {
                tree_cost(bvh2, k, slots)
            };
        }
        c
    }

    #[test]
    fn every_triangle_lands_in_one_leaf_of_at_most_max_triangles() {
        let m = meshes();
        let (bvh2, plan) = planned_tree(&m);
        let mut seen = vec![0u32; bvh2.primitive_indices.len()];
        let mut work = vec![0u32];
        let (mut wide, mut leaves) = (0, 0);
        while let Some(i) = work.pop() {
            wide += 1;
            let mut kids = Vec::new();
            plan.slots(&bvh2, i, &mut kids);
            assert!(
                !kids.is_empty() && kids.len() <= WIDTH,
                "{} slots",
                kids.len()
            );
            for k in kids {
                if plan.is_leaf(k) {
                    leaves += 1;
                    let mut p = Vec::new();
                    subtree_prims(&bvh2, k, &mut p);
                    assert!(!p.is_empty() && p.len() as u32 <= MAX_LEAF_TRIS);
                    p.iter().for_each(|&q| seen[q as usize] += 1);
                } else {
                    work.push(k);
                }
            }
        }
        assert!(seen.iter().all(|&s| s == 1));
        // Grouped, not one triangle per leaf nor one leaf per wide node.
        assert!(
            leaves * 3 < seen.len() && wide * 3 < leaves,
            "{wide} {leaves}"
        );
    }

    #[test]
    fn the_plan_costs_less_than_the_greedy_grouping() {
        let m = meshes();
        let (bvh2, plan) = planned_tree(&m);
        let b = &bvh2.nodes;
        let planned = |i: u32| {
            let mut kids = Vec::new();
            plan.slots(&bvh2, i, &mut kids);
            let leaf = kids.iter().map(|&k| plan.is_leaf(k)).collect();
            (kids, leaf)
        };
        // The usual greedy BVH2 → BVH8 collapse: open the largest inner slot until eight;
        // subtrees of at most MAX_LEAF_TRIS triangles made leaves when that is cheaper.
        let greedy = |i: u32| {
            let mut kids = vec![i];
            loop {
                let open = (0..kids.len())
                    .filter(|&s| b[kids[s] as usize].prim_count == 0)
                    .max_by(|&x, &y| area(&bvh2, kids[x]).total_cmp(&area(&bvh2, kids[y])));
                match open {
                    Some(s) if kids.len() < WIDTH => {
                        let f = b[kids[s] as usize].first_index;
                        kids.swap_remove(s);
                        kids.extend([f, f + 1]);
                    }
                    _ => break,
                }
            }
            let leaf = kids.iter().map(|&k| b[k as usize].prim_count > 0).collect();
            (kids, leaf)
        };
        let (p, g) = (tree_cost(&bvh2, 0, &planned), tree_cost(&bvh2, 0, &greedy));
        assert!(p.is_finite() && p < 0.9 * g, "plan {p}, greedy {g}");
    }

    #[test]
    fn a_tiny_scene_is_one_wide_node_of_leaves() {
        let m = meshes()[1..5].to_vec();
        let (bvh2, plan) = planned_tree(&m);
        let mut kids = Vec::new();
        plan.slots(&bvh2, 0, &mut kids);
        assert!(kids.iter().all(|&k| plan.is_leaf(k)));
    }
}
