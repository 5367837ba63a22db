//! Behavioural tests of the simulator on tiny tiles made here (seconds in debug builds).

use super::*;
use crate::btf::{BtfSource, DirectionSet, RawBtf};
use crate::math::Vec3;

fn settings(
    views: &[(f32, f32)],
    lights: &[(f32, f32)],
    strata: usize,
    inter: bool,
) -> SynthSettings {
    SynthSettings {
        views: DirectionSet::from_angles_deg(views.to_vec()),
        lights: DirectionSet::from_angles_deg(lights.to_vec()),
        strata,
        seed: 7,
        interreflection: inter,
        indirect_clamp: 1.0,
        progress: false,
    }
}

/// Mean RGB over the texels of one (view, light) image.
fn mean(b: &RawBtf, v: usize, l: usize) -> Vec3 {
    let mut s = Vec3::ZERO;
    for y in 0..b.height() {
        for x in 0..b.width() {
            s += Vec3::from(b.texel(v, l, x, y));
        }
    }
    s / (b.width() * b.height()) as f32
}

#[test]
fn flat_white_lambertian_gives_cos_theta_l_for_every_view() {
    let surf = MicroSurface::from_fn(
        8,
        8,
        2,
        true,
        |_, _| 0.0,
        |_, _| BrdfParams::lambert(Vec3::ONE),
    )
    .unwrap();
    let lights = [(0.0, 0.0), (30.0, 90.0), (60.0, 180.0), (75.0, 300.0)];
    let s = settings(&[(0.0, 0.0), (45.0, 30.0), (75.0, 200.0)], &lights, 2, true);
    let b = measure(&surf, &s).unwrap();
    for v in 0..3 {
        for (l, &(theta, _)) in lights.iter().enumerate() {
            let want = theta.to_radians().cos();
            for y in 0..8 {
                for x in 0..8 {
                    for c in b.texel(v, l, x, y) {
                        // f16 storage: relative precision 2⁻¹¹.
                        assert!(
                            (c - want).abs() < 1e-3,
                            "v{v} l{l} ({x},{y}): {c} vs {want}"
                        );
                    }
                }
            }
        }
    }
}

/// V-grooves along y (period 4 texels, 45° walls), seen head-on. With the light across the
/// grooves at elevation ε above the horizon, the wall facing it (cos_wall = (sin θ + cos θ)/√2)
/// is shadowed by the opposite wall over a fraction (1 − tan ε)/(1 + tan ε) of its width, so
/// B̄ = ½ · cos_wall · (1 − that); without cast shadows it would be ½ · cos_wall.
#[test]
fn v_grooves_shadow_grazing_light_across_them() {
    let p = 4.0f32;
    let surf = MicroSurface::from_fn(
        8,
        8,
        4,
        false,
        |x, _| ((x / p).fract() - 0.5).abs() * p,
        |_, _| BrdfParams::lambert(Vec3::ONE),
    )
    .unwrap();
    let lights = [(75.0, 0.0), (60.0, 0.0), (75.0, 90.0)];
    let direct = measure(&surf, &settings(&[(0.0, 0.0)], &lights, 4, false)).unwrap();
    for (l, theta) in [(0usize, 75.0f32), (1, 60.0)] {
        let eps = (90.0 - theta).to_radians();
        let cos_wall = (theta.to_radians().sin() + theta.to_radians().cos()) / 2f32.sqrt();
        let shadowed = (1.0 - eps.tan()) / (1.0 + eps.tan());
        let want = 0.5 * cos_wall * (1.0 - shadowed);
        let unshadowed = 0.5 * cos_wall;
        let got = mean(&direct, 0, l).x;
        assert!((got - want).abs() < 0.012, "θ_l {theta}: {got} vs {want}");
        assert!(
            got < unshadowed - 0.1,
            "θ_l {theta}: {got} not shadowed ({unshadowed})"
        );
    }
    // Along the grooves nothing casts a shadow: both walls see cos 45° · cos 75°.
    let along = mean(&direct, 0, 2).x;
    let want = 45f32.to_radians().cos() * 75f32.to_radians().cos();
    assert!((along - want).abs() < 2e-3, "{along} vs {want}");
    // Inter-reflection adds light inside the grooves but cannot exceed the unshadowed value.
    let inter = measure(&surf, &settings(&[(0.0, 0.0)], &lights, 4, true)).unwrap();
    let (d, i) = (mean(&direct, 0, 0).x, mean(&inter, 0, 0).x);
    assert!(
        i > d + 0.005 && i < 0.5 * 0.866,
        "direct {d}, with bounce {i}"
    );
}

