//! Cost of one full BTF evaluation (3 views × RGB, with light interpolation) at a random texel
//! and random view/light directions, for PLM-C, PLM, LM and the raw BTF on a 256² material with
//! the UBO2003 81 × 81 directions; and the cost of rendering a small scene whose surfaces are a
//! PLM-C BTF against the same scene with diffuse surfaces (same spp, one thread).
//!
//! The models are synthesised directly (random lobes, random cluster indices, random increasing
//! polynomials) rather than fitted: the evaluation cost does not depend on the values. The raw BTF
//! is 81·81·256²·3 f16 = 2.6 GB in memory (what the raw path really costs). Set
//! `BTF_EVAL_SKIP_RAW=1` to skip it on machines short of memory.
//!
//! `plmc_64` is the PLM-C model on 64² texels (its index planes fit in the cache). `plmc` runs
//! the AVX-512 kernel where the CPU has it, `plmc_sse2` the x86_64 baseline. The render group's
//! integrator shares the view lookup and texel addressing of a hit between its BSDF calls
//! (`Bsdf::at`). `examples/btf_eval_profile.rs` runs the same workloads for callgrind and
//! for best-of-N CPU-time A/B runs (kernel alone, lookups alone, with or without AVX-512).
//!
//! `cargo bench --bench btf_eval`; ns per evaluation = reported time / 4096 queries. The
//! evaluation group measures thread CPU time (the machine is shared); the render group, whose
//! work runs on a pool thread, process CPU time.

use btfpt::bsdf::plmc::{BATCH, PlmcHit, PlmcMaterial};
use btfpt::bsdf::{Bsdf, BtfBsdf, BtfMaterial, Bxdf, Diffuse, PlmcBsdf, Texture};
use btfpt::btf::locate16::LOCATE_LANES;
use btfpt::btf::{DirectionSet, RawBtf, StoredEncoding};
use btfpt::math::{Pcg32, Spectrum, Vec2, Vec3};
use btfpt::model::ModelKind;
use btfpt::render::IntegratorKind;
use btfpt::render::film::RenderState;
use btfpt::render::packet::PacketOptions;
#[path = "common/btf_scene.rs"]
mod btf_scene;
#[path = "common/cpu_time.rs"]
mod cpu_time;

use btf_scene::{QUERIES, SIZE, box_scene, hits16, model, model_sized, queries, scene};

use cpu_time::{ProcessCpuTime, ThreadCpuTime};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

