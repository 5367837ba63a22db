//! Accel against brute force: every ISA build of the 8-wide traversal, degenerate directions,
//! sparse nodes, barycentrics, the stack spill.

use super::node::Node8;
use super::stack::{Entry, Stack};
use super::tri::Tri;
use super::*;
use crate::math::simd::Isa;

fn quad(z: f32) -> Mesh {
    Mesh {
        name: "quad".into(),
        positions: vec![
            Vec3::new(-1.0, -1.0, z),
            Vec3::new(1.0, -1.0, z),
            Vec3::new(1.0, 1.0, z),
            Vec3::new(-1.0, 1.0, z),
        ],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        ..Default::default()
    }
}

#[test]
fn closest_hit_maps_back_to_mesh_and_triangle() {
    let meshes = vec![quad(0.0), quad(2.0)];
    let accel = Accel::build(&meshes);
    assert_eq!(accel.triangle_count(), 4);
    let h = accel
        .intersect(Vec3::new(0.5, -0.2, 5.0), -Vec3::Z, f32::INFINITY) // (−0, −0, −1)
        .unwrap();
    assert_eq!(h.mesh, 1);
    assert_eq!(h.prim, 0);
    assert!((h.t - 3.0).abs() < 1e-5);
    let h = accel
        .intersect(Vec3::new(-0.5, 0.2, -5.0), Vec3::Z, f32::INFINITY)
        .unwrap();
    assert_eq!((h.mesh, h.prim), (0, 1));
    assert!(
        accel
            .intersect(Vec3::new(3.0, 0.0, 5.0), -Vec3::Z, 100.0)
            .is_none()
    );
    assert!(
        accel
            .intersect(Vec3::new(0.5, 0.0, 5.0), -Vec3::Z, 2.5)
            .is_none()
    );
    assert!(accel.occluded(Vec3::new(0.5, 0.0, 5.0), -Vec3::Z, 3.5));
    assert!(!accel.occluded(Vec3::new(0.5, 0.0, 5.0), -Vec3::Z, 2.9));
    let (lo, hi) = accel.bounds();
    assert_eq!(lo, Vec3::new(-1.0, -1.0, 0.0));
    assert_eq!(hi, Vec3::new(1.0, 1.0, 2.0));
}

/// Brute force over every triangle with the same intersection routine.
fn brute(meshes: &[Mesh], o: Vec3, d: Vec3, tmax: f32) -> Option<(f32, u32, u32, Vec2)> {
    let mut best: Option<(f32, u32, u32, Vec2)> = None;
    for (mi, m) in meshes.iter().enumerate() {
        for (ti, idx) in m.indices.iter().enumerate() {
            let p = idx.map(|i| m.positions[i as usize]);
            let lim = best.map_or(tmax, |b| b.0);
            if let Some((t, u, v)) = Tri::new(p[0], p[1], p[2]).intersect(o.into(), d.into(), lim) {
                best = Some((t, mi as u32, ti as u32, Vec2::new(u, v)));
            }
        }
    }
    best
}

/// Checks closest and any hits of `rays` (o, d, tmax) through the traversal built for `isa`
/// against brute force; returns the hits, for comparing builds bit for bit.
fn check_rays(
    accel: &Accel,
    meshes: &[Mesh],
    isa: Isa,
    rays: &[(Vec3, Vec3, f32)],
) -> Vec<Option<Hit>> {
    let mut out = Vec::with_capacity(rays.len());
    for (k, &(o, d, tmax)) in rays.iter().enumerate() {
        let want = brute(meshes, o, d, tmax);
        let got = accel.intersect_isa(isa, o, d, tmax);
        assert_eq!(
            accel.occluded_isa(isa, o, d, tmax),
            want.is_some(),
            "{isa:?} ray {k}: {o:?} {d:?}"
        );
        match (want, got) {
            (None, None) => {}
            (Some((t, m, p, b)), Some(h)) => {
                assert!(
                    (h.t - t).abs() <= 1e-5 * t.max(1.0),
                    "{isa:?} ray {k}: {h:?} vs {t}"
                );
                if (h.mesh, h.prim) != (m, p) {
                    // Only a tie (shared edge/vertex at the same t) may pick another triangle.
                    assert!((h.t - t).abs() <= 1e-6 * t.max(1.0), "{isa:?} ray {k}");
                } else {
                    assert!((h.b - b).length() < 1e-5, "{isa:?} ray {k}");
                }
            }
            (w, g) => panic!("{isa:?} ray {k} {o:?} {d:?}: brute {w:?} vs bvh {g:?}"),
        }
        out.push(got);
    }
    out
}

