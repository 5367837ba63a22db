//! Radiometric checks of the integrator with analytic answers (diffuse BSDFs, generated meshes).

use crate::common::*;
use btfpt::bsdf::Texture;
use btfpt::bsdf::texture::{BitmapTexture, TexFilter, UvTransform, Wrap};
use btfpt::geometry::Mesh;
use btfpt::geometry::generate::{quad, sphere};
use btfpt::geometry::sphere::Sphere;
use btfpt::io::RgbImage;
use btfpt::math::Mat4;
use btfpt::math::{Spectrum, Vec3};
use btfpt::render::RenderScene;
use btfpt::scene::{Emitter, Scene};
use std::sync::Arc;

/// A convex diffuse object under a uniform environment reflects exactly albedo·Le (it never sees
/// itself); pixels missing the object see Le.
#[test]
fn diffuse_sphere_in_constant_environment() {
    let mut s = scene(
        Vec3::new(0.0, 0.0, 4.0),
        Vec3::ZERO,
        40.0,
        (24, 24),
        vec![sphere(Vec3::ZERO, 1.0, 24, 48, false, false)],
        vec![diffuse(0.6)],
        vec![Emitter::Constant {
            radiance: Spectrum::splat(2.0),
        }],
    );
    s.integrator.max_depth = -1;
    let rs = RenderScene::new(s).unwrap();
    let state = render(&rs, settings(&rs.scene, 16, 1));
    // Central pixels all hit the sphere (its image radius is ≈ 8.5 px around the centre).
    let center = |x: usize, y: usize| {
        let (dx, dy) = (x as f32 - 11.5, y as f32 - 11.5);
        dx * dx + dy * dy < 36.0
    };
    let (mean, se, n) = region_stats(&state, center);
    assert!(n > 100);
    assert!(
        (mean - 1.2).abs() < 3.0 * se + 1e-4,
        "L = {mean} ± {se}, want 1.2"
    );
    // Corners see the environment directly and exactly.
    let img = state.mean_image();
    assert_eq!(img.get(0, 0), [2.0, 2.0, 2.0]);
    assert_eq!(state.invalid_samples(), 0);
}

fn furnace(albedo: f32, max_depth: i32, spp: u32) -> (f64, f64) {
    // Camera inside a closed, inward-facing, emissive diffuse sphere: L = Le·Σ_{k<max_depth} aᵏ.
    let mut m = sphere(Vec3::ZERO, 1.0, 16, 32, true, true);
    m.emitter = Some(Spectrum::ONE);
    let mut s = scene(
        Vec3::new(0.1, 0.2, 0.0),
        Vec3::new(0.1, 0.2, 1.0),
        60.0,
        (8, 8),
        vec![m],
        vec![diffuse(albedo)],
        vec![],
    );
    s.integrator.max_depth = max_depth;
    let rs = RenderScene::new(s).unwrap();
    let st = render(&rs, settings(&rs.scene, spp, 7));
    assert_eq!(st.invalid_samples(), 0);
    let (m, se, _) = region_stats(&st, |_, _| true);
    (m, se)
}

/// White-furnace style test of area-light NEE + MIS, RR and Mitsuba's max_depth semantics.
#[test]
fn emissive_furnace_matches_geometric_series() {
    let a = 0.8f64;
    for (depth, want) in [
        (1, 1.0),
        (2, 1.0 + a),
        (3, 1.0 + a + a * a),
        (-1, 1.0 / (1.0 - a)),
    ] {
        let (m, se) = furnace(a as f32, depth, 64);
        // Tessellation (16×32, smooth normals) perturbs the answer by well under 1%.
        let tol = 4.0 * se + 0.01 * want;
        assert!(
            (m - want).abs() < tol,
            "max_depth {depth}: {m} ± {se}, want {want}"
        );
    }
}

