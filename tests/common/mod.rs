//! Scenes built in code for the render tests (the XML loader is another module's job).
#![allow(dead_code)]

use btfpt::bsdf::{Bsdf, Diffuse, Texture};
use btfpt::geometry::Mesh;
use btfpt::math::{Spectrum, Vec3};
use btfpt::render::RenderScene;
use btfpt::render::film::{RenderSettings, RenderState};
use btfpt::scene::{Camera, Emitter, IntegratorSettings, Scene};
use std::process::Command;
use std::sync::atomic::AtomicBool;

/// Mitsuba's `lookat` (camera x = left): the library's, re-exported for the tests.
pub use btfpt::math::transform::look_at as lookat;

/// The `btfpt` binary built for these tests, ready for arguments; its `synth:` cache is a folder
/// of the build's scratch space, never the user's cache.
pub fn btfpt() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_btfpt"));
    c.env(
        "BTFPT_CACHE_DIR",
        std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("synth-cache"),
    );
    c
}

/// Runs `btfpt ARGS` to completion: (exit success, stdout, stderr).
pub fn btfpt_output(args: &[&str]) -> (bool, String, String) {
    let out = btfpt().args(args).output().expect("run btfpt");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

pub fn diffuse(albedo: f32) -> Bsdf {
    Bsdf::Diffuse(Diffuse {
        reflectance: Texture::Constant(Spectrum::splat(albedo)),
    })
}

pub fn scene(
    origin: Vec3,
    target: Vec3,
    fov: f32,
    res: (u32, u32),
    meshes: Vec<Mesh>,
    bsdfs: Vec<Bsdf>,
    emitters: Vec<Emitter>,
) -> Scene {
    Scene {
        btf_uses: Vec::new(),
        emission_textures: Vec::new(),
        inputs: Vec::new(),
        source: "in-code.xml".into(),
        camera: Camera {
            to_world: lookat(origin, target, Vec3::Y),
            projection: btfpt::scene::Projection::Perspective,
            fov_x_deg: fov,
            near_clip: 1e-3,
            far_clip: 1e4,
            width: res.0,
            height: res.1,
            crop: None,
            filter: btfpt::math::filter::Filter::BOX,
        },
        integrator: IntegratorSettings::default(),
        channels: Default::default(),
        spp: 4,
        meshes,
        bsdfs,
        emitters,
    }
}

pub fn settings(s: &Scene, spp: u32, seed: u64) -> RenderSettings {
    RenderSettings {
        width: s.camera.width,
        height: s.camera.height,
        crop: [0, 0, s.camera.width, s.camera.height],
        spp_begin: 0,
        spp_end: spp,
        seed,
    }
}

/// Renders to completion on the current thread pool.
pub fn render(rs: &RenderScene, st: RenderSettings) -> RenderState {
    let mut state = RenderState::new(st).unwrap();
    let stop = AtomicBool::new(false);
    while !state.is_complete() {
        btfpt::render::driver::run_pass(rs, &mut state, 1 << 20, &stop, &|_, _| {});
    }
    state
}

/// Per-channel-0 mean and standard error of the mean over the pixels where `mask` holds,
/// from the per-pixel means and variances of the mean.
pub fn region_stats(state: &RenderState, mask: impl Fn(usize, usize) -> bool) -> (f64, f64, usize) {
    let mean = state.mean_image();
    let var = state.variance_image().unwrap();
    let (mut s, mut v, mut n) = (0.0, 0.0, 0usize);
    for y in 0..mean.height {
        for x in 0..mean.width {
            if mask(x, y) {
                s += mean.get(x, y)[0] as f64;
                v += var.get(x, y)[0] as f64;
                n += 1;
            }
        }
    }
    let n_f = n.max(1) as f64;
    (s / n_f, (v / (n_f * n_f)).sqrt(), n)
}

/// A Mitsuba `perspective` sensor of `fov` degrees at (0, 0, `distance`) looking at the origin,
/// `spp` independent samples, a `width`×`height` box-filtered film: the header of the small
/// scene files the command-line tests write.
pub fn perspective_sensor(fov: f32, distance: f32, spp: u32, width: u32, height: u32) -> String {
    format!(
        r#"    <sensor type="perspective">
        <float name="fov" value="{fov}"/>
        <transform name="to_world"><lookat origin="0, 0, {distance}" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="{spp}"/></sampler>
        <film type="hdrfilm"><integer name="width" value="{width}"/><integer name="height" value="{height}"/>
            <rfilter type="box"/></film>
    </sensor>
"#
    )
}

/// Writes a raw BTF cache of 2 views (0° and 45°) × the 81 UBO2003 lights over a `w`×`h` texture
/// `tex` (linear, row-major): texel t under light l and view v is `tex[t]` · max(cos θ_l, 0.05) ·
/// (1 − 0.2 v), with G and B at 0.8 and 0.6 of R.
pub fn write_two_view_btf(path: &std::path::Path, w: usize, h: usize, tex: &[f32]) {
    use btfpt::btf::{DirectionSet, RawBtf, StoredEncoding, cache};
    assert_eq!(tex.len(), w * h);
    let lights = DirectionSet::ubo2003();
    let views = DirectionSet::from_angles_deg(vec![(0.0, 0.0), (45.0, 0.0)]);
    let mut data = Vec::with_capacity(2 * 81 * w * h * 3);
    for v in 0..2 {
        for l in 0..81 {
            let k = lights.dirs[l].z.max(0.05) * (1.0 - 0.2 * v as f32);
            for &t in tex {
                data.extend_from_slice(&[t * k, 0.8 * t * k, 0.6 * t * k]);
            }
        }
    }
    let btf = RawBtf::from_f32(views, lights, w, h, StoredEncoding::Linear, &data).unwrap();
    cache::write_raw(&btf, path).unwrap();
}

/// An ASCII PLY grid of `n`×`n` quads over [-1, 1]² (z = 0) with per-vertex colours (uchar
/// r, g, b: Mitsuba's `vertex_color`) and a per-face `weight_0` (`face_weight`).
pub fn attributed_grid_ply(n: usize) -> String {
    let mut s = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nproperty uchar r\nproperty uchar g\nproperty uchar b\n\
         element face {}\nproperty list uchar int vertex_indices\nproperty float weight_0\nend_header\n",
        (n + 1) * (n + 1),
        n * n
    );
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (
                2.0 * i as f32 / n as f32 - 1.0,
                2.0 * j as f32 / n as f32 - 1.0,
            );
            let (r, g, b) = (
                (i * 255 / n) as u8,
                (j * 255 / n) as u8,
                ((i + j) * 40 % 256) as u8,
            );
            s += &format!("{x} {y} 0 {r} {g} {b}\n");
        }
    }
    for j in 0..n {
        for i in 0..n {
            let v = j * (n + 1) + i;
            let w = ((i * 7 + j * 3) % 10) as f32 / 9.0;
            s += &format!("4 {} {} {} {} {w}\n", v, v + 1, v + n + 2, v + n + 1);
        }
    }
    s
}