/// Runs `check_rays` for every instruction set and requires the same bits from all of them.
fn check_all_isas(accel: &Accel, meshes: &[Mesh], rays: &[(Vec3, Vec3, f32)]) -> usize {
    let portable = check_rays(accel, meshes, Isa::PORTABLE, rays);
    for isa in Isa::available() {
        assert_eq!(check_rays(accel, meshes, isa, rays), portable, "{isa:?}");
    }
    portable.iter().filter(|h| h.is_some()).count()
}

#[test]
fn wide_bvh_matches_brute_force() {
    use crate::geometry::generate::sphere_displaced;
    use crate::math::warp::square_to_uniform_sphere;
    // A bumpy sphere (~2k triangles, deep enough for several wide levels) plus an
    // axis-aligned box of quads, so zero direction components and ±0.0 meet slab planes.
    let mut meshes = vec![sphere_displaced(
        Vec3::ZERO,
        1.0,
        24,
        48,
        false,
        true,
        |d| 0.1 * (7.0 * d.x).sin() * (5.0 * d.y).cos(),
    )];
    for (z, s) in [(1.5f32, 1.0f32), (-1.5, 2.0)] {
        let mut q = quad(z);
        q.positions
            .iter_mut()
            .for_each(|p| *p *= Vec3::new(s, s, 1.0));
        meshes.push(q);
    }
    let accel = Accel::build(&meshes);
    assert!(accel.nodes.len() > 20);
    let mut rng = crate::math::Pcg32::new(7, 9);
    let mut rays = Vec::new();
    for k in 0..4000 {
        let o = square_to_uniform_sphere(rng.next_2d()) * (0.5 + 3.0 * rng.next_f32());
        let mut d = (square_to_uniform_sphere(rng.next_2d()) * 0.8 - o).normalize();
        if k % 4 == 0 {
            // Axis-aligned directions with signed zeros.
            let a = (k / 4) % 3;
            let s = if (k / 12) % 2 == 0 { 1.0 } else { -1.0 };
            d = Vec3::ZERO;
            d[a] = s;
            if k % 8 == 0 {
                d = -d; // the zero components become −0.0
            }
        }
        let tmax = if k % 3 == 0 { 2.0 } else { f32::INFINITY };
        rays.push((o, d, tmax));
    }
    let hits = check_all_isas(&accel, &meshes, &rays);
    assert!(
        hits > 1500,
        "only {hits} hits: the test rays miss too often"
    );
}

#[test]
fn degenerate_directions_on_slab_planes() {
    // A 3 × 3 × 3 lattice of unit quads facing ±z (and their transposes facing x and y), so
    // node boxes share planes at integer coordinates. Origins on those planes with zero
    // direction components give (b − o)·(1/d) = 0·∞ = NaN slab distances, which the test
    // must ignore, not turn into misses or hits.
    let mut meshes = Vec::new();
    for i in -1..=1 {
        for j in -1..=1 {
            for k in [-2.0f32, 0.0, 2.0] {
                let (x, y) = (i as f32 * 2.0, j as f32 * 2.0);
                let q = |f: &dyn Fn(f32, f32) -> Vec3| Mesh {
                    positions: vec![
                        f(x - 0.5, y - 0.5),
                        f(x + 0.5, y - 0.5),
                        f(x + 0.5, y + 0.5),
                        f(x - 0.5, y + 0.5),
                    ],
                    indices: vec![[0, 1, 2], [0, 2, 3]],
                    ..Default::default()
                };
                meshes.push(q(&|a, b| Vec3::new(a, b, k)));
                meshes.push(q(&|a, b| Vec3::new(k + 0.25, a, b)));
                meshes.push(q(&|a, b| Vec3::new(b, k - 0.25, a)));
            }
        }
    }
    let accel = Accel::build(&meshes);
    let planes = [
        -3.0f32, -2.5, -2.0, -1.5, -0.5, 0.0, 0.5, 1.5, 2.0, 2.25, 2.5, 3.0,
    ];
    let mut rays = Vec::new();
    let mut rng = crate::math::Pcg32::new(5, 11);
    for a in 0..3 {
        for s in [1.0f32, -1.0] {
            for zero in [0.0f32, -0.0] {
                for _ in 0..120 {
                    // Axis direction: the other two components are ±0.0.
                    let mut d = Vec3::splat(zero);
                    d[a] = s;
                    let mut o = Vec3::ZERO;
                    for b in 0..3 {
                        o[b] = if rng.next_f32() < 0.7 {
                            planes[(rng.next_f32() * planes.len() as f32) as usize % planes.len()]
                        } else {
                            rng.next_f32() * 6.0 - 3.0
                        };
                    }
                    o[a] = -s * 4.0;
                    rays.push((o, d, f32::INFINITY));
                    rays.push((o, d, 1.0 + 6.0 * rng.next_f32()));
                    // Diagonal in a plane: one zero component.
                    let mut d2 = Vec3::splat(s);
                    d2[a] = zero;
                    let o2 = o + d2 * -4.0;
                    rays.push((o2, d2.normalize(), f32::INFINITY));
                }
            }
        }
    }
    // Rays starting exactly on a box face, going along it.
    rays.push((Vec3::new(-0.5, -4.0, 0.0), Vec3::Y, f32::INFINITY));
    rays.push((Vec3::new(0.5, 0.5, -4.0), Vec3::Z, f32::INFINITY));
    rays.push((Vec3::new(2.5, 2.5, 4.0), -Vec3::Z, f32::INFINITY));
    let hits = check_all_isas(&accel, &meshes, &rays);
    assert!(
        hits > rays.len() / 5,
        "only {hits} of {} rays hit",
        rays.len()
    );
}