/// Full MIS (NEE + BSDF sampling) and pure BSDF sampling estimate the same image.
#[test]
fn nee_and_bsdf_sampling_agree() {
    // Floor, a tilted emissive quad facing it and an environment.
    let floor = quad(
        Vec3::new(-2.0, 0.0, 2.0),
        Vec3::new(4.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -4.0),
    );
    let mut light = quad(
        Vec3::new(-0.5, 1.0, -0.5),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 1.0),
    );
    light.emitter = Some(Spectrum::new(4.0, 3.0, 2.0));
    light.bsdf = 1;
    let s = scene(
        Vec3::new(0.0, 2.0, 3.0),
        Vec3::new(0.0, 0.0, 0.0),
        50.0,
        (12, 12),
        vec![floor, light],
        vec![diffuse(0.5), diffuse(0.0)],
        vec![Emitter::Constant {
            radiance: Spectrum::splat(0.3),
        }],
    );
    let ma = mis_matches_bsdf_sampling_alone(s, 64, 256, |_, _| true);
    // The light faces down (e1 × e2 = x × z = −y) onto the floor, so the image must be
    // brighter than the environment-only floor value 0.5·0.3 (its back, seen from above, is black).
    assert!(ma > 0.2, "{ma}");
}

/// Renders `s` with MIS (NEE and BSDF sampling, `spp_mis` samples) and with BSDF sampling alone
/// (`spp_bsdf`), asserts their means over the pixels `region` picks agree within 4 σ, and returns
/// the MIS mean.
fn mis_matches_bsdf_sampling_alone(
    s: Scene,
    spp_mis: u32,
    spp_bsdf: u32,
    region: impl Fn(usize, usize) -> bool + Copy,
) -> f64 {
    let mut rs = RenderScene::new(s).unwrap();
    let a = render(&rs, settings(&rs.scene, spp_mis, 3));
    rs.integrator.nee = false;
    let b = render(&rs, settings(&rs.scene, spp_bsdf, 4));
    let (ma, sa, _) = region_stats(&a, region);
    let (mb, sb, _) = region_stats(&b, region);
    let z = (ma - mb) / (sa * sa + sb * sb).sqrt();
    assert!(
        z.abs() < 4.0,
        "MIS {ma} ± {sa} vs BSDF-only {mb} ± {sb} (z = {z})"
    );
    ma
}

/// An analytic (Mitsuba `sphere`) mesh with centre `c` and radius `r`.
fn analytic(c: Vec3, r: f32, flip: bool) -> Mesh {
    let xf = Mat4::from_translation(c) * Mat4::from_scale(Vec3::splat(r));
    Mesh {
        name: "sphere".into(),
        sphere: Some(Sphere::from_to_world(&xf, flip).unwrap()),
        ..Default::default()
    }
}

/// The furnace inside an analytic, inward-facing emissive sphere: uniform-area emitter sampling
/// from inside, its pdf in MIS and the flipped normal; exact up to noise (no tessellation).
#[test]
fn analytic_sphere_furnace_matches_geometric_series() {
    let a = 0.8f64;
    for (depth, want) in [(2, 1.0 + a), (-1, 1.0 / (1.0 - a))] {
        let mut m = analytic(Vec3::new(0.0, 0.0, 0.3), 1.0, true);
        m.emitter = Some(Spectrum::ONE);
        let mut s = scene(
            Vec3::new(0.1, 0.2, 0.0),
            Vec3::new(0.1, 0.2, 1.0),
            60.0,
            (8, 8),
            vec![m],
            vec![diffuse(a as f32)],
            vec![],
        );
        s.integrator.max_depth = depth;
        let rs = RenderScene::new(s).unwrap();
        let st = render(&rs, settings(&rs.scene, 64, 5));
        assert_eq!(st.invalid_samples(), 0);
        let (m, se, _) = region_stats(&st, |_, _| true);
        assert!(
            (m - want).abs() < 4.0 * se + 1e-4,
            "max_depth {depth}: {m} ± {se}, want {want}"
        );
    }
}

