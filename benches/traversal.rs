//! Ray traversal throughput of the obvhs CWBVH wrapper on a displaced sphere of ~130k
//! triangles: closest-hit and shadow rays, incoherent random rays. Throughput is reported in
//! elements/s = rays/s.

use btfpt::geometry::accel::Accel;
use btfpt::geometry::generate::sphere_displaced;
use btfpt::math::{Pcg32, Vec3, warp};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;

fn setup() -> (Accel, Vec<(Vec3, Vec3)>) {
    let mesh = sphere_displaced(Vec3::ZERO, 1.0, 256, 256, false, true, |d| {
        0.08 * (9.0 * d.x).sin() * (7.0 * d.y).cos() * (5.0 * d.z).sin()
    });
    assert!(mesh.indices.len() >= 50_000);
    let accel = Accel::build(std::slice::from_ref(&mesh));
    // Random rays from a sphere of radius 3 toward random points near the object.
    let mut rng = Pcg32::new(1, 2);
    let rays = (0..65_536)
        .map(|_| {
            let o = warp::square_to_uniform_sphere(rng.next_2d()) * 3.0;
            let t = warp::square_to_uniform_sphere(rng.next_2d()) * 0.9;
            (o, (t - o).normalize())
        })
        .collect();
    (accel, rays)
}

fn bench(c: &mut Criterion) {
    let (accel, rays) = setup();
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
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