/// Occupied child slots of a node (empty slots keep u32::MAX).
fn occupied(n: &Node8) -> usize {
    n.child.iter().filter(|&&c| c != u32::MAX).count()
}

#[test]
fn sparse_nodes_match_brute_force() {
    use crate::math::warp::square_to_uniform_sphere;
    // Scenes too small to fill eight slots: one triangle, two quads, a few scattered
    // triangles (a root with fewer than eight children, leaves with fewer than eight lanes).
    let mut rng = crate::math::Pcg32::new(1, 3);
    let mut scattered = Vec::new();
    for _ in 0..12 {
        let c = square_to_uniform_sphere(rng.next_2d()) * 2.0;
        let e = square_to_uniform_sphere(rng.next_2d()) * 0.3;
        let f = square_to_uniform_sphere(rng.next_2d()) * 0.3;
        scattered.push(Mesh {
            positions: vec![c, c + e, c + f],
            indices: vec![[0, 1, 2]],
            ..Default::default()
        });
    }
    let one = vec![Mesh {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        indices: vec![[0, 1, 2]],
        ..Default::default()
    }];
    for meshes in [one, vec![quad(0.0), quad(3.0)], scattered] {
        let accel = Accel::build(&meshes);
        assert!(accel.nodes.iter().all(|n| occupied(n) >= 1));
        assert!(occupied(&accel.nodes[0]) < super::node::WIDTH);
        let mut rays = Vec::new();
        for k in 0..600 {
            let o = square_to_uniform_sphere(rng.next_2d()) * 4.0;
            let t = square_to_uniform_sphere(rng.next_2d()) * 0.5 * rng.next_f32();
            let tmax = if k % 2 == 0 { f32::INFINITY } else { 4.0 };
            rays.push((o, (t - o).normalize(), tmax));
        }
        check_all_isas(&accel, &meshes, &rays);
    }
}

#[test]
fn hit_barycentrics_match_shading() {
    let meshes = vec![Mesh {
        positions: vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.1),
            Vec3::new(0.0, 2.0, -0.1),
        ],
        indices: vec![[0, 1, 2]],
        ..Default::default()
    }];
    let accel = Accel::build(&meshes);
    let o = Vec3::new(0.3, 0.5, 2.0);
    let d = Vec3::new(0.1, 0.2, -1.0).normalize();
    let h = accel.intersect(o, d, f32::INFINITY).unwrap();
    let p = &meshes[0].positions;
    let b = crate::geometry::shading::barycentrics(p[0], p[1], p[2], o, d);
    assert!((h.b - b).length() < 1e-6, "{:?} vs {b:?}", h.b);
    let x = p[0] * (1.0 - b.x - b.y) + p[1] * b.x + p[2] * b.y;
    assert!((o + d * h.t - x).length() < 1e-5);
}

#[test]
fn stack_is_lifo_across_the_heap_spill() {
    let mut st = Stack::new();
    for i in 0..100u32 {
        st.push(Entry {
            node: i,
            t: i as f32,
        });
    }
    for i in (0..100u32).rev() {
        assert_eq!(st.pop().map(|e| e.node), Some(i));
    }
    assert!(st.pop().is_none());
}

