//! The batched BSDF interface against the scalar code, lane by lane and bit for bit: every BSDF
//! kind with SoA twins (and its textures looked up 16 lanes at a time), on random queries with
//! the degenerate inputs the scalar branches exist for (directions below and on the horizon, at
//! the pole, sample numbers at 0 and near 1).

use crate::bsdf::batch::{BsdfBatch, L};
use crate::bsdf::texture::{BitmapTexture, Checkerboard, TexFilter, UvTransform, Wrap};
use crate::bsdf::*;
use crate::io::RgbImage;
use crate::math::simd::f16::{F16, M16, V2x, V3x};
use crate::math::{Pcg32, warp};
use std::sync::Arc;

fn bits(v: Vec3) -> [u32; 3] {
    v.to_array().map(f32::to_bits)
}

/// A 5×3 image of random colours in [lo, hi).
fn image(rng: &mut Pcg32, lo: f32, hi: f32) -> RgbImage {
    let mut img = RgbImage::new(5, 3);
    for y in 0..3 {
        for x in 0..5 {
            let mut c = || lo + (hi - lo) * rng.next_f32();
            img.set(x, y, [c(), c(), c()]);
        }
    }
    img
}

/// A textured parameter in [lo, hi): bitmap (bilinear, repeat), mapped (nearest, mirror, with a
/// `to_uv`), or a checkerboard of a constant and a bitmap, by `k`.
fn texture(rng: &mut Pcg32, k: usize, lo: f32, hi: f32) -> Texture {
    match k % 3 {
        0 => Texture::Bitmap(Arc::new(image(rng, lo, hi))),
        1 => Texture::Mapped(Arc::new(BitmapTexture::new(
            image(rng, lo, hi),
            if k.is_multiple_of(2) {
                TexFilter::Bilinear
            } else {
                TexFilter::Nearest
            },
            [Wrap::Mirror, Wrap::Clamp, Wrap::Repeat][k % 3],
            UvTransform([1.7, 0.3, 0.1, -0.2, 2.5, 0.4]),
        ))),
        _ => Texture::Checkerboard(Arc::new(Checkerboard {
            color0: Texture::Constant(Spectrum::splat(0.5 * (lo + hi))),
            color1: Texture::Bitmap(Arc::new(image(rng, lo, hi))),
            to_uv: UvTransform([4.0, 0.0, 0.0, 0.0, 3.0, 0.0]),
        })),
    }
}

/// The BSDFs with SoA twins, in the variants their branches distinguish.
fn bsdfs(rng: &mut Pcg32) -> Vec<Bsdf> {
    use MicrofacetType::{Beckmann, Ggx};
    let mut out = Vec::new();
    let c = |v: f32| Texture::Constant(Spectrum::splat(v));
    out.push(Bsdf::Conductor(Conductor {
        eta: Texture::Constant(Spectrum::new(0.2, 0.92, 1.1)),
        k: Texture::Constant(Spectrum::new(3.9, 2.45, 2.14)),
        specular_reflectance: texture(rng, 2, 0.2, 1.0),
    }));
    for (k, (kind, visible)) in [
        (Ggx, true),
        (Beckmann, true),
        (Ggx, false),
        (Beckmann, false),
    ]
    .into_iter()
    .enumerate()
    {
        let anisotropic = k.is_multiple_of(2);
        out.push(Bsdf::RoughConductor(RoughConductor {
            distribution: kind,
            alpha_u: if anisotropic {
                texture(rng, k, 0.02, 0.6)
            } else {
                c(0.3)
            },
            alpha_v: c(if anisotropic { 0.1 } else { 0.3 }),
            eta: texture(rng, k + 1, 0.1, 1.5),
            k: Texture::Constant(Spectrum::new(3.9, 2.45, 2.14)),
            specular_reflectance: texture(rng, k + 2, 0.3, 1.0),
            sample_visible: visible,
        }));
        out.push(Bsdf::RoughDielectric(RoughDielectric {
            distribution: kind,
            alpha_u: if anisotropic {
                texture(rng, k, 0.02, 0.6)
            } else {
                c(0.25)
            },
            alpha_v: c(if anisotropic { 0.4 } else { 0.25 }),
            eta: [1.5, 0.7, 1.33, 2.4][k],
            specular_reflectance: c(1.0),
            specular_transmittance: texture(rng, k + 1, 0.3, 1.0),
            sample_visible: visible,
        }));
        out.push(Bsdf::RoughPlastic(RoughPlastic::new(
            kind,
            [0.1, 0.3, 0.05, 0.6][k],
            [1.49, 1.9, 1.2, 1.49][k],
            texture(rng, k, 0.0, 0.9),
            if k == 1 {
                texture(rng, 2, 0.5, 1.0)
            } else {
                c(1.0)
            },
            k == 2,
            visible,
        )));
    }
    for (k, eta) in [1.5f32, 0.7, 1.0].into_iter().enumerate() {
        out.push(Bsdf::Dielectric(Dielectric {
            eta,
            specular_reflectance: c(1.0),
            specular_transmittance: texture(rng, k, 0.4, 1.0),
        }));
        out.push(Bsdf::Plastic(Plastic::new(
            eta,
            texture(rng, k + 1, 0.0, 0.9),
            c(1.0),
            k == 1,
        )));
    }
    out
}

