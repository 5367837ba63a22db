//! Agreement with Mitsuba 3 itself: `reference-images/bsdf_golden.txt` holds eval/pdf/sample
//! results of Mitsuba 3.9.1's own plugins (variant `scalar_rgb`, made by
//! `reference-images/bsdf_golden.py`) at fixed directions and random numbers; every line must be
//! reproduced by our models.

use super::texture::{Checkerboard, UvTransform};
use super::*;

const GOLDEN: &str = include_str!("../../reference-images/bsdf_golden.txt");

const GOLD_ETA: Spectrum = Spectrum::new(0.143, 0.374, 1.442);
const GOLD_K: Spectrum = Spectrum::new(3.983, 2.385, 1.603);

fn c(r: f32, g: f32, b: f32) -> Texture {
    Texture::Constant(Spectrum::new(r, g, b))
}

fn rough(alpha_u: f32, alpha_v: f32, sample_visible: bool) -> Bsdf {
    rough_with(MicrofacetType::Ggx, alpha_u, alpha_v, sample_visible)
}

fn rough_with(distribution: MicrofacetType, alpha_u: f32, alpha_v: f32, vis: bool) -> Bsdf {
    Bsdf::RoughConductor(RoughConductor {
        distribution,
        alpha_u: Texture::uniform(alpha_u),
        alpha_v: Texture::uniform(alpha_v),
        eta: Texture::Constant(GOLD_ETA),
        k: Texture::Constant(GOLD_K),
        specular_reflectance: c(0.9, 0.8, 0.7),
        sample_visible: vis,
    })
}

/// The configurations of `bsdf_golden.py`, by name.
fn config(name: &str) -> Bsdf {
    match name {
        "diffuse" => Bsdf::Diffuse(Diffuse {
            reflectance: c(0.2, 0.5, 0.8),
        }),
        "rough_iso_vis" => rough(0.3, 0.3, true),
        "rough_aniso_vis" => rough(0.5, 0.1, true),
        "rough_aniso_novis" => rough(0.12, 0.45, false),
        "rough_iso_novis" => rough(0.2, 0.2, false),
        "conductor_gold" => Bsdf::Conductor(Conductor {
            eta: Texture::Constant(GOLD_ETA),
            k: Texture::Constant(GOLD_K),
            specular_reflectance: c(1.0, 0.9, 0.8),
        }),
        "conductor_none" => Bsdf::Conductor(Conductor {
            eta: Texture::Constant(Spectrum::ZERO),
            k: Texture::Constant(Spectrum::ONE),
            specular_reflectance: c(1.0, 1.0, 1.0),
        }),
        "dielectric" => Bsdf::Dielectric(Dielectric {
            eta: 1.5,
            specular_reflectance: c(1.0, 1.0, 1.0),
            specular_transmittance: c(1.0, 1.0, 1.0),
        }),
        "dielectric_tinted" => Bsdf::Dielectric(Dielectric {
            eta: 1.33,
            specular_reflectance: c(0.5, 0.6, 0.7),
            specular_transmittance: c(0.9, 0.3, 0.4),
        }),
        "thindielectric" => Bsdf::ThinDielectric(ThinDielectric {
            eta: 1.5,
            specular_reflectance: c(1.0, 1.0, 1.0),
            specular_transmittance: c(0.9, 0.8, 0.7),
        }),
        "twosided_rough" => Bsdf::TwoSided(
            TwoSided::new(
                rough(0.3, 0.1, true),
                Bsdf::Diffuse(Diffuse {
                    reflectance: c(0.3, 0.2, 0.1),
                }),
            )
            .unwrap(),
        ),
        "plastic" => Bsdf::Plastic(Plastic::new(
            1.49 / 1.000277,
            c(0.2, 0.5, 0.8),
            c(1.0, 1.0, 1.0),
            false,
        )),
        "plastic_nonlinear" => {
            Bsdf::Plastic(Plastic::new(1.7, c(0.6, 0.3, 0.1), c(0.8, 0.9, 1.0), true))
        }
        "roughplastic" => Bsdf::RoughPlastic(RoughPlastic::new(
            MicrofacetType::Ggx,
            0.2,
            1.49 / 1.000277,
            c(0.2, 0.5, 0.8),
            c(1.0, 1.0, 1.0),
            false,
            true,
        )),
        "roughplastic_nonlinear_novis" => Bsdf::RoughPlastic(RoughPlastic::new(
            MicrofacetType::Ggx,
            0.45,
            1.7,
            c(0.6, 0.3, 0.1),
            c(0.8, 0.9, 1.0),
            true,
            false,
        )),
        "roughdielectric" => Bsdf::RoughDielectric(RoughDielectric {
            distribution: MicrofacetType::Ggx,
            alpha_u: c(0.25, 0.25, 0.25),
            alpha_v: c(0.25, 0.25, 0.25),
            eta: 1.5,
            specular_reflectance: c(1.0, 1.0, 1.0),
            specular_transmittance: c(1.0, 1.0, 1.0),
            sample_visible: true,
        }),
        "roughdielectric_aniso_novis" => Bsdf::RoughDielectric(RoughDielectric {
            distribution: MicrofacetType::Ggx,
            alpha_u: c(0.4, 0.4, 0.4),
            alpha_v: c(0.1, 0.1, 0.1),
            eta: 1.33,
            specular_reflectance: c(0.5, 0.6, 0.7),
            specular_transmittance: c(0.9, 0.3, 0.4),
            sample_visible: false,
        }),
        "blend" => Bsdf::Blend(BlendBsdf {
            weight: c(0.3, 0.3, 0.3),
            bsdfs: Box::new([
                rough(0.3, 0.3, true),
                Bsdf::Diffuse(Diffuse {
                    reflectance: c(0.3, 0.2, 0.1),
                }),
            ]),
        }),
        "mask" => Bsdf::Mask(Mask {
            opacity: c(0.35, 0.35, 0.35),
            nested: Box::new(Bsdf::RoughPlastic(RoughPlastic::new(
                MicrofacetType::Ggx,
                0.1,
                1.49 / 1.000277,
                c(0.1, 0.6, 0.3),
                c(1.0, 1.0, 1.0),
                false,
                true,
            ))),
        }),
        "normalmap" => Bsdf::NormalMap(NormalMap {
            normalmap: c(0.7, 0.35, 0.9),
            nested: Box::new(Bsdf::RoughPlastic(RoughPlastic::new(
                MicrofacetType::Ggx,
                0.2,
                1.49 / 1.000277,
                c(0.5, 0.3, 0.2),
                c(1.0, 1.0, 1.0),
                false,
                true,
            ))),
            flip_invalid_normals: true,
            use_shadowing_function: true,
        }),
        "normalmap_rough" => Bsdf::NormalMap(NormalMap {
            normalmap: c(0.2, 0.6, 0.8),
            nested: Box::new(rough(0.3, 0.1, true)),
            flip_invalid_normals: true,
            use_shadowing_function: true,
        }),
        _ => beckmann_config(name),
    }
}