/// A red-topped mesa 3 texels high: its top moves by −h·tan θ_v along φ_v between views.
#[test]
fn parallax_shifts_a_raised_feature_between_views() {
    let (cx, cy, r) = (8.0f32, 8.0f32, 2.5f32);
    let inside = move |x: f32, y: f32| (x - cx).hypot(y - cy) < r;
    let surf = MicroSurface::from_fn(
        16,
        16,
        4,
        false,
        move |x, y| if inside(x, y) { 3.0 } else { 0.0 },
        move |x, y| {
            let top = (x - cx).hypot(y - cy) < r - 0.25;
            BrdfParams::lambert(if top { Vec3::X } else { Vec3::ONE })
        },
    )
    .unwrap();
    let top = surf.heightfield().zmax();
    let views = [(0.0, 0.0), (45.0, 0.0), (30.0, 90.0)];
    let b = measure(&surf, &settings(&views, &[(0.0, 0.0)], 2, false)).unwrap();
    for (v, &(theta, phi)) in views.iter().enumerate() {
        let (mut sw, mut sx, mut sy) = (0.0f32, 0.0f32, 0.0f32);
        for y in 0..16 {
            for x in 0..16 {
                let t = b.texel(v, 0, x, y);
                let w = (t[0] - t[1]).max(0.0);
                sw += w;
                sx += w * (x as f32 + 0.5);
                sy += w * (y as f32 + 0.5);
            }
        }
        let shift = top * theta.to_radians().tan();
        let (wx, wy) = (
            cx - shift * phi.to_radians().cos(),
            cy - shift * phi.to_radians().sin(),
        );
        let (gx, gy) = (sx / sw, sy / sw);
        assert!(
            (gx - wx).abs() < 0.2 && (gy - wy).abs() < 0.2,
            "view {v}: centroid ({gx}, {gy}) vs ({wx}, {wy})"
        );
    }
}

#[test]
fn output_is_identical_for_one_and_two_threads() {
    let surf = MaterialKind::Wool.build(8, 8, 2, 3).unwrap();
    let s = settings(
        &[(0.0, 0.0), (45.0, 60.0), (75.0, 135.0)],
        &[(0.0, 0.0), (60.0, 18.0), (75.0, 300.0)],
        2,
        true,
    );
    let run = |n: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
            .install(|| measure(&surf, &s).unwrap())
    };
    let (a, b) = (run(1), run(2));
    assert!(a.data() == b.data());
    let other = measure(
        &surf,
        &SynthSettings {
            seed: 8,
            ..s.clone()
        },
    )
    .unwrap();
    assert!(other.data() != a.data(), "the seed must matter");
}

#[test]
fn all_materials_give_finite_nonnegative_varying_data() {
    let views = [(0.0, 0.0), (45.0, 60.0), (75.0, 180.0)];
    let lights = [(0.0, 0.0), (30.0, 30.0), (60.0, 200.0), (75.0, 315.0)];
    let s = settings(&views, &lights, 1, true);
    for m in MaterialKind::ALL {
        let b = measure(&m.build(16, 16, 2, 1).unwrap(), &s).unwrap();
        let vals: Vec<f32> = b.data().iter().map(|v| v.to_f32()).collect();
        assert!(
            vals.iter().all(|v| v.is_finite() && *v >= 0.0),
            "{}",
            m.name()
        );
        let n = vals.len() as f32;
        let mu = vals.iter().sum::<f32>() / n;
        let var = vals.iter().map(|v| (v - mu).powi(2)).sum::<f32>() / n;
        assert!(
            mu > 0.01 && var.sqrt() > 0.1 * mu,
            "{}: mean {mu} sd {}",
            m.name(),
            var.sqrt()
        );
        // Spatial variation within the head-on image as well.
        let first: Vec<f32> = (0..16 * 16)
            .map(|t| b.texel(0, 0, t % 16, t / 16)[0])
            .collect();
        let lo = first.iter().copied().fold(f32::INFINITY, f32::min);
        let hi = first.iter().copied().fold(0.0, f32::max);
        assert!(hi > 1.2 * lo + 1e-3, "{}: flat head-on image", m.name());
    }
}

/// Anisotropy = the response changes when view and light are rotated together about the normal
/// (an isotropic surface would not change). Corduroy ridges run along y.
#[test]
fn corduroy_changes_under_joint_azimuth_rotation() {
    let surf = MaterialKind::Corduroy.build(12, 12, 2, 1).unwrap();
    let views = [(60.0, 0.0), (60.0, 90.0)];
    let lights = [(60.0, 0.0), (60.0, 90.0), (45.0, 180.0), (45.0, 270.0)];
    let b = measure(&surf, &settings(&views, &lights, 2, true)).unwrap();
    let lum = |v, l| crate::math::color::luminance(mean(&b, v, l));
    for (l0, l90) in [(0, 1), (2, 3)] {
        let (across, along) = (lum(0, l0), lum(1, l90));
        assert!(
            (along - across).abs() > 0.25 * along.max(across),
            "lights {l0}/{l90}: across {across} along {along}"
        );
    }
}

#[test]
fn bad_settings_and_names_are_rejected() {
    let surf = MaterialKind::Leather.build(4, 4, 1, 1).unwrap();
    let below = settings(&[(95.0, 0.0)], &[(0.0, 0.0)], 1, false);
    assert!(measure(&surf, &below).is_err());
    let zero = settings(&[(0.0, 0.0)], &[(0.0, 0.0)], 0, false);
    assert!(measure(&surf, &zero).is_err());
    assert!(MaterialKind::from_name("velvet").is_err());
    assert_eq!(MaterialKind::from_name("Wool").unwrap(), MaterialKind::Wool);
    assert!(MaterialKind::Wool.build(0, 4, 2, 1).is_err());
}