#[test]
fn empty_scene_never_hits() {
    let accel = Accel::build(&[]);
    assert!(
        accel
            .intersect(Vec3::ZERO, Vec3::Z, f32::INFINITY)
            .is_none()
    );
    assert!(!accel.occluded(Vec3::ZERO, Vec3::Z, f32::INFINITY));
}

#[test]
fn offset_origin_escapes_the_surface() {
    let meshes = vec![quad(0.0)];
    let accel = Accel::build(&meshes);
    let mut rng = crate::math::Pcg32::new(3, 4);
    for _ in 0..2000 {
        let p = Vec3::new(rng.next_f32() * 1.8 - 0.9, rng.next_f32() * 1.8 - 0.9, 0.0);
        let d = crate::math::warp::square_to_uniform_sphere(rng.next_2d());
        if d.z.abs() < 1e-3 {
            continue;
        }
        let o = offset_origin(p, Vec3::Z, d);
        assert!(accel.intersect(o, d, f32::INFINITY).is_none());
    }
}

#[test]
fn parts_match_brute_force() {
    use crate::geometry::generate::sphere_displaced;
    use crate::math::warp::square_to_uniform_sphere;
    // ~4.6k triangles in parts of 256: more than eight parts, so the top needs two levels.
    let meshes = vec![
        sphere_displaced(Vec3::ZERO, 1.0, 32, 64, false, true, |d| {
            0.1 * (7.0 * d.x).sin() * (5.0 * d.y).cos()
        }),
        quad(1.5),
        Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0],
            indices: vec![[0, 1, 2]],
            ..Default::default()
        },
    ];
    let accel = Accel::build_in_parts(&meshes, 256);
    let whole = Accel::build(&meshes);
    assert_eq!(accel.triangle_count(), whole.triangle_count());
    assert_eq!(accel.bounds(), whole.bounds());
    // The root joins part roots: inner children only.
    assert!(accel.nodes[0].count.iter().all(|&c| c == 0));
    assert!(
        accel.nodes[0]
            .child
            .iter()
            .filter(|&&c| c != u32::MAX)
            .count()
            >= 2
    );
    let mut rng = crate::math::Pcg32::new(5, 11);
    let mut rays = Vec::new();
    for k in 0..3000 {
        let o = square_to_uniform_sphere(rng.next_2d()) * (0.5 + 3.0 * rng.next_f32());
        let d = (square_to_uniform_sphere(rng.next_2d()) * 0.9 - o).normalize();
        let tmax = if k % 3 == 0 { 2.0 } else { f32::INFINITY };
        rays.push((o, d, tmax));
    }
    assert!(check_all_isas(&accel, &meshes, &rays) > 1000);
}

#[test]
fn leaves_share_packets() {
    use crate::geometry::generate::sphere_displaced;
    let meshes = vec![sphere_displaced(
        Vec3::ZERO,
        1.0,
        64,
        128,
        false,
        true,
        |_| 0.0,
    )];
    let accel = Accel::build(&meshes);
    let n = accel.triangle_count();
    assert_eq!(n, meshes[0].indices.len());
    // Each wide node packs its leaves: far fuller packets than one leaf per packet.
    let lanes = accel.tris.len() * tri::LANES;
    assert!(
        n as f64 > 0.7 * lanes as f64,
        "{n} triangles in {lanes} lanes"
    );
}

#[test]
fn reinsertion_budget_falls_with_size() {
    assert_eq!(build::reinsertion_ratio(1000), 0.05);
    let (a, b) = (
        build::reinsertion_ratio(1 << 20),
        build::reinsertion_ratio(1 << 22),
    );
    assert!(a < 0.05 && b < a && b > 0.005, "{a} {b}");
}