/// `bsdf_golden.py`'s 4×3 raw RGB height image (row 0 at v = 0, as both lay it out).
fn bump_texels() -> Texture {
    let mut img = crate::io::RgbImage::new(4, 3);
    for j in 0..3 {
        for i in 0..4 {
            let v = 0.1 + 0.2 * ((3 * i + 5 * j) % 7) as f64 / 7.0;
            img.set(i, j, [v as f32, (0.8 * v) as f32, (1.3 * v) as f32]);
        }
    }
    Texture::Bitmap(std::sync::Arc::new(img))
}

fn bump(nested: Bsdf, scale: f32) -> Bsdf {
    Bsdf::BumpMap(BumpMap {
        height: bump_texels(),
        scale,
        nested: Box::new(nested),
        flip_invalid_normals: true,
        use_shadowing_function: true,
    })
}

/// The Beckmann configurations (Mitsuba's default distribution) and the bump maps.
fn beckmann_config(name: &str) -> Bsdf {
    const B: MicrofacetType = MicrofacetType::Beckmann;
    match name {
        "beckmann_rough_iso_vis" => rough_with(B, 0.3, 0.3, true),
        "beckmann_rough_aniso_vis" => rough_with(B, 0.5, 0.1, true),
        "beckmann_rough_aniso_novis" => rough_with(B, 0.12, 0.45, false),
        "beckmann_rough_iso_novis" => rough_with(B, 0.2, 0.2, false),
        "beckmann_rough_smooth_vis" => rough_with(B, 0.03, 0.03, true),
        "beckmann_roughplastic" => Bsdf::RoughPlastic(RoughPlastic::new(
            B,
            0.2,
            1.49 / 1.000277,
            c(0.2, 0.5, 0.8),
            c(1.0, 1.0, 1.0),
            false,
            true,
        )),
        "beckmann_roughplastic_nonlinear_novis" => Bsdf::RoughPlastic(RoughPlastic::new(
            B,
            0.45,
            1.7,
            c(0.6, 0.3, 0.1),
            c(0.8, 0.9, 1.0),
            true,
            false,
        )),
        "beckmann_roughdielectric" => Bsdf::RoughDielectric(RoughDielectric {
            distribution: B,
            alpha_u: c(0.25, 0.25, 0.25),
            alpha_v: c(0.25, 0.25, 0.25),
            eta: 1.5,
            specular_reflectance: c(1.0, 1.0, 1.0),
            specular_transmittance: c(1.0, 1.0, 1.0),
            sample_visible: true,
        }),
        "beckmann_roughdielectric_aniso_novis" => Bsdf::RoughDielectric(RoughDielectric {
            distribution: B,
            alpha_u: c(0.4, 0.4, 0.4),
            alpha_v: c(0.1, 0.1, 0.1),
            eta: 1.33,
            specular_reflectance: c(0.5, 0.6, 0.7),
            specular_transmittance: c(0.9, 0.3, 0.4),
            sample_visible: false,
        }),
        "bumpmap_roughplastic" => bump(
            Bsdf::RoughPlastic(RoughPlastic::new(
                B,
                0.2,
                1.49 / 1.000277,
                c(0.5, 0.3, 0.2),
                c(1.0, 1.0, 1.0),
                false,
                true,
            )),
            0.3,
        ),
        "bumpmap_rough_aniso" => bump(rough(0.3, 0.1, true), 0.5),
        _ => textured_config(name),
    }
}

