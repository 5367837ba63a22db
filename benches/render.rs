//! End-to-end rendering of a small Cornell-box-like scene built in code (diffuse walls, an
//! area light, two spheres): one 64×64 frame at 4 spp, single-threaded. Throughput is in
//! pixel-samples per second.

use btfpt::bsdf::{Bsdf, Diffuse, Texture};
use btfpt::geometry::generate::{quad, sphere};
use btfpt::math::{Mat4, Spectrum, Vec3};
use btfpt::render::RenderScene;
use btfpt::render::film::{RenderSettings, RenderState};
use btfpt::scene::{Camera, IntegratorSettings, Scene};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::sync::atomic::AtomicBool;

fn diffuse(r: f32, g: f32, b: f32) -> Bsdf {
    Bsdf::Diffuse(Diffuse {
        reflectance: Texture::Constant(Spectrum::new(r, g, b)),
    })
}

fn cornell() -> RenderScene {
    let mut meshes = Vec::new();
    let mut wall = |c: Vec3, e1: Vec3, e2: Vec3, bsdf: u32| {
        let mut q = quad(c, e1, e2);
        q.bsdf = bsdf;
        meshes.push(q);
    };
    let (x, y, z) = (Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::Z * 2.0);
    let o = Vec3::new(-1.0, -1.0, -1.0);
    wall(o, z, x, 0); // floor (normal +y)
    wall(o + y, x, z, 0); // ceiling (normal −y)
    wall(o, x, y, 0); // back (normal +z)
    wall(o, y, z, 1); // left (normal +x)
    wall(o + x, z, y, 2); // right (normal −x)
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
        source: "cornell (in code)".into(),
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
        bsdfs: vec![
            diffuse(0.73, 0.73, 0.73),
            diffuse(0.65, 0.05, 0.05),
            diffuse(0.12, 0.45, 0.15),
        ],
        emitters: vec![],
    };
    RenderScene::new(scene).expect("valid scene")
}

fn bench(c: &mut Criterion) {
    let rs = cornell();
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
    let mut g = c.benchmark_group("render");
    g.sample_size(20);
    g.throughput(Throughput::Elements(64 * 64 * 4));
    g.bench_function("cornell_64x64_4spp_1thread", |b| {
        b.iter(|| {
            let mut st = RenderState::new(settings).expect("settings");
            pool.install(|| st.run_pass(&rs, 4, &stop, &|_, _| {}));
            st.rays()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