fn bench_eval(c: &mut Criterion<ThreadCpuTime>) {
    let q = queries();
    let mut g = c.benchmark_group("btf_eval_256");
    g.throughput(Throughput::Elements(QUERIES as u64));
    g.sample_size(30);
    let interp = DirectionSet::ubo2003().interpolator().unwrap();
    g.bench_function("direction_lookup", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for (_, wo) in &q {
                let (i, w) = interp.lookup(black_box(*wo));
                acc += w[0] + i[0] as f32;
            }
            acc
        })
    });
    // The same 4096 directions located 16 at a time (the batched kernels' light search).
    g.bench_function("direction_locate16", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for chunk in q.chunks(LOCATE_LANES) {
                let (mut qx, mut qy) = ([0f32; LOCATE_LANES], [0f32; LOCATE_LANES]);
                for (j, (_, wo)) in chunk.iter().enumerate() {
                    (qx[j], qy[j]) = (wo.x, wo.y);
                }
                let l = interp.locate16(black_box(&qx), black_box(&qy));
                acc += l.w[0][0] + l.tri[15] as f32;
            }
            acc
        })
    });
    g.bench_function("direction_locate", |b| {
        b.iter(|| {
            let mut acc = 0.0f32;
            for (_, wo) in &q {
                let (t, w) = interp.locate(black_box([wo.x, wo.y]));
                acc += w[0] + t as f32;
            }
            acc
        })
    });
    for kind in [ModelKind::PlmC, ModelKind::Plm, ModelKind::Lm] {
        let m = model(kind);
        let bsdf = PlmcBsdf::new(Arc::new(PlmcMaterial::new(&m).unwrap()), 1.0, false).unwrap();
        drop(m);
        g.bench_function(kind.name(), |b| {
            b.iter(|| {
                let mut acc = Spectrum::ZERO;
                for (si, wo) in &q {
                    acc += bsdf.eval(black_box(si), black_box(*wo));
                }
                acc
            })
        });
        if kind == ModelKind::PlmC {
            // A 64² model (1.3 MB of index planes: cache-resident), to separate compute from the
            // 256² model's memory misses.
            let small = PlmcBsdf::new(
                Arc::new(PlmcMaterial::new(&model_sized(kind, 64)).unwrap()),
                1.0,
                false,
            )
            .unwrap();
            g.bench_function("plmc_64", |b| {
                b.iter(|| {
                    let mut acc = Spectrum::ZERO;
                    for (si, wo) in &q {
                        acc += small.eval(black_box(si), black_box(*wo));
                    }
                    acc
                })
            });
            // The same model on the baseline SSE2 kernel (equal to `plmc` on CPUs without AVX2+FMA).
            let sse2 = PlmcBsdf::new(
                Arc::new(PlmcMaterial::new(&model(kind)).unwrap().without_avx2()),
                1.0,
                false,
            )
            .unwrap();
            g.bench_function("plmc_sse2", |b| {
                b.iter(|| {
                    let mut acc = Spectrum::ZERO;
                    for (si, wo) in &q {
                        acc += sse2.eval(black_box(si), black_box(*wo));
                    }
                    acc
                })
            });
            g.bench_function("plmc_eval_pdf", |b| {
                b.iter(|| {
                    let mut acc = Spectrum::ZERO;
                    for (si, wo) in &q {
                        let (f, pdf) = bsdf.eval_pdf(black_box(si), black_box(*wo));
                        acc += f * pdf;
                    }
                    acc
                })
            });
            // The packet integrator's form: 16 queries per call (view lookups and texel
            // addressing by `prepare16`, as in a packet batch), one pass of the 16-lane kernel.
            let batch = |want_pdf: bool| {
                let bsdf = &bsdf;
                let q = &q;
                move || {
                    let mut acc = Spectrum::ZERO;
                    let mut out = [(Spectrum::ZERO, 0.0); BATCH];
                    let want = [want_pdf; BATCH];
                    for chunk in q.chunks(BATCH) {
                        let n = chunk.len();
                        let hits: [PlmcHit; BATCH] = hits16(bsdf, black_box(chunk));
                        let wo: [Vec3; BATCH] = std::array::from_fn(|j| chunk[j.min(n - 1)].1);
                        bsdf.eval_pdf_batch(
                            &hits[..n],
                            black_box(&wo[..n]),
                            &want[..n],
                            &mut out[..n],
                        );
                        for (f, pdf) in &out[..n] {
                            acc += *f * pdf.max(1.0);
                        }
                    }
                    acc
                }
            };
            g.bench_function("plmc_batch16", |b| b.iter(batch(false)));
            g.bench_function("plmc_eval_pdf_batch16", |b| b.iter(batch(true)));
            g.bench_function("plmc_sample", |b| {
                let mut rng = Pcg32::new(7, 3);
                b.iter(|| {
                    let mut acc = Spectrum::ZERO;
                    for (si, _) in &q {
                        if let Some((_, w)) =
                            bsdf.sample(black_box(si), rng.next_f32(), rng.next_2d())
                        {
                            acc += w;
                        }
                    }
                    acc
                })
            });
            // BSDF sampling at a batch's per-hit states: one query at a time (`sample_hit`, the
            // scalar integrator's call) against 16 per call (`sample_batch`, the packet
            // integrator's: the model evaluations in one pass of the 16-lane kernel).
            let sampling = |batched: bool| {
                let bsdf = &bsdf;
                let q = &q;
                move || {
                    let mut rng = Pcg32::new(7, 3);
                    let mut acc = Spectrum::ZERO;
                    let mut out = [None; BATCH];
                    for chunk in q.chunks(BATCH) {
                        let n = chunk.len();
                        let hits: [PlmcHit; BATCH] = hits16(bsdf, black_box(chunk));
                        let u1: [f32; BATCH] = std::array::from_fn(|_| rng.next_f32());
                        let u2: [Vec2; BATCH] = std::array::from_fn(|_| rng.next_2d());
                        if batched {
                            bsdf.sample_batch(&hits[..n], &u1[..n], &u2[..n], &mut out[..n]);
                        } else {
                            for j in 0..n {
                                out[j] = bsdf.sample_hit(&hits[j], u1[j], u2[j]);
                            }
                        }
                        for (_, w) in out[..n].iter().flatten() {
                            acc += *w;
                        }
                    }
                    acc
                }
            };
            g.bench_function("plmc_sample_hit16", |b| b.iter(sampling(false)));
            g.bench_function("plmc_sample_batch16", |b| b.iter(sampling(true)));
            let bilinear = PlmcBsdf::new(bsdf.material().clone(), 1.0, true).unwrap();
            g.bench_function("plmc_bilinear", |b| {
                b.iter(|| {
                    let mut acc = Spectrum::ZERO;
                    for (si, wo) in &q {
                        acc += bilinear.eval(black_box(si), black_box(*wo));
                    }
                    acc
                })
            });
        }
    }
    if std::env::var_os("BTF_EVAL_SKIP_RAW").is_none() {
        let set = DirectionSet::ubo2003();
        let n = set.len() * set.len() * SIZE * SIZE * 3;
        let data: Vec<half::f16> = (0..n)
            .map(|i| half::f16::from_f32(((i * 2654435761) % 1000) as f32 * 1e-3))
            .collect();
        let raw =
            RawBtf::from_f16(set.clone(), set, SIZE, SIZE, StoredEncoding::Linear, data).unwrap();
        let bsdf = BtfBsdf::new(Arc::new(BtfMaterial::new(Arc::new(raw)).unwrap()), 1.0).unwrap();
        g.bench_function("raw", |b| {
            b.iter(|| {
                let mut acc = Spectrum::ZERO;
                for (si, wo) in &q {
                    acc += bsdf.eval(black_box(si), black_box(*wo));
                }
                acc
            })
        });
    }
    g.finish();
}