/// `bsdf_golden.py`'s `texels`: a 4×3 raw image, value (i, j) = f(i, j) × scales per channel.
pub(super) fn texels(f: impl Fn(usize, usize) -> f64, scales: [f64; 3]) -> Texture {
    let mut img = crate::io::RgbImage::new(4, 3);
    for j in 0..3 {
        for i in 0..4 {
            let v = f(i, j);
            img.set(i, j, scales.map(|s| (s * v) as f32));
        }
    }
    Texture::Bitmap(std::sync::Arc::new(img))
}

fn alpha_texels() -> Texture {
    texels(
        |i, j| 0.05 + 0.5 * ((2 * i + 3 * j) % 5) as f64 / 5.0,
        [1.0, 0.7, 1.4],
    )
}

fn eta_texels() -> Texture {
    texels(|i, j| 0.2 + 0.3 * ((i + 2 * j) % 4) as f64, [1.0, 1.5, 0.6])
}

fn k_texels() -> Texture {
    texels(|i, j| 2.0 + 0.4 * ((3 * i + j) % 5) as f64, [1.0, 0.8, 0.6])
}

pub(super) fn checker(c0: f32, c1: f32) -> Texture {
    Texture::Checkerboard(std::sync::Arc::new(Checkerboard {
        color0: Texture::uniform(c0),
        color1: Texture::uniform(c1),
        to_uv: UvTransform::IDENTITY,
    }))
}

/// Textured roughness and complex IOR (Mitsuba's unbounded textures).
fn textured_config(name: &str) -> Bsdf {
    match name {
        "rough_textured_alpha" => Bsdf::RoughConductor(RoughConductor {
            distribution: MicrofacetType::Ggx,
            alpha_u: alpha_texels(),
            alpha_v: checker(0.1, 0.45),
            eta: Texture::Constant(GOLD_ETA),
            k: Texture::Constant(GOLD_K),
            specular_reflectance: c(0.9, 0.8, 0.7),
            sample_visible: true,
        }),
        "beckmann_rough_textured_novis" => Bsdf::RoughConductor(RoughConductor {
            distribution: MicrofacetType::Beckmann,
            alpha_u: alpha_texels(),
            alpha_v: alpha_texels(),
            eta: eta_texels(),
            k: k_texels(),
            specular_reflectance: c(1.0, 1.0, 1.0),
            sample_visible: false,
        }),
        "conductor_textured_ior" => Bsdf::Conductor(Conductor {
            eta: eta_texels(),
            k: k_texels(),
            specular_reflectance: c(1.0, 1.0, 1.0),
        }),
        "roughdielectric_checker_alpha" => Bsdf::RoughDielectric(RoughDielectric {
            distribution: MicrofacetType::Ggx,
            alpha_u: checker(0.1, 0.45),
            alpha_v: checker(0.1, 0.45),
            eta: 1.5,
            specular_reflectance: c(1.0, 1.0, 1.0),
            specular_transmittance: c(1.0, 1.0, 1.0),
            sample_visible: true,
        }),
        other => panic!("golden file names an unknown configuration {other}"),
    }
}