/// An instance of a group against the same mesh placed in world space by hand: the same hits
/// (t to rounding), reported as the group's mesh and triangle with the instance; shadow rays
/// blocked alike; the group's triangles stored once for several instances.
#[test]
fn instances_hit_as_world_space_copies() {
    use crate::geometry::mesh::Placement;
    use crate::math::Mat4;
    let ball = crate::geometry::generate::sphere(Vec3::ZERO, 1.0, 12, 24, false, false);
    let placements = [
        Mat4::from_translation(Vec3::new(2.0, 0.0, 0.0)),
        Mat4::from_scale_rotation_translation(
            Vec3::new(0.5, 1.5, 1.0),
            glam::Quat::from_rotation_y(0.7),
            Vec3::new(-2.0, 0.5, 0.0),
        ),
    ];
    let mut member = ball.clone();
    member.group = Some(0);
    let mut scene = vec![member];
    for m in placements {
        scene.push(Mesh {
            instance: Some(Box::new(Placement::new(0, m).unwrap())),
            ..Default::default()
        });
    }
    let copies: Vec<Mesh> = placements
        .iter()
        .map(|m| {
            let mut c = ball.clone();
            for p in &mut c.positions {
                *p = m.transform_point3(*p);
            }
            c
        })
        .collect();
    let two = Accel::build(&scene);
    let one = Accel::build(&copies);
    assert_eq!(two.triangle_count(), ball.indices.len());
    let (lo, hi) = one.bounds();
    let (lo2, hi2) = two.bounds();
    // An instance's box is its group's box moved: it holds the tight box of the copy.
    assert!(lo2.cmple(lo + 1e-5).all() && hi2.cmpge(hi - 1e-5).all());
    // Rays through a triangle edge or a silhouette may round to the other side.
    let (mut hits, mut edge) = (0, 0);
    for i in 0..400 {
        let o = Vec3::new(-4.0 + 0.02 * i as f32, 0.3 - 0.001 * i as f32, 5.0);
        let d = Vec3::new(0.05, 0.02, -1.0).normalize();
        let a = one.intersect(o, d, f32::INFINITY);
        let b = two.intersect(o, d, f32::INFINITY);
        match (a, b) {
            (None, None) => {}
            (Some(a), Some(b)) => {
                hits += 1;
                assert!((a.t - b.t).abs() < 1e-4 * a.t, "{a:?} {b:?}");
                assert_eq!((b.mesh, b.inst), (0, 1 + a.mesh));
                assert_eq!(a.inst, NO_INSTANCE);
                edge += usize::from(a.prim != b.prim);
            }
            _ => edge += 1,
        }
        edge += usize::from(one.occluded(o, d, 10.0) != two.occluded(o, d, 10.0));
    }
    assert!(hits > 100 && edge <= 2, "{hits} hits, {edge} disagreements");
}

/// Traces `rays` in packets of sixteen (lanes where `active` is set) through `intersect16`,
/// which must take the packets whose active rays share their direction signs (and leave the
/// others), and requires each lane to get exactly what the one-ray traversal gives it, in
/// every build; returns how many lanes hit.
fn check_packets(accel: &Accel, rays: &[[(Vec3, Vec3, f32); 16]], active: u32) -> usize {
    let mut hits = 0;
    for isa in std::iter::once(Isa::PORTABLE).chain(Isa::available()) {
        for (k, packet) in rays.iter().enumerate() {
            let axis = |f: &dyn Fn(usize) -> Vec3| -> [[f32; 16]; 3] {
                std::array::from_fn(|a| std::array::from_fn(|l| f(l)[a]))
            };
            let o = axis(&|l| packet[l].0);
            let d = axis(&|l| packet[l].1);
            let tmax = std::array::from_fn(|l| packet[l].2);
            // A lane outside `active` keeps what it held.
            let sentinel = Some(Hit {
                t: -1.0,
                mesh: 7,
                prim: 7,
                b: Vec2::ZERO,
                inst: NO_INSTANCE,
            });
            let mut out = [sentinel; 16];
            let signs = |l: usize| (1.0 / packet[l].1).to_array().map(f32::is_sign_negative);
            let first = signs(active.trailing_zeros() as usize);
            let coherent = (0..16).all(|l| active & (1 << l) == 0 || signs(l) == first);
            let packed = accel.intersect16_isa(isa, &o, &d, &tmax, active, &mut out);
            assert_eq!(
                packed,
                coherent && active.count_ones() >= 4,
                "{isa:?} packet {k}"
            );
            for (l, &(o, d, t)) in packet.iter().enumerate() {
                if !packed || active & (1 << l) == 0 {
                    assert_eq!(out[l], sentinel, "{isa:?} packet {k} lane {l}");
                    continue;
                }
                let want = accel.intersect_isa(isa, o, d, t);
                assert_eq!(out[l], want, "{isa:?} packet {k} lane {l}: {o:?} {d:?} {t}");
                hits += want.is_some() as usize;
            }
        }
    }
    hits
}

