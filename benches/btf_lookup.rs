//! Cost of the raw BTF material on the renderer's hot path: direction lookup alone, and a full
//! `eval` (2 lookups + 9 texel fetches) at random uv and directions, on a synthetic 64² × 81 × 81
//! material (161 MB of f16, built here). Run: `cargo bench --bench btf_lookup`.

use btfpt::bsdf::{BtfBsdf, BtfMaterial, Bxdf};
use btfpt::btf::{DirectionSet, RawBtf, StoredEncoding};
use btfpt::geometry::SurfaceInteraction;
use btfpt::math::{Pcg32, Vec2, Vec3, warp};
use criterion::{Criterion, criterion_group, criterion_main};
use half::f16;
use std::hint::black_box;
use std::sync::Arc;

const N: usize = 64;

fn material() -> BtfBsdf {
    let set = DirectionSet::ubo2003();
    let mut data = Vec::with_capacity(81 * 81 * N * N * 3);
    for v in &set.dirs {
        for l in &set.dirs {
            let r = Vec3::new(-v.x, -v.y, v.z);
            let b = l.z * (0.2 + 2.0 * r.dot(*l).max(0.0).powi(10));
            for y in 0..N {
                for x in 0..N {
                    let t = 1.0 + 0.3 * ((x * 7 + y * 13) % 17) as f32 / 17.0;
                    data.extend([b * t, 0.8 * b * t, 0.5 * b * t].map(f16::from_f32));
                }
            }
        }
    }
    let raw = RawBtf::from_f16(set.clone(), set, N, N, StoredEncoding::Linear, data)
        .expect("synthetic BTF");
    let m = BtfMaterial::new(Arc::new(raw)).expect("material");
    BtfBsdf::new(Arc::new(m), 1.0).expect("bsdf")
}

/// Random queries: (interaction, light direction), both in the upper hemisphere.
fn queries(n: usize) -> Vec<(SurfaceInteraction, Vec3)> {
    let mut rng = Pcg32::new(42, 1);
    (0..n)
        .map(|_| {
            let wi = warp::square_to_uniform_hemisphere(rng.next_2d());
            let wo = warp::square_to_uniform_hemisphere(rng.next_2d());
            let uv = Vec2::new(rng.next_f32(), rng.next_f32());
            (SurfaceInteraction::for_tests(wi, uv), wo)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let bsdf = material();
    let q = queries(4096);
    let interp = DirectionSet::ubo2003()
        .interpolator()
        .expect("interpolator");
    let mut g = c.benchmark_group("btf");
    g.throughput(criterion::Throughput::Elements(q.len() as u64));
    g.bench_function("direction_lookup_ubo2003", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for (_, wo) in &q {
                let (i, w) = interp.lookup(black_box(*wo));
                acc += w[0] + i[0] as f32;
            }
            acc
        })
    });
    g.bench_function("raw_eval_64x64x81x81", |b| {
        b.iter(|| {
            let mut acc = Vec3::ZERO;
            for (si, wo) in &q {
                acc += bsdf.eval(black_box(si), black_box(*wo));
            }
            acc
        })
    });
    g.bench_function("raw_sample_64x64x81x81", |b| {
        let mut rng = Pcg32::new(7, 3);
        b.iter(|| {
            let mut acc = Vec3::ZERO;
            for (si, _) in &q {
                if let Some((_, w)) = bsdf.sample(black_box(si), rng.next_f32(), rng.next_2d()) {
                    acc += w;
                }
            }
            acc
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
