//! The Cornell-like box built in code that `benches/render.rs`, `benches/btf_eval.rs` and
//! `examples/btf_eval_profile.rs` render: five walls, an area light, two spheres, a 64×64 film
//! at 4 spp, rendered on one thread.

use btfpt::bsdf::Bsdf;
use btfpt::geometry::generate::{quad, sphere};
use btfpt::math::{Mat4, Spectrum, Vec3};
use btfpt::render::RenderScene;
use btfpt::render::film::RenderSettings;
use btfpt::scene::{Camera, IntegratorSettings, Scene};

/// Film side in pixels and samples per pixel of the box renders.
pub const FILM: u32 = 64;
pub const SPP: u32 = 4;

/// The box with `bsdfs`; `walls` = BSDF index of the floor, ceiling, back, left and right walls
/// (the light and the spheres use BSDF 0).
pub fn box_scene(bsdfs: Vec<Bsdf>, walls: [u32; 5]) -> RenderScene {
    let mut meshes = Vec::new();
    let (x, y, z) = (Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::Z * 2.0);
    let o = Vec3::new(-1.0, -1.0, -1.0);
    // floor (normal +y), ceiling (−y), back (+z), left (+x), right (−x)
    for ((c, e1, e2), bsdf) in [
        (o, z, x),
        (o + y, x, z),
        (o, x, y),
        (o, y, z),
        (o + x, z, y),
    ]
    .into_iter()
    .zip(walls)
    {
        let mut q = quad(c, e1, e2);
        q.bsdf = bsdf;
        meshes.push(q);
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
        channels: Default::default(),
        btf_uses: Vec::new(),
        emission_textures: Vec::new(),
        inputs: Vec::new(),
        source: "box (in code)".into(),
        camera: Camera {
            to_world: Mat4::from_cols(
                left.extend(0.0),
                up.extend(0.0),
                dir.extend(0.0),
                origin.extend(1.0),
            ),
            projection: btfpt::scene::Projection::Perspective,
            fov_x_deg: 40.0,
            near_clip: 1e-3,
            far_clip: 100.0,
            width: FILM,
            height: FILM,
            crop: None,
            filter: btfpt::math::filter::Filter::BOX,
        },
        integrator: IntegratorSettings::default(),
        spp: SPP,
        meshes,
        bsdfs,
        emitters: vec![],
    };
    RenderScene::new(scene).expect("valid scene")
}

/// The whole film, samples 0..SPP, seed 0.
pub fn settings() -> RenderSettings {
    RenderSettings {
        width: FILM,
        height: FILM,
        crop: [0, 0, FILM, FILM],
        spp_begin: 0,
        spp_end: SPP,
        seed: 0,
    }
}

/// The one-thread pool the renders run in (a bench measures one core).
pub fn single_thread_pool() -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("thread pool")
}
