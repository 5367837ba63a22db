//! Fitting throughput: one-lobe Lafortune fits per second over the 81 UBO2003 light directions
//! (curves from random lobes plus noise) and one view-channel K-means (4096 texels, 20 features,
//! K = 256).
//!
//! Two clocks: wall time (criterion's default; meaningful on an idle machine) and CPU time of the
//! process (`CLOCK_PROCESS_CPUTIME_ID`, groups `*_cpu`), which stays meaningful when the machine
//! is shared: fits per CPU-second × cores is the throughput on that many idle cores.

use btfpt::btf::DirectionSet;
use btfpt::fit::lafortune::{LobeFitter, eval_all};
use btfpt::math::Pcg32;
use btfpt::math::kmeans::kmeans;
use criterion::measurement::{Measurement, ValueFormatter, WallTime};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use rayon::prelude::*;
use std::hint::black_box;
use std::time::Duration;

/// Criterion measurement: CPU time consumed by the whole process (all threads).
struct CpuTime {
    /// Only used for its nanosecond formatter.
    wall: WallTime,
}

fn process_cpu() -> Duration {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec through a valid pointer.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime(CLOCK_PROCESS_CPUTIME_ID) failed");
    Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32)
}

impl Measurement for CpuTime {
    type Intermediate = Duration;
    type Value = Duration;
    fn start(&self) -> Duration {
        process_cpu()
    }
    fn end(&self, i: Duration) -> Duration {
        process_cpu().saturating_sub(i)
    }
    fn add(&self, a: &Duration, b: &Duration) -> Duration {
        *a + *b
    }
    fn zero(&self) -> Duration {
        Duration::ZERO
    }
    fn to_f64(&self, v: &Duration) -> f64 {
        v.as_nanos() as f64
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        self.wall.formatter()
    }
}

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

fn features(n: usize, dim: usize) -> Vec<f32> {
    // 64 blob centres plus spread: a clustering with structure, like texels of a few materials.
    let mut rng = Pcg32::new(7, 3);
    let centres: Vec<f32> = (0..64 * dim).map(|_| rng.next_f32()).collect();
    (0..n)
        .flat_map(|i| {
            let c = (i * 7919) % 64;
            (0..dim)
                .map(|j| centres[c * dim + j] + 0.15 * (rng.next_f32() - 0.5))
                .collect::<Vec<_>>()
        })
        .collect()
}

fn lafortune<M: Measurement>(c: &mut Criterion<M>, group: &str) {
    let f = LobeFitter::new(&DirectionSet::ubo2003().dirs).unwrap();
    let n = 4096;
    let data = curves(&f, n);
    let mut g = c.benchmark_group(group);
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
    let feat = features(4096, 20);
    let mut g = c.benchmark_group(format!("{group}_kmeans"));
    g.sample_size(10);
    g.bench_function("4096x20_k256", |b| {
        b.iter(|| kmeans(black_box(&feat), 20, 256, 1, 40).iterations)
    });
    g.finish();
}

fn wall(c: &mut Criterion) {
    lafortune(c, "lafortune");
}

fn cpu(c: &mut Criterion<CpuTime>) {
    lafortune(c, "lafortune_cpu");
}

criterion_group!(benches, wall);
criterion_group! {
    name = cpu_benches;
    config = Criterion::default().with_measurement(CpuTime { wall: WallTime });
    targets = cpu
}
criterion_main!(benches, cpu_benches);
