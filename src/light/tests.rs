//! Every light's SoA twin against its scalar original, lane by lane and bit for bit, through
//! [`LightSet::sample_x`] and [`LightSet::eval_infinite_x`]: random reference points and numbers
//! mixed with the degenerate ones the branches exist for (a point on the light, directions
//! outside and on the edge of a spot's cone, zero and non-finite directions).

use super::*;
use crate::bsdf::Texture;
use crate::io::RgbImage;
use crate::math::simd::f16::{M16, V2x, V3x};
use crate::math::{Mat4, Pcg32, Spectrum, Vec2};
use std::path::PathBuf;
use std::sync::Arc;

fn bits3(v: Vec3) -> [u32; 3] {
    v.to_array().map(f32::to_bits)
}

fn sky() -> RgbImage {
    let (w, h) = (9, 6);
    let mut img = RgbImage::new(w, h);
    for j in 0..h {
        for i in 0..w {
            let v = 0.2 + ((i * 5 + j * 3) % 7) as f32 + if (i, j) == (4, 2) { 30.0 } else { 0.0 };
            img.set(i, j, [v, 0.6 * v, 0.2]);
        }
    }
    img
}

fn light_set() -> LightSet {
    let spot_at = Mat4::from_translation(Vec3::new(0.0, 2.0, 0.0)) * Mat4::from_rotation_x(1.2);
    let emitters = vec![
        Emitter::Point {
            position: Vec3::new(0.5, 1.0, -0.5),
            intensity: Spectrum::new(3.0, 2.0, 1.0),
        },
        Emitter::Spot {
            to_world: spot_at,
            intensity: Spectrum::splat(5.0),
            cutoff_angle: 40.0,
            beam_width: 25.0,
            texture: None,
        },
        Emitter::Spot {
            to_world: Mat4::from_translation(Vec3::new(0.3, -2.0, 0.1))
                * Mat4::from_rotation_x(-1.4),
            intensity: Spectrum::new(4.0, 3.0, 2.0),
            cutoff_angle: 50.0,
            beam_width: 30.0,
            texture: Some(Texture::Bitmap(Arc::new(sky()))),
        },
        Emitter::Projector {
            to_world: Mat4::from_translation(Vec3::new(-0.5, 0.2, 2.5))
                * Mat4::from_rotation_y(2.9),
            irradiance: Texture::Bitmap(Arc::new(sky())),
            scale: 2.5,
            fov_x: 70.0,
        },
        Emitter::Directional {
            direction: Vec3::new(0.3, -1.0, 0.2),
            irradiance: Spectrum::new(1.0, 0.9, 0.8),
        },
        Emitter::Constant {
            radiance: Spectrum::new(0.1, 0.2, 0.3),
        },
        Emitter::EnvMap {
            image: Arc::new(sky()),
            to_world: Mat4::from_rotation_y(0.4),
            scale: 1.5,
            filename: PathBuf::from("sky.exr"),
        },
    ];
    LightSet::new(&[], &emitters, &[], (Vec3::splat(-1.0), Vec3::splat(1.0))).unwrap()
}

#[test]
fn sample_x_is_sample_per_lane() {
    let ls = light_set();
    let n = ls.lights.len();
    let spot_pos = Vec3::new(0.0, 2.0, 0.0);
    let mut rng = Pcg32::new(12, 4);
    for round in 0..400 {
        let (mut p, mut u) = (V3x::ZERO, V2x::ZERO);
        let mut u_sel = [0f32; 16];
        let mut chosen = [0u32; 16];
        let mut want = M16::splat(false);
        for l in 0..16 {
            let k = round * 16 + l;
            let pl = match k % 9 {
                // On the point light, on the spot light, far away.
                0 => Vec3::new(0.5, 1.0, -0.5),
                1 => spot_pos,
                2 => Vec3::splat(1e3),
                _ => Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 6.0 - 3.0,
            };
            p.set(l, pl);
            u.set(l, rng.next_2d());
            u_sel[l] = if k % 11 == 0 {
                0.999_999_9
            } else {
                rng.next_f32()
            };
            chosen[l] = ls.select(u_sel[l]) as u32;
            want.0[l] = k % 7 != 3;
        }
        let (s, ok) = ls.sample_x(p, &chosen, want, u);
        for l in 0..16 {
            if !want.0[l] {
                assert!(!ok.0[l]);
                continue;
            }
            let want_s = ls.sample(p.get(l), u_sel[l], u.get(l));
            let what = format!("light {} of {n}, p = {}", chosen[l], p.get(l));
            assert_eq!(ok.0[l], want_s.is_some(), "{what}");
            if let Some(w) = want_s {
                assert_eq!(bits3(s.wi.get(l)), bits3(w.wi), "{what}");
                assert_eq!(s.dist.0[l].to_bits(), w.dist.to_bits(), "{what}");
                assert_eq!(bits3(s.n_geo.get(l)), bits3(w.n_geo), "{what}");
                assert_eq!(bits3(s.weight.get(l)), bits3(w.weight), "{what}");
                assert_eq!(s.pdf.0[l].to_bits(), w.pdf.to_bits(), "{what}");
                assert_eq!(s.delta.0[l], w.delta, "{what}");
            }
        }
    }
}

/// The spot light's three regions (inside the beam, the transition band, outside the cutoff)
/// all occur among the reference points, so the test above covers each branch.
#[test]
fn spot_regions_are_all_reached() {
    let ls = light_set();
    let spot = ls
        .lights
        .iter()
        .position(|l| matches!(l, Light::Spot(_)))
        .unwrap();
    let u_sel = (spot as f32 + 0.5) / ls.lights.len() as f32;
    let mut seen = [false; 3];
    let mut rng = Pcg32::new(12, 4);
    for _ in 0..4000 {
        let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 6.0 - 3.0;
        match ls.sample(p, u_sel, Vec2::ZERO) {
            None => seen[2] = true,
            Some(s) => {
                let d2 = (Vec3::new(0.0, 2.0, 0.0) - p).length_squared();
                let full = 5.0 / d2 * ls.lights.len() as f32;
                seen[((s.weight.x - full).abs() > 1e-4 * full) as usize] = true;
            }
        }
    }
    assert_eq!(seen, [true; 3]);
}

#[test]
fn eval_infinite_x_is_eval_infinite_per_lane() {
    let ls = light_set();
    assert_eq!(ls.infinite_count(), 2);
    let mut rng = Pcg32::new(1, 99);
    for round in 0..200 {
        let mut d = V3x::ZERO;
        for l in 0..16 {
            let v = match (round * 16 + l) % 13 {
                0 => Vec3::ZERO,
                1 => Vec3::NAN,
                2 => Vec3::Y,
                3 => -Vec3::Y,
                _ => (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0)
                    .normalize_or_zero(),
            };
            d.set(l, v);
        }
        for k in 0..ls.infinite_count() {
            let (le, pdf) = ls.eval_infinite_x(k, d);
            for l in 0..16 {
                let (sle, spdf) = ls.eval_infinite(k, d.get(l));
                assert_eq!(bits3(le.get(l)), bits3(sle), "d = {}", d.get(l));
                assert_eq!(pdf.0[l].to_bits(), spdf.to_bits());
            }
        }
    }
}