/// A spherical area light seen from outside: Mitsuba's cone sampling (NEE) and BSDF sampling
/// weighted by the cone pdf (MIS) agree with pure BSDF sampling; an analytic occluder casts
/// its shadow through `occluded`.
#[test]
fn analytic_sphere_light_nee_and_bsdf_sampling_agree() {
    let floor = quad(
        Vec3::new(-2.0, 0.0, 2.0),
        Vec3::new(4.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -4.0),
    );
    let mut light = analytic(Vec3::new(0.3, 1.2, -0.2), 0.4, false);
    light.emitter = Some(Spectrum::new(4.0, 3.0, 2.0));
    light.bsdf = 1;
    let blocker = analytic(Vec3::new(0.0, 0.4, 0.0), 0.3, false);
    let s = scene(
        Vec3::new(0.0, 2.0, 3.0),
        Vec3::new(0.0, 0.0, 0.0),
        50.0,
        (12, 12),
        vec![floor, light, blocker],
        vec![diffuse(0.5), diffuse(0.0)],
        vec![],
    );
    let ma = mis_matches_bsdf_sampling_alone(s, 64, 512, |_, _| true);
    assert!(ma > 0.1, "{ma}");
}

/// NaN radiance in the input never reaches the film: samples are discarded and counted.
#[test]
fn nan_input_renders_finite() {
    let mut bad = quad(
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(0.0, 2.0, 0.0),
    );
    bad.emitter = Some(Spectrum::new(f32::NAN, 1.0, 1.0));
    let mut nan_tri = quad(Vec3::ZERO, Vec3::X, Vec3::Y);
    nan_tri.positions[1] = Vec3::new(f32::NAN, 0.0, 0.0);
    let s = scene(
        Vec3::new(0.0, 0.0, 3.0),
        Vec3::ZERO,
        60.0,
        (8, 8),
        vec![bad, nan_tri],
        vec![diffuse(0.5)],
        vec![Emitter::Constant {
            radiance: Spectrum::splat(1.0),
        }],
    );
    let rs = RenderScene::new(s).unwrap();
    let st = render(&rs, settings(&rs.scene, 4, 0));
    assert!(st.invalid_samples() > 0);
    assert!(st.mean_image().data.iter().all(|v| v.is_finite()));
}

/// hide_emitters: the camera sees neither the environment nor area emitters directly (camera
/// rays pass through area emitters, as Mitsuba's `skip_area_emitters`).
#[test]
fn hide_emitters_hides_only_direct_visibility() {
    let mut light = quad(
        Vec3::new(-5.0, -5.0, -1.0),
        Vec3::new(10.0, 0.0, 0.0),
        Vec3::new(0.0, 10.0, 0.0),
    );
    light.emitter = Some(Spectrum::ONE);
    let mut s = scene(
        Vec3::new(0.0, 0.0, 3.0),
        Vec3::ZERO,
        30.0,
        (4, 4),
        vec![light],
        vec![diffuse(0.0)],
        vec![Emitter::Constant {
            radiance: Spectrum::splat(1.0),
        }],
    );
    let rs = RenderScene::new(s.clone()).unwrap();
    let shown = render(&rs, settings(&rs.scene, 2, 0)).mean_image();
    assert!(shown.data.iter().all(|&v| v == 1.0));
    s.integrator.hide_emitters = true;
    let rs = RenderScene::new(s).unwrap();
    let hidden = render(&rs, settings(&rs.scene, 2, 0)).mean_image();
    assert!(hidden.data.iter().all(|&v| v == 0.0));
}

/// Environment-map NEE (importance sampled) + MIS agrees with pure BSDF sampling.
#[test]
fn envmap_nee_and_bsdf_sampling_agree() {
    let mut img = btfpt::io::RgbImage::new(16, 8);
    for j in 0..8 {
        for i in 0..16 {
            let hot = if (i, j) == (5, 2) { 20.0 } else { 0.0 };
            img.set(i, j, [0.2 + 0.05 * i as f32 + hot, 0.3, 0.1 * j as f32]);
        }
    }
    let s = scene(
        Vec3::new(0.0, 0.5, 3.0),
        Vec3::ZERO,
        45.0,
        (10, 10),
        vec![sphere(Vec3::ZERO, 1.0, 16, 32, false, true)],
        vec![diffuse(0.7)],
        vec![Emitter::EnvMap {
            image: std::sync::Arc::new(img),
            to_world: btfpt::math::Mat4::from_rotation_y(0.7),
            scale: 1.5,
            filename: "gen.exr".into(),
        }],
    );
    mis_matches_bsdf_sampling_alone(s, 128, 1024, |x, y| {
        (3..7).contains(&x) && (3..7).contains(&y)
    });
}

