//! BVH2 → 8-wide collapse: obvhs's binary BVH flattened into [`Node8`]s and leaf packets.

use super::node::{Node8, WIDTH};
use super::tri::LANES;
use obvhs::bvh2::Bvh2;

/// Flattens obvhs's binary BVH into 8-wide nodes: each wide node takes a binary node and
/// repeatedly opens its largest-area inner child until it has eight children (the usual BVH2 →
/// BVH8 collapse). Returns the nodes (root first) and the leaf-ordered triangle packets as
/// source triangle indices (u32::MAX in unused lanes). Iterative, so deep trees cannot overflow
/// the call stack.
pub(super) fn flatten(bvh2: &Bvh2) -> (Vec<Node8>, Vec<[u32; LANES]>) {
    let b = &bvh2.nodes;
    let mut nodes = Vec::with_capacity(b.len() / 4 + 1);
    let mut order: Vec<[u32; LANES]> = Vec::with_capacity(bvh2.primitive_indices.len() / 2);
    // (binary node to turn into a wide node, wide parent and slot to link it from)
    let mut work: Vec<(u32, Option<(usize, usize)>)> = vec![(0, None)];
    let mut kids: Vec<u32> = Vec::with_capacity(WIDTH);
    while let Some((bi, parent)) = work.pop() {
        let me = nodes.len();
        nodes.push(Node8::EMPTY);
        if let Some((p, slot)) = parent {
            let pn: &mut Node8 = &mut nodes[p];
            pn.child[slot] = me as u32;
        }
        kids.clear();
        kids.push(bi);
        while kids.len() < WIDTH {
            let open = kids
                .iter()
                .enumerate()
                .filter(|(_, k)| b[**k as usize].prim_count == 0)
                .max_by(|x, y| {
                    let ax = b[*x.1 as usize].aabb.half_area();
                    let ay = b[*y.1 as usize].aabb.half_area();
                    ax.total_cmp(&ay)
                })
                .map(|(i, _)| i);
            let Some(i) = open else { break };
            let first = b[kids[i] as usize].first_index;
            kids.swap_remove(i);
            kids.push(first);
            kids.push(first + 1);
        }
        for (slot, &k) in kids.iter().enumerate() {
            let bn = &b[k as usize];
            let (mn, mx) = (bn.aabb.min, bn.aabb.max);
            let n = &mut nodes[me];
            for a in 0..3 {
                n.bounds[2 * a][slot] = mn[a];
                n.bounds[2 * a + 1][slot] = mx[a];
            }
            if bn.prim_count == 0 {
                work.push((k, Some((me, slot))));
            } else {
                let f = bn.first_index as usize;
                let prims = &bvh2.primitive_indices[f..f + bn.prim_count as usize];
                n.child[slot] = order.len() as u32;
                n.count[slot] = prims.len().div_ceil(LANES) as u32;
                for chunk in prims.chunks(LANES) {
                    let mut pk = [u32::MAX; LANES];
                    pk[..chunk.len()].copy_from_slice(chunk);
                    order.push(pk);
                }
            }
        }
    }
    (nodes, order)
}
