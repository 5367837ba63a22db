//! End-to-end rendering of a small Cornell-box-like scene built in code (diffuse walls, an
//! area light, two spheres): one 64×64 frame at 4 spp, single-threaded. Throughput is in
//! pixel-samples per second. The scalar and the packet integrator side by side (the same
//! image bits): `cargo bench --bench render`.

use btfpt::bsdf::{Bsdf, Diffuse, Texture};
use btfpt::math::Spectrum;
use btfpt::render::film::RenderState;
use btfpt::render::packet::PacketOptions;
use btfpt::render::{IntegratorKind, RenderScene};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::sync::atomic::AtomicBool;

#[path = "common/box_scene.rs"]
mod box_scene;

fn diffuse(r: f32, g: f32, b: f32) -> Bsdf {
    Bsdf::Diffuse(Diffuse {
        reflectance: Texture::Constant(Spectrum::new(r, g, b)),
    })
}

/// The shared box with grey walls, a red left and a green right wall.
fn cornell() -> RenderScene {
    box_scene::box_scene(
        vec![
            diffuse(0.73, 0.73, 0.73),
            diffuse(0.65, 0.05, 0.05),
            diffuse(0.12, 0.45, 0.15),
        ],
        [0, 0, 0, 1, 2],
    )
}

fn bench(c: &mut Criterion) {
    let mut rs = cornell();
    let settings = box_scene::settings();
    let pool = box_scene::single_thread_pool();
    let stop = AtomicBool::new(false);
    let mut g = c.benchmark_group("render");
    g.sample_size(20);
    g.throughput(Throughput::Elements(64 * 64 * 4));
    for (name, kind) in [
        ("cornell_64x64_4spp_1thread", IntegratorKind::Scalar),
        (
            "cornell_64x64_4spp_1thread_packet",
            IntegratorKind::Packet(PacketOptions::default()),
        ),
    ] {
        rs.kind = kind;
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut st = RenderState::new(settings).expect("settings");
                pool.install(|| {
                    btfpt::render::driver::run_pass(&rs, &mut st, 4, &stop, &|_, _| {})
                });
                st.rays()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
