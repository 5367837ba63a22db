//! BVH2 → 8-wide collapse: obvhs's binary BVH flattened into [`Node8`]s and leaf packets.

use super::node::{Node8, WIDTH};
use super::tri::LANES;
use obvhs::bvh2::Bvh2;

/// Flattens obvhs's binary BVH into 8-wide nodes appended to `nodes`: each wide node takes a
/// binary node and repeatedly opens its largest-area inner child until it has eight children
/// (the usual BVH2 → BVH8 collapse). The leaf children of one wide node share packets: their
/// triangles are packed first-fit, largest leaf first, into as few 8-lane packets as hold them
/// without splitting a leaf, appended to `packets` as global triangle ids (`gids` of obvhs's
/// primitive indices; u32::MAX in unused lanes). A leaf child then tests its packet mates too,
/// which costs nothing (the lanes run at once) and can only find real hits. Returns the index
/// of the root wide node. Iterative, so deep trees cannot overflow the call stack.
pub(super) fn flatten(
    bvh2: &Bvh2,
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
    // Leaf children of the current wide node: (slot, first primitive, primitive count).
    let mut leaves: Vec<(usize, usize, usize)> = Vec::with_capacity(WIDTH);
    // Lanes used in each packet opened for the current wide node.
    let mut fill: Vec<usize> = Vec::with_capacity(WIDTH);
    while let Some((bi, parent)) = work.pop() {
        let me = nodes.len();
        nodes.push(Node8::EMPTY);
        if let Some((p, slot)) = parent {
            nodes[p].child[slot] = me as u32;
        }
        kids.clear();
        kids.push(bi);
        while kids.len() < WIDTH {
            let open = kids
                .iter()
                .enumerate()
                .filter(|(_, k)| b[**k as usize].prim_count == 0)
                .max_by(|x, y| {
                    let ax = b[*x.1 as usize].aabb().half_area();
                    let ay = b[*y.1 as usize].aabb().half_area();
                    ax.total_cmp(&ay)
                })
                .map(|(i, _)| i);
            let Some(i) = open else { break };
            let first = b[kids[i] as usize].first_index;
            kids.swap_remove(i);
            kids.push(first);
            kids.push(first + 1);
        }
        leaves.clear();
        for (slot, &k) in kids.iter().enumerate() {
            let bn = &b[k as usize];
            let bx = bn.aabb();
            let n = &mut nodes[me];
            for a in 0..3 {
                n.bounds[2 * a][slot] = bx.min[a];
                n.bounds[2 * a + 1][slot] = bx.max[a];
            }
            if bn.prim_count == 0 {
                work.push((k, Some((me, slot))));
            } else {
                leaves.push((slot, bn.first_index as usize, bn.prim_count as usize));
            }
        }
        // Largest leaf first (ties by slot, so the layout is deterministic).
        leaves.sort_by(|x, y| y.2.cmp(&x.2).then(x.0.cmp(&y.0)));
        fill.clear();
        let base = packets.len();
        for &(slot, f, count) in &leaves {
            let prims = &bvh2.primitive_indices[f..f + count];
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
