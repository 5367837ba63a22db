//! Ray traversal throughput on a displaced sphere of ~130k triangles, incoherent random rays:
//! closest-hit and shadow rays through btfpt's `Accel` (8-wide BVH over obvhs's BVH2 build),
//! and, in the same run for a side-by-side ratio, the same queries through obvhs 0.4's own
//! CWBVH traversal (what `Accel` used before). Measured in thread CPU time, so the numbers
//! hold on a shared machine; throughput is rays per CPU second.

#[path = "common/cpu_time.rs"]
mod cpu_time;

use btfpt::geometry::Mesh;
use btfpt::geometry::accel::Accel;
use btfpt::geometry::generate::sphere_displaced;
use btfpt::math::{Pcg32, Vec3, warp};
use cpu_time::ThreadCpuTime;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use obvhs::BvhBuildParams;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::ray::{Ray, RayHit};
use obvhs::rt_triangle::RtTriangle;
use obvhs::triangle::Triangle;
use std::hint::black_box;

/// The displaced sphere with `n` × `n` quads (2n² triangles).
fn mesh(n: u32) -> Mesh {
    sphere_displaced(Vec3::ZERO, 1.0, n, n, false, true, |d| {
        0.08 * (9.0 * d.x).sin() * (7.0 * d.y).cos() * (5.0 * d.z).sin()
    })
}

/// Random rays from a sphere of radius 3 toward random points near the object.
fn rays() -> Vec<(Vec3, Vec3)> {
    let mut rng = Pcg32::new(1, 2);
    (0..65_536)
        .map(|_| {
            let o = warp::square_to_uniform_sphere(rng.next_2d()) * 3.0;
            let t = warp::square_to_uniform_sphere(rng.next_2d()) * 0.9;
            (o, (t - o).normalize())
        })
        .collect()
}

/// obvhs's CWBVH with the wrapper `Accel` had before the hand-written traversal.
struct Cw {
    bvh: CwBvh,
    tris: Vec<RtTriangle>,
}

impl Cw {
    fn build(m: &Mesh) -> Cw {
        let tris: Vec<Triangle> = m
            .indices
            .iter()
            .map(|i| Triangle {
                v0: m.positions[i[0] as usize].into(),
                v1: m.positions[i[1] as usize].into(),
                v2: m.positions[i[2] as usize].into(),
            })
            .collect();
        let bvh = build_cwbvh_from_tris(
            &tris,
            BvhBuildParams::medium_build(),
            &mut std::time::Duration::default(),
        );
        let tris = bvh
            .primitive_indices
            .iter()
            .map(|&i| RtTriangle::from(&tris[i as usize]))
            .collect();
        Cw { bvh, tris }
    }

    fn intersect(&self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        let ray = Ray::new(
            o.into(),
            glam::Vec3A::from(d) + glam::Vec3A::ZERO,
            0.0,
            tmax,
        );
        let mut hit = RayHit::none();
        self.bvh
            .ray_traverse(ray, &mut hit, |r, id| self.tris[id].intersect(r))
    }

    fn occluded(&self, o: Vec3, d: Vec3, tmax: f32) -> bool {
        let ray = Ray::new(
            o.into(),
            glam::Vec3A::from(d) + glam::Vec3A::ZERO,
            0.0,
            tmax,
        );
        !self
            .bvh
            .ray_traverse_miss(ray, |r, id| self.tris[id].intersect(r))
    }
}

fn bench(c: &mut Criterion<ThreadCpuTime>) {
    // 130k triangles (the acceptance size, ≥ 50k; its BVH is larger than L2) and 8k triangles
    // (fits in L2: shows the instruction cost without the memory latency).
    bench_mesh(c, &mesh(256));
    bench_mesh(c, &mesh(64));
}

fn bench_mesh(c: &mut Criterion<ThreadCpuTime>, mesh: &Mesh) {
    let accel = Accel::build(std::slice::from_ref(mesh));
    let cw = Cw::build(mesh);
    let rays = rays();
    // Both structures must agree on what they hit.
    let a: u32 = rays
        .iter()
        .map(|&(o, d)| accel.intersect(o, d, f32::INFINITY).is_some() as u32)
        .sum();
    let b: u32 = rays
        .iter()
        .map(|&(o, d)| cw.intersect(o, d, f32::INFINITY) as u32)
        .sum();
    assert!(a.abs_diff(b) <= 2, "hit counts differ: {a} vs {b}");
    let k = accel.triangle_count() / 1000;
    let mut g = c.benchmark_group("traversal");
    g.throughput(Throughput::Elements(rays.len() as u64));
    g.bench_function(format!("closest_hit_{k}k_tris"), |b| {
        b.iter(|| {
            let mut hits = 0u32;
            for &(o, d) in &rays {
                hits += accel.intersect(o, d, f32::INFINITY).is_some() as u32;
            }
            black_box(hits)
        })
    });
    g.bench_function(format!("shadow_{k}k_tris"), |b| {
        b.iter(|| {
            let mut blocked = 0u32;
            for &(o, d) in &rays {
                blocked += accel.occluded(o, d, 2.5) as u32;
            }
            black_box(blocked)
        })
    });
    g.bench_function(format!("obvhs_cwbvh_closest_hit_{k}k_tris"), |b| {
        b.iter(|| {
            let mut hits = 0u32;
            for &(o, d) in &rays {
                hits += cw.intersect(o, d, f32::INFINITY) as u32;
            }
            black_box(hits)
        })
    });
    g.bench_function(format!("obvhs_cwbvh_shadow_{k}k_tris"), |b| {
        b.iter(|| {
            let mut blocked = 0u32;
            for &(o, d) in &rays {
                blocked += cw.occluded(o, d, 2.5) as u32;
            }
            black_box(blocked)
        })
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().with_measurement(ThreadCpuTime);
    targets = bench
}
criterion_main!(benches);