fn bench_render(c: &mut Criterion<ProcessCpuTime>) {
    let plmc = Arc::new(PlmcMaterial::new(&model(ModelKind::PlmC)).unwrap());
    let settings = box_scene::settings();
    let pool = box_scene::single_thread_pool();
    let stop = AtomicBool::new(false);
    let mut g = c.benchmark_group("render_box_64x64_4spp");
    g.sample_size(20);
    g.throughput(Throughput::Elements(64 * 64 * 4));
    for (name, bsdf) in [
        (
            "diffuse",
            Bsdf::Diffuse(Diffuse {
                reflectance: Texture::Constant(Spectrum::splat(0.5)),
            }),
        ),
        (
            "plmc",
            Bsdf::Plmc(PlmcBsdf::new(plmc.clone(), 4.0, false).unwrap()),
        ),
        (
            "plmc_no_prefetch",
            Bsdf::Plmc(
                PlmcBsdf::new(plmc.clone(), 4.0, false)
                    .unwrap()
                    .without_prefetch(),
            ),
        ),
    ] {
        let mut rs = scene(bsdf);
        for (suffix, kind) in [
            ("", IntegratorKind::Scalar),
            ("_packet", IntegratorKind::Packet(PacketOptions::default())),
        ] {
            rs.kind = kind;
            g.bench_function(format!("{name}{suffix}"), |b| {
                b.iter(|| {
                    let mut st = RenderState::new(settings).expect("settings");
                    pool.install(|| {
                        btfpt::render::driver::run_pass(&rs, &mut st, 4, &stop, &|_, _| {})
                    });
                    st.rays()
                })
            });
        }
    }
    g.finish();
}

criterion_group! {
    name = eval;
    config = Criterion::default().with_measurement(ThreadCpuTime);
    targets = bench_eval
}
criterion_group! {
    name = render;
    config = Criterion::default().with_measurement(ProcessCpuTime);
    targets = bench_render
}
criterion_main!(eval, render);