/// A random query per lane; every few lanes a degenerate direction or sample number.
fn query(rng: &mut Pcg32, round: usize, l: usize) -> (Vec3, Vec3, Vec2, f32, Vec2) {
    let mut a = warp::square_to_uniform_sphere(rng.next_2d());
    let mut b = warp::square_to_uniform_sphere(rng.next_2d());
    match (round + l) % 9 {
        0 => a.z = 0.0,
        1 => b.z = 0.0,
        2 => a = Vec3::Z,
        3 => a.z = -a.z.abs(),
        4 => b = Vec3::new(-a.x, -a.y, a.z),
        5 => a = Vec3::new(a.x, a.y, 1e-4).normalize(),
        _ => {}
    }
    if (round + l).is_multiple_of(3) {
        b.z = b.z.abs();
    }
    if (round + l) % 4 == 1 {
        a.z = a.z.abs();
    }
    let uv = Vec2::new(rng.next_f32() * 3.0 - 1.0, rng.next_f32() * 2.0);
    let u1 = match l {
        5 => 0.0,
        6 => 1.0 - f32::EPSILON,
        _ => rng.next_f32(),
    };
    let u2 = match l {
        7 => Vec2::ZERO,
        8 => Vec2::splat(1.0 - f32::EPSILON),
        _ => rng.next_2d(),
    };
    (a, b, uv, u1, u2)
}