/// A bumpy sphere over a floor quad: deep enough for several wide levels.
fn packet_scene() -> Vec<Mesh> {
    use crate::geometry::generate::sphere_displaced;
    let mut floor = quad(0.0);
    for p in &mut floor.positions {
        *p = Vec3::new(p.x * 4.0, -1.2, p.y * 4.0);
    }
    vec![
        sphere_displaced(Vec3::ZERO, 1.0, 32, 64, false, true, |d| {
            0.1 * (7.0 * d.x).sin() * (5.0 * d.y).cos()
        }),
        floor,
    ]
}

/// Rows of sixteen camera rays (a pinhole at `eye` looking at the origin), one per image row
/// of `rows`, with per-lane limits from `tmax`.
fn camera_rows(
    eye: Vec3,
    rows: usize,
    tmax: impl Fn(usize) -> f32,
) -> Vec<[(Vec3, Vec3, f32); 16]> {
    let fwd = (-eye).normalize();
    let right = fwd.cross(Vec3::Y).normalize();
    let up = right.cross(fwd);
    (0..rows)
        .map(|r| {
            let y = 1.0 - 2.0 * (r as f32 + 0.5) / rows as f32;
            std::array::from_fn(|l| {
                let x = -1.0 + 2.0 * (l as f32 + 0.5) / 16.0;
                (
                    (eye),
                    (fwd + right * (0.6 * x) + up * (0.6 * y)).normalize(),
                    tmax(l),
                )
            })
        })
        .collect()
}

#[test]
fn camera_packets_match_one_ray_traversal() {
    let meshes = packet_scene();
    let accel = Accel::build(&meshes);
    assert!(accel.nodes.len() > 20);
    let mut total = 0;
    // Seen from a diagonal, a row's rays share their direction signs (the packet traversal);
    // from above, every row crosses x = 0 and mixes them (left to the one-ray traversal).
    for eye in [
        Vec3::new(2.5, 1.0, 2.8),
        Vec3::new(-2.5, 2.0, -2.0),
        Vec3::new(0.0, 4.0, 0.01),
    ] {
        total += check_packets(
            &accel,
            &camera_rows(eye, 40, |_| f32::INFINITY),
            u32::MAX >> 16,
        );
        // Limits that cut some hits off, and lanes left out.
        let rows = camera_rows(eye, 24, |l| [f32::INFINITY, 3.2, 2.0, 0.5][l % 4]);
        total += check_packets(&accel, &rows, 0b1011_0111_1110_1101);
        total += check_packets(&accel, &rows, 0b1111);
    }
    assert!(
        total > 800,
        "only {total} lane hits in packets: the rows miss too often"
    );
}

#[test]
fn incoherent_packets_match_one_ray_traversal() {
    use crate::math::warp::square_to_uniform_sphere;
    let meshes = packet_scene();
    let accel = Accel::build(&meshes);
    let mut rng = crate::math::Pcg32::new(3, 5);
    // Random origins, directions of one octant per packet (so the packet path runs) and of
    // any octant.
    let packets: Vec<[(Vec3, Vec3, f32); 16]> = (0..200)
        .map(|k| {
            std::array::from_fn(|_| {
                let o = square_to_uniform_sphere(rng.next_2d()) * 3.0;
                let mut d = square_to_uniform_sphere(rng.next_2d());
                if k % 2 == 0 {
                    d = d.abs() * Vec3::new(-1.0, 1.0, -1.0);
                }
                (o, d, if k % 3 == 0 { 2.5 } else { f32::INFINITY })
            })
        })
        .collect();
    assert!(check_packets(&accel, &packets, u32::MAX >> 16) > 500);
}

#[test]
fn equal_distances_pick_the_lowest_slot_in_both_traversals() {
    // Two copies of the same sphere: every hit is a tie between two triangles, which the
    // one-ray and the packet traversal must resolve alike (nearest t, then lowest slot),
    // whatever order they visit the copies in.
    let mut meshes = packet_scene();
    meshes.push(meshes[0].clone());
    let accel = Accel::build(&meshes);
    let rows = camera_rows(Vec3::new(2.2, 0.8, 2.4), 32, |_| f32::INFINITY);
    let hits = check_packets(&accel, &rows, u32::MAX >> 16);
    assert!(hits > 150, "only {hits} lane hits in packets");
    // Every sphere hit is a tie (the copies' triangles are the same bits).
    let ties = rows
        .iter()
        .flatten()
        .filter(|&&(o, d, t)| accel.intersect(o, d, t).is_some_and(|h| h.mesh != 1))
        .count();
    assert!(ties > 60, "only {ties} ties");
}
