//! The 16-lane transcendental functions of `math::simd::approx` against libm, per batch of 16 values
//! (thread CPU time): `sin_cos/simd_<isa>` vs `sin_cos/libm`, same for exp2 and log2. The
//! portable (SSE2) build of the same lane loop is measured too, to show what the ISA buys.

use btfpt::math::simd::approx::{exp2_isa, log2_isa, sin_cos_isa};
use btfpt::math::simd::f16::F16;
use btfpt::math::simd::{F32x16, Isa, WIDTH};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;

#[path = "common/cpu_time.rs"]
mod cpu_time;
use cpu_time::ThreadCpuTime;

/// 64 batches of 16 inputs in `lo..hi`.
fn inputs(lo: f32, hi: f32) -> Vec<F32x16> {
    (0..64)
        .map(|b| std::array::from_fn(|i| lo + (hi - lo) * ((b * WIDTH + i) as f32 / 1024.0)))
        .collect()
}

fn bench(c: &mut Criterion<ThreadCpuTime>) {
    let angles = inputs(0.0, 2.0 * std::f32::consts::PI);
    let exps = inputs(-20.0, 20.0);
    let logs = inputs(1e-3, 100.0);
    let mut g = c.benchmark_group("simd_math");
    g.throughput(Throughput::Elements(1024));
    g.bench_function("sin_cos/libm", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for x in &angles {
                for &v in black_box(x) {
                    let (s, c) = v.sin_cos();
                    acc += s + c;
                }
            }
            acc
        })
    });
    g.bench_function("exp2/libm", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for x in &exps {
                for &v in black_box(x) {
                    acc += v.exp2();
                }
            }
            acc
        })
    });
    g.bench_function("log2/libm", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for x in &logs {
                for &v in black_box(x) {
                    acc += v.log2();
                }
            }
            acc
        })
    });
    for isa in Isa::available() {
        let name = format!("{isa:?}");
        g.bench_with_input(BenchmarkId::new("sin_cos/simd", &name), &isa, |b, &isa| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for x in &angles {
                    let (F16(s), F16(c)) = sin_cos_isa(isa, F16(*black_box(x)));
                    acc += s[3] + c[11];
                }
                acc
            })
        });
        g.bench_with_input(BenchmarkId::new("exp2/simd", &name), &isa, |b, &isa| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for x in &exps {
                    acc += exp2_isa(isa, F16(*black_box(x))).0[5];
                }
                acc
            })
        });
        g.bench_with_input(BenchmarkId::new("log2/simd", &name), &isa, |b, &isa| {
            b.iter(|| {
                let mut acc = 0.0f32;
                for x in &logs {
                    acc += log2_isa(isa, F16(*black_box(x))).0[7];
                }
                acc
            })
        });
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().with_measurement(ThreadCpuTime).sample_size(30);
    targets = bench
}
criterion_main!(benches);