/// Runs `bsdfs` through a batch (lanes of the first one's kind, each lane's own BSDF in
/// `own`) and checks every lane against the scalar code.
fn check(batch_bsdf: &Bsdf, own: &[&Bsdf; L], rng: &mut Pcg32, rounds: usize, name: &str) {
    for round in 0..rounds {
        let mut batch = BsdfBatch::new(batch_bsdf);
        let (mut wi, mut wo, mut uv) = (V3x::ZERO, V3x::ZERO, V2x::ZERO);
        let (mut u1, mut u2) = (F16::splat(0.0), V2x::ZERO);
        let mut delta = M16::splat(false);
        let mut si = Vec::new();
        let mut smooth = [false; L];
        for l in 0..L {
            let (a, b, t, s1, s2) = query(rng, round, l);
            wi.set(l, a);
            wo.set(l, b);
            uv.set(l, t);
            u1.0[l] = s1;
            u2.set(l, s2);
            delta.0[l] = (round + l).is_multiple_of(5);
            let s = SurfaceInteraction::for_tests(a, t);
            smooth[l] = batch.start_lane(l, own[l], a, t, || s);
            si.push(s);
        }
        batch.prepare(u16::MAX, &wi, &uv);
        let (f, pdf) = batch.eval_for_light(M16::splat(true), wi, wo, delta, |l| si[l]);
        let bs = batch.sample(wi, u1, u2, |l| si[l]);
        for (l, s) in si.iter().enumerate() {
            let at = own[l].at(s);
            assert_eq!(smooth[l], at.flags().has(BsdfFlags::SMOOTH), "{name}");
            let (sf, spdf) = at.eval_for_light(s, wo.get(l), delta.0[l]);
            let what = format!(
                "{name} round {round} lane {l}: wi {} wo {}",
                s.wi,
                wo.get(l)
            );
            assert_eq!(bits(f.get(l)), bits(sf), "eval, {what}");
            assert_eq!(pdf.0[l].to_bits(), spdf.to_bits(), "pdf, {what}");
            match own[l].sample(s, u1.0[l], u2.get(l)) {
                None => assert!(!bs.ok.0[l], "sample should fail, {what}"),
                Some((b, w)) => {
                    assert!(bs.ok.0[l], "sample should succeed, {what}");
                    assert_eq!(bits(bs.wo.get(l)), bits(b.wo), "sample wo, {what}");
                    assert_eq!(bs.pdf.0[l].to_bits(), b.pdf.to_bits(), "sample pdf, {what}");
                    assert_eq!(bits(bs.weight.get(l)), bits(w), "sample weight, {what}");
                    assert_eq!(bs.eta.0[l].to_bits(), b.eta.to_bits(), "sample eta, {what}");
                    assert_eq!(bs.delta.0[l], b.sampled.has(BsdfFlags::DELTA), "{what}");
                }
            }
        }
    }
}

#[test]
fn soa_twins_match_the_scalar_bsdfs() {
    let mut rng = Pcg32::new(11, 3);
    for (k, b) in bsdfs(&mut rng).iter().enumerate() {
        check(b, &[b; L], &mut rng, 120, &format!("bsdf {k} {b:?}"));
    }
}

#[test]
fn diffuse_batches_look_up_each_lanes_texture() {
    // A diffuse batch holds lanes of several diffuse BSDFs: textures shared by many lanes are
    // looked up 16 at a time, the others lane by lane; all must be the scalar albedos.
    let mut rng = Pcg32::new(5, 1);
    let d = |t: Texture| Bsdf::Diffuse(Diffuse { reflectance: t });
    let many = d(texture(&mut rng, 0, 0.0, 1.0));
    let few = d(texture(&mut rng, 1, 0.0, 1.0));
    let checker = d(texture(&mut rng, 2, 0.0, 1.0));
    let plain = d(Texture::Constant(Spectrum::new(0.2, 0.5, 0.7)));
    let two =
        Bsdf::TwoSided(TwoSided::new(d(texture(&mut rng, 2, 0.0, 1.0)), few.clone()).unwrap());
    let mut own = [&many; L];
    for (l, o) in own.iter_mut().enumerate() {
        *o = match l % 8 {
            0 | 3 | 5 => &many,
            1 => &few,
            2 | 6 => &checker,
            4 => &two,
            _ => &plain,
        };
    }
    check(&many, &own, &mut rng, 200, "diffuse mix");
}

#[test]
fn textures_look_up_16_lanes_as_the_scalar_code() {
    let mut rng = Pcg32::new(9, 4);
    for k in 0..9 {
        let t = texture(&mut rng, k, -0.5, 2.0);
        for _ in 0..50 {
            let mut uv = V2x::ZERO;
            for l in 0..L {
                let v = Vec2::new(rng.next_f32() * 8.0 - 4.0, rng.next_f32() * 8.0 - 4.0);
                uv.set(l, if l == 3 { Vec2::new(f32::NAN, 1e30) } else { v });
            }
            let x = t.eval_x(uv);
            let x1 = t.eval_1_t::<F16>(uv.into());
            for l in 0..L {
                assert_eq!(bits(x.get(l)), bits(t.eval(uv.get(l))), "texture {k}");
                assert_eq!(x1.0[l].to_bits(), t.eval_1(uv.get(l)).to_bits());
            }
        }
    }
}
