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
//! `cargo bench --bench btf_eval`; ns per evaluation = reported time / 4096 queries. The
//! evaluation group measures thread CPU time (the machine is shared); the render group, whose
//! work runs on a pool thread, process CPU time.

use btfpt::bsdf::{Bsdf, BtfBsdf, BtfMaterial, Diffuse, PlmcBsdf, Texture};
use btfpt::btf::plmc::PlmcMaterial;
use btfpt::btf::{DirectionSet, RawBtf, StoredEncoding};
use btfpt::fit::model::{ModelKind, PackedLobe, PlmcModel, ValueSpace, ViewParams};
use btfpt::geometry::SurfaceInteraction;
use btfpt::geometry::generate::{quad, sphere};
use btfpt::math::{Frame, Mat4, Pcg32, Spectrum, Vec3, warp};
use btfpt::render::RenderScene;
use btfpt::render::film::{RenderSettings, RenderState};
use btfpt::scene::{Camera, IntegratorSettings, Scene};
#[path = "common/cpu_time.rs"]
mod cpu_time;

use cpu_time::{ProcessCpuTime, ThreadCpuTime};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

const SIZE: usize = 256;
const QUERIES: usize = 4096;

fn lobe(rng: &mut Pcg32) -> PackedLobe {
    let d = warp::square_to_cosine_hemisphere(rng.next_2d());
    PackedLobe::pack(&[
        0.2 + rng.next_f32(),
        d.x,
        d.y,
        d.z,
        1.0 + 80.0 * rng.next_f32() * rng.next_f32(),
    ])
}

/// A random model of `kind` on the UBO2003 directions, `SIZE`² texels, 256 clusters for PLM-C.
fn model(kind: ModelKind) -> PlmcModel {
    let set = DirectionSet::ubo2003();
    let mut rng = Pcg32::new(kind.code() as u64, 1);
    let texels = SIZE * SIZE;
    let k = 256;
    let params = (0..set.len())
        .map(|_| match kind {
            ModelKind::PlmC => ViewParams::Clustered {
                k,
                table: (0..3 * k).map(|_| lobe(&mut rng)).collect(),
                index: (0..3 * texels)
                    .map(|_| rng.next_below(k as u32) as u16)
                    .collect(),
            },
            _ => {
                // Per-texel lobes: a pool of random lobes repeated (generation cost only).
                let pool: Vec<PackedLobe> = (0..4096).map(|_| lobe(&mut rng)).collect();
                ViewParams::Texel(
                    (0..3 * texels)
                        .map(|i| pool[(i * 2654435761) % pool.len()])
                        .collect(),
                )
            }
        })
        .collect();
    let polys = if kind.has_polys() {
        (0..set.len() * set.len() * 3)
            .map(|_| {
                [
                    0.01 * rng.next_f32(),
                    0.9 + 0.2 * rng.next_f32(),
                    0.1 * rng.next_f32(),
                    -0.05 * rng.next_f32(),
                    0.01 * rng.next_f32(),
                ]
            })
            .collect()
    } else {
        Vec::new()
    };
    PlmcModel {
        kind,
        views: set.clone(),
        lights: set,
        width: SIZE,
        height: SIZE,
        clusters: if kind == ModelKind::PlmC { k } else { 0 },
        space: ValueSpace::Linear,
        params,
        polys,
    }
}

fn queries() -> Vec<(SurfaceInteraction, Vec3)> {
    let mut rng = Pcg32::new(42, 42);
    (0..QUERIES)
        .map(|_| {
            let wi = warp::square_to_uniform_hemisphere(rng.next_2d());
            let wo = warp::square_to_uniform_hemisphere(rng.next_2d());
            let mut si = SurfaceInteraction::for_tests(wi, rng.next_2d());
            si.sh_frame = Frame::from_normal(Vec3::Z);
            (si, wo)
        })
        .collect()
}

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

/// A closed box with two spheres and an area light; every surface uses `bsdf`.
fn scene(bsdf: Bsdf) -> RenderScene {
    let mut meshes = Vec::new();
    let (x, y, z) = (Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::Z * 2.0);
    let o = Vec3::new(-1.0, -1.0, -1.0);
    for (c, e1, e2) in [
        (o, z, x),
        (o + y, x, z),
        (o, x, y),
        (o, y, z),
        (o + x, z, y),
    ] {
        meshes.push(quad(c, e1, e2));
    }
    let mut light = quad(
        Vec3::new(-0.3, 0.99, -0.3),
        Vec3::new(0.6, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 0.6),
    );
    light.emitter = Some(Spectrum::splat(15.0));
    meshes.push(light);
    meshes.push(sphere(
        Vec3::new(-0.4, -0.6, -0.3),
        0.4,
        32,
        64,
        false,
        true,
    ));
    meshes.push(sphere(
        Vec3::new(0.45, -0.65, 0.3),
        0.35,
        32,
        64,
        false,
        true,
    ));
    let dir = Vec3::new(0.0, 0.0, -1.0);
    let origin = Vec3::new(0.0, 0.0, 3.4);
    let left = Vec3::Y.cross(dir).normalize();
    let up = dir.cross(left);
    let scene = Scene {
        source: "box (in code)".into(),
        camera: Camera {
            to_world: Mat4::from_cols(
                left.extend(0.0),
                up.extend(0.0),
                dir.extend(0.0),
                origin.extend(1.0),
            ),
            fov_x_deg: 40.0,
            near_clip: 1e-3,
            far_clip: 100.0,
            width: 64,
            height: 64,
            crop: None,
        },
        integrator: IntegratorSettings::default(),
        spp: 4,
        meshes,
        bsdfs: vec![bsdf],
        emitters: vec![],
    };
    RenderScene::new(scene).expect("valid scene")
}

fn bench_render(c: &mut Criterion<ProcessCpuTime>) {
    let plmc = Arc::new(PlmcMaterial::new(&model(ModelKind::PlmC)).unwrap());
    let settings = RenderSettings {
        width: 64,
        height: 64,
        crop: [0, 0, 64, 64],
        spp_begin: 0,
        spp_end: 4,
        seed: 0,
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("thread pool");
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
        let rs = scene(bsdf);
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut st = RenderState::new(settings).expect("settings");
                pool.install(|| st.run_pass(&rs, 4, &stop, &|_, _| {}));
                st.rays()
            })
        });
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
