//! The synthetic models, queries and the box scene of `benches/btf_eval.rs`, shared with
//! `examples/btf_eval_profile.rs` (instruction counts under callgrind, ray counts).

use btfpt::bsdf::plmc::{PREPARE_LANES, PlmcHit};
use btfpt::bsdf::{Bsdf, PlmcBsdf};
use btfpt::btf::DirectionSet;
use btfpt::geometry::SurfaceInteraction;
use btfpt::math::{Frame, Pcg32, Vec3, warp};
use btfpt::model::{ModelKind, PackedLobe, PlmcModel, ValueSpace, ViewParams};
use btfpt::render::RenderScene;

#[path = "box_scene.rs"]
pub mod box_scene;

pub const SIZE: usize = 256;
pub const QUERIES: usize = 4096;

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
pub fn model(kind: ModelKind) -> PlmcModel {
    model_sized(kind, SIZE)
}

/// [`model`] with `size`² texels.
pub fn model_sized(kind: ModelKind, size: usize) -> PlmcModel {
    let set = DirectionSet::ubo2003();
    let mut rng = Pcg32::new(kind.code() as u64, 1);
    let texels = size * size;
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
        width: size,
        height: size,
        clusters: if kind == ModelKind::PlmC { k } else { 0 },
        space: ValueSpace::Linear,
        params,
        polys,
    }
}

pub fn queries() -> Vec<(SurfaceInteraction, Vec3)> {
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

/// The shared box ([`box_scene::box_scene`]) with `bsdf` on every surface.
pub fn scene(bsdf: Bsdf) -> RenderScene {
    box_scene::box_scene(vec![bsdf], [0; 5])
}

/// The per-hit states of up to 16 queries as the packet integrator makes them (one
/// [`PlmcBsdf::prepare16`]); slots past `chunk.len()` repeat the last query.
pub fn hits16(bsdf: &PlmcBsdf, chunk: &[(SurfaceInteraction, Vec3)]) -> [PlmcHit; PREPARE_LANES] {
    let n = chunk.len();
    assert!(n > 0 && n <= PREPARE_LANES);
    let mut w = [[0f32; PREPARE_LANES]; 3];
    let mut uv = [[0f32; PREPARE_LANES]; 2];
    for l in 0..PREPARE_LANES {
        let si = &chunk[l.min(n - 1)].0;
        (w[0][l], w[1][l], w[2][l]) = (si.wi.x, si.wi.y, si.wi.z);
        (uv[0][l], uv[1][l]) = (si.uv.x, si.uv.y);
    }
    let mut hits = [const { std::mem::MaybeUninit::uninit() }; PREPARE_LANES];
    let mut lane = [0u8; PREPARE_LANES];
    let n = bsdf.prepare16(
        [&w[0], &w[1], &w[2]],
        [&uv[0], &uv[1]],
        u16::MAX,
        &mut hits,
        &mut lane,
    );
    assert_eq!(n, PREPARE_LANES, "bench views are above the horizon");
    // SAFETY: prepare16 wrote all PREPARE_LANES entries.
    hits.map(|h| unsafe { h.assume_init() })
}