/// A 2 × 2 nearest-filtered bitmap of four distinct colours, clamped at the border.
fn four_texels() -> (Texture, [[f32; 3]; 4]) {
    let texels = [
        [1.0, 0.25, 0.5],
        [0.125, 2.0, 0.75],
        [3.0, 0.5, 0.0625],
        [0.375, 0.625, 4.0],
    ];
    let image = RgbImage {
        width: 2,
        height: 2,
        data: texels.concat(),
    };
    let t = BitmapTexture::new(
        image,
        TexFilter::Nearest,
        Wrap::Clamp,
        UvTransform::IDENTITY,
    );
    (Texture::Mapped(Arc::new(t)), texels)
}

/// An area light whose radiance is a texture, seen directly (max_depth 1: emission only):
/// each quarter of the light shows one texel exactly, and each texel shows once.
#[test]
fn textured_area_light_seen_directly_shows_its_texels() {
    let (texture, texels) = four_texels();
    let mut light = quad(Vec3::new(-1.0, -1.0, 0.0), Vec3::X * 2.0, Vec3::Y * 2.0);
    light.emitter = Some(Spectrum::ONE);
    let mut s = scene(
        Vec3::new(0.0, 0.0, 3.4),
        Vec3::ZERO,
        40.0,
        (16, 16),
        vec![light],
        vec![diffuse(0.5)],
        vec![],
    );
    s.emission_textures = vec![(0, texture)];
    s.integrator.max_depth = 1;
    let rs = RenderScene::new(s).unwrap();
    let img = render(&rs, settings(&rs.scene, 4, 1)).mean_image();
    // The light spans the middle ≈ 12.9 px of the 16: pixels 4 and 11 sit inside its quarters.
    let mut seen = Vec::new();
    for (x, y) in [(4, 4), (11, 4), (4, 11), (11, 11)] {
        let v = img.get(x, y);
        let k = texels.iter().position(|t| *t == v);
        assert!(
            k.is_some(),
            "pixel ({x}, {y}) = {v:?} is none of the texels"
        );
        seen.push(k);
    }
    seen.sort();
    seen.dedup();
    assert_eq!(seen.len(), 4, "each texel should show once");
}

/// A radiance texture that is the same everywhere lights a diffuse floor as its constant does:
/// the same samples, the emitted radiance looked up through the texture (light sampling and
/// emitter hits alike).
#[test]
fn uniform_radiance_texture_lights_like_the_constant() {
    let c = [2.0f32, 1.5, 0.75];
    let image = RgbImage {
        width: 3,
        height: 2,
        data: c.repeat(6),
    };
    let render_with = |textured: bool| {
        let floor = quad(Vec3::new(-2.0, -1.0, 2.0), Vec3::X * 4.0, Vec3::Z * -4.0);
        let mut light = quad(Vec3::new(-0.5, 1.0, -0.5), Vec3::X, Vec3::Z);
        light.emitter = Some(if textured {
            Spectrum::ONE
        } else {
            Spectrum::from(c)
        });
        let mut s = scene(
            Vec3::new(0.0, 0.5, 4.0),
            Vec3::new(0.0, -0.5, 0.0),
            50.0,
            (24, 16),
            vec![floor, light],
            vec![diffuse(0.7)],
            vec![],
        );
        if textured {
            s.emission_textures = vec![(1, Texture::Bitmap(Arc::new(image.clone())))];
        }
        let rs = RenderScene::new(s).unwrap();
        render(&rs, settings(&rs.scene, 8, 3)).mean_image()
    };
    let (plain, textured) = (render_with(false), render_with(true));
    let lit = plain.data.iter().filter(|&&v| v > 0.0).count();
    assert!(
        lit > plain.data.len() / 4,
        "the floor should be lit: {lit} values"
    );
    for (a, b) in plain.data.iter().zip(&textured.data) {
        assert!((a - b).abs() <= 1e-5 * a.abs().max(1.0), "{a} vs {b}");
    }
}
