//! Fitting throughput: one-lobe Lafortune fits per second over the 81 UBO2003 light directions
//! (curves from random lobes plus noise), single-threaded and over all cores with rayon.

use btfpt::btf::DirectionSet;
use btfpt::fit::lafortune::{LobeFitter, eval_all};
use btfpt::math::Pcg32;
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use rayon::prelude::*;
use std::hint::black_box;

fn curves(f: &LobeFitter, count: usize) -> Vec<f32> {
    let mut rng = Pcg32::new(1, 2);
    let mut out = vec![0.0f32; count * f.lights()];
    for c in out.chunks_mut(f.lights()) {
        let th = rng.next_f32() * 1.2;
        let ph = rng.next_f32() * std::f32::consts::TAU;
        let lobe = [
            0.1 + rng.next_f32(),
            th.sin() * ph.cos(),
            th.sin() * ph.sin(),
            th.cos(),
            0.5 + 20.0 * rng.next_f32(),
        ];
        eval_all(&lobe, f, c);
        for v in c.iter_mut() {
            *v = (*v + 0.02 * (rng.next_f32() - 0.5)).max(0.0);
        }
    }
    out
}

fn bench(c: &mut Criterion) {
    let f = LobeFitter::new(&DirectionSet::ubo2003().dirs).unwrap();
    let n = 4096;
    let data = curves(&f, n);
    let mut g = c.benchmark_group("lafortune");
    g.throughput(Throughput::Elements(n as u64));
    g.sample_size(10);
    g.bench_function("fit_4096_serial", |b| {
        b.iter(|| {
            data.chunks(81)
                .map(|y| f.fit(black_box(y)).sse)
                .sum::<f64>()
        })
    });
    g.bench_function("fit_4096_rayon", |b| {
        b.iter(|| {
            data.par_chunks(81)
                .map(|y| f.fit(black_box(y)).sse)
                .sum::<f64>()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