/// Our flags for Mitsuba 3's `BSDFFlags` bits (Null = 1 is our straight-through transmission).
fn flags_from_mitsuba(bits: u32) -> BsdfFlags {
    match bits {
        1 | 64 => BsdfFlags::DELTA_TRANSMISSION,
        2 => BsdfFlags::DIFFUSE_REFLECTION,
        4 => BsdfFlags::DIFFUSE_TRANSMISSION,
        8 => BsdfFlags::GLOSSY_REFLECTION,
        16 => BsdfFlags::GLOSSY_TRANSMISSION,
        32 => BsdfFlags::DELTA_REFLECTION,
        _ => BsdfFlags(u32::MAX),
    }
}

fn close(a: f32, b: f32, rel: f32) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()) + 1e-6
}

fn close3(a: Vec3, b: Vec3, rel: f32) -> bool {
    close(a.x, b.x, rel) && close(a.y, b.y, rel) && close(a.z, b.z, rel)
}

#[test]
fn matches_mitsuba3_plugins() {
    let (n_config, n_eval, n_sample) = check_golden(GOLDEN, config);
    assert!(n_config == 36 && n_eval > 400 && n_sample > 300);
}

/// Checks every line of a golden file in `bsdf_golden.py`'s format against the configurations
/// `config` builds by name; returns the numbers of configurations, evals and samples.
pub(super) fn check_golden(text: &str, config: fn(&str) -> Bsdf) -> (usize, usize, usize) {
    let mut configs: Vec<(String, Bsdf)> = Vec::new();
    let (mut n_eval, mut n_sample) = (0, 0);
    let mut failures = Vec::new();
    // Largest relative differences of eval and pdf (over values above 1e-3).
    let (mut max_eval, mut max_pdf) = (0.0f32, 0.0f32);
    let rel = |a: f32, b: f32| {
        if a.abs().max(b.abs()) > 1e-3 {
            (a - b).abs() / a.abs().max(b.abs())
        } else {
            0.0
        }
    };
    for (ln, line) in text.lines().enumerate() {
        let f: Vec<&str> = line.split_whitespace().collect();
        let num = |i: usize| -> f32 { f[i].parse().unwrap() };
        let v3 = |i: usize| Vec3::new(num(i), num(i + 1), num(i + 2));
        match f[0] {
            "bsdf" => {
                assert_eq!(f[1].parse::<usize>().unwrap(), configs.len());
                configs.push((f[2].to_string(), config(f[2])));
            }
            "eval" => {
                let (name, b) = &configs[f[1].parse::<usize>().unwrap()];
                let s = SurfaceInteraction::for_tests(v3(2), Vec2::new(0.3, 0.6));
                let wo = v3(5);
                let (e, p) = (b.eval(&s, wo), b.pdf(&s, wo));
                let r = v3(8);
                max_eval = max_eval.max(rel(e.x, r.x).max(rel(e.y, r.y)).max(rel(e.z, r.z)));
                max_pdf = max_pdf.max(rel(p, num(11)));
                if !close3(e, v3(8), 1e-4) || !close(p, num(11), 1e-4) {
                    failures.push(format!(
                        "line {}: {name} eval: ours {e} pdf {p}, Mitsuba {} pdf {}",
                        ln + 1,
                        v3(8),
                        num(11)
                    ));
                }
                n_eval += 1;
            }
            "sample" => {
                let (name, b) = &configs[f[1].parse::<usize>().unwrap()];
                let s = SurfaceInteraction::for_tests(v3(2), Vec2::new(0.3, 0.6));
                let r = b.sample(&s, num(5), Vec2::new(num(6), num(7)));
                let ok_ref = f[8] == "1";
                let ours = r.filter(|(bs, w)| bs.pdf > 0.0 && w.max_element() > 0.0);
                let agree = match (&ours, ok_ref) {
                    (None, false) => true,
                    (Some((bs, w)), true) => {
                        close3(bs.wo, v3(9), 1e-4)
                            && close(bs.pdf, num(12), 2e-4)
                            && close(bs.eta, num(13), 1e-6)
                            && bs.sampled == flags_from_mitsuba(f[14].parse().unwrap())
                            && close3(*w, v3(15), 2e-4)
                    }
                    _ => false,
                };
                if !agree {
                    failures.push(format!(
                        "line {}: {name} sample: ours {ours:?}, Mitsuba `{line}`",
                        ln + 1
                    ));
                }
                n_sample += 1;
            }
            other => panic!("line {}: unknown record {other}", ln + 1),
        }
    }
    println!("max relative difference to Mitsuba: eval {max_eval:e}, pdf {max_pdf:e}");
    assert!(
        failures.is_empty(),
        "{} mismatches with Mitsuba 3:\n{}",
        failures.len(),
        failures.join("\n")
    );
    (configs.len(), n_eval, n_sample)
}
