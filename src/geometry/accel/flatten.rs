//! BVH2 → 8-wide: obvhs's binary BVH flattened into [`Node8`]s and leaf packets, grouped as a
//! [`WidePlan`] chose.

use super::collapse::{WidePlan, subtree_prims};
use super::node::{Node8, WIDTH};
use super::tri::LANES;
use obvhs::bvh2::Bvh2;

/// Flattens obvhs's binary BVH into 8-wide nodes appended to `nodes`: each wide node takes a
/// binary node and the (at most eight) slots `plan` chose for it, each a leaf of its whole
/// subtree's triangles or the next wide node. The leaf children of one wide node share packets: their
/// triangles are packed first-fit, largest leaf first, into as few 8-lane packets as hold them
/// without splitting a leaf, appended to `packets` as global triangle ids (`gids` of obvhs's
/// primitive indices; u32::MAX in unused lanes). A leaf child then tests its packet mates too,
/// which costs nothing (the lanes run at once) and can only find real hits. Returns the index
/// of the root wide node. Iterative, so deep trees cannot overflow the call stack.
pub(super) fn flatten(
    bvh2: &Bvh2,
    plan: &WidePlan,
    gids: &[u32],
    nodes: &mut Vec<Node8>,
    packets: &mut Vec<[u32; LANES]>,
) -> u32 {
    let b = &bvh2.nodes;
    let root = nodes.len() as u32;
    nodes.reserve(b.len() / 8 + 1);
    packets.reserve(bvh2.primitive_indices.len() / 5 + 1);
    // (binary node to turn into a wide node, wide parent and slot to link it from)
    let mut work: Vec<(u32, Option<(usize, usize)>)> = vec![(0, None)];
    let mut kids: Vec<u32> = Vec::with_capacity(WIDTH);
    // Leaf children of the current wide node: (slot, first primitive in `prims`, count).
    let mut leaves: Vec<(usize, usize, usize)> = Vec::with_capacity(WIDTH);
    // The primitives of the current wide node's leaf children.
    let mut prims: Vec<u32> = Vec::with_capacity(WIDTH * 2 * LANES);
    // Lanes used in each packet opened for the current wide node.
    let mut fill: Vec<usize> = Vec::with_capacity(WIDTH);
    while let Some((bi, parent)) = work.pop() {
        let me = nodes.len();
        nodes.push(Node8::EMPTY);
        if let Some((p, slot)) = parent {
            nodes[p].child[slot] = me as u32;
        }
        kids.clear();
        plan.slots(bvh2, bi, &mut kids);
        leaves.clear();
        prims.clear();
        for (slot, &k) in kids.iter().enumerate() {
            let bn = &b[k as usize];
            let bx = bn.aabb();
            let n = &mut nodes[me];
            for a in 0..3 {
                n.bounds[2 * a][slot] = bx.min[a];
                n.bounds[2 * a + 1][slot] = bx.max[a];
            }
            if !plan.is_leaf(k) {
                work.push((k, Some((me, slot))));
            } else {
                let first = prims.len();
                subtree_prims(bvh2, k, &mut prims);
                leaves.push((slot, first, prims.len() - first));
            }
        }
        // Largest leaf first (ties by slot, so the layout is deterministic).
        leaves.sort_by(|x, y| y.2.cmp(&x.2).then(x.0.cmp(&y.0)));
        fill.clear();
        let base = packets.len();
        for &(slot, f, count) in &leaves {
            let prims = &prims[f..f + count];
            let n = &mut nodes[me];
            if count > LANES {
                // Only with leaves wider than a packet: whole packets of its own.
                n.set_leaf(slot, packets.len() as u32, count.div_ceil(LANES));
                for chunk in prims.chunks(LANES) {
                    let mut pk = [u32::MAX; LANES];
                    for (l, &p) in pk.iter_mut().zip(chunk) {
                        *l = gids[p as usize];
                    }
                    packets.push(pk);
                    fill.push(LANES);
                }
                continue;
            }
            let bin = match fill.iter().position(|&u| u + count <= LANES) {
                Some(i) => i,
                None => {
                    packets.push([u32::MAX; LANES]);
                    fill.push(0);
                    fill.len() - 1
                }
            };
            let pk = &mut packets[base + bin];
            for (l, &p) in pk[fill[bin]..].iter_mut().zip(prims) {
                *l = gids[p as usize];
            }
            fill[bin] += count;
            n.set_leaf(slot, (base + bin) as u32, 1);
        }
        nodes[me].link_shared_packets();
    }
    root
}
