use super::bsdf::floor_fast;
use super::kernel::{pow_f4, srgb_to_linear_f4};
use super::*;
use crate::bsdf::BsdfSample;
use crate::btf::DirectionSet;
use crate::btf::directions::DirectionInterp;
use crate::geometry::SurfaceInteraction;
use crate::math::color::srgb_to_linear;
use crate::math::simd::f4::F4;
use crate::math::{Pcg32, frame::from_spherical, warp};
use crate::math::{Spectrum, Vec2, Vec3};
use crate::model::{
    BtfFile, BtfModel, Lobe, ModelKind, PackedLobe, PlmcModel, Poly, ValueSpace, ViewParams, codec,
    lobe, polynomial, resolve_model_file,
};
use std::path::Path;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::OnceLock;

fn dir(theta_deg: f32, phi_deg: f32) -> Vec3 {
    from_spherical(theta_deg.to_radians(), phi_deg.to_radians())
}

/// A random glossy lobe: D near the mirror of `v`, n in [1, 60].
fn random_lobe(rng: &mut Pcg32, v: Vec3, scale: f32) -> Lobe {
    let r = Vec3::new(-v.x, -v.y, v.z);
    let jitter = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, 0.0) * 0.3;
    let d = (r + jitter + Vec3::Z * 0.2).normalize();
    [
        scale * (0.2 + rng.next_f32()),
        d.x,
        d.y,
        d.z,
        1.0 + 59.0 * rng.next_f32() * rng.next_f32(),
    ]
}

/// A random, increasing polynomial around the identity.
fn random_poly(rng: &mut Pcg32) -> Poly {
    [
        0.02 * rng.next_f32(),
        0.8 + 0.4 * rng.next_f32(),
        0.3 * (rng.next_f32() - 0.5),
        0.1 * (rng.next_f32() - 0.5),
        0.05 * rng.next_f32(),
    ]
}

/// A small model of any kind on the UBO2003 directions (w × h texels, k clusters for PLM-C),
/// round-tripped through the file format so the tests read what a file holds.
fn model(kind: ModelKind, space: ValueSpace, w: usize, h: usize, k: usize, seed: u64) -> PlmcModel {
    let set = DirectionSet::ubo2003();
    let mut rng = Pcg32::new(seed, 7);
    let texels = w * h;
    let scale = if space == ValueSpace::Srgb { 0.5 } else { 1.0 };
    let params = set
        .dirs
        .iter()
        .map(|&v| match kind {
            ModelKind::PlmC => ViewParams::Clustered {
                k,
                table: (0..3 * k)
                    .map(|_| PackedLobe::pack(&random_lobe(&mut rng, v, scale)))
                    .collect(),
                index: (0..3 * texels)
                    .map(|_| rng.next_below(k as u32) as u16)
                    .collect(),
            },
            _ => ViewParams::Texel(
                (0..3 * texels)
                    .map(|_| PackedLobe::pack(&random_lobe(&mut rng, v, scale)))
                    .collect(),
            ),
        })
        .collect();
    let polys = if kind.has_polys() {
        (0..81 * 81 * 3).map(|_| random_poly(&mut rng)).collect()
    } else {
        Vec::new()
    };
    let m = PlmcModel {
        kind,
        views: set.clone(),
        lights: set,
        width: w,
        height: h,
        clusters: if kind == ModelKind::PlmC { k } else { 0 },
        space,
        params,
        polys,
    };
    let bytes = codec::to_bytes(&m).unwrap();
    codec::from_bytes(&bytes, Path::new("test.plmc")).unwrap()
}

struct Fixture {
    model: PlmcModel,
    /// The material as built (the AVX-512 or AVX2+FMA kernel where the CPU has it).
    bsdf: PlmcBsdf,
    /// The same model without the AVX-512 kernel (AVX2+FMA where the CPU has it).
    avx2: PlmcBsdf,
    /// The same model forced onto the baseline SSE2 kernel.
    sse2: PlmcBsdf,
}

fn fixture(kind: ModelKind, space: ValueSpace) -> &'static Fixture {
    static F: OnceLock<Vec<(ModelKind, ValueSpace, Fixture)>> = OnceLock::new();
    let all = F.get_or_init(|| {
        let mut v = Vec::new();
        for (i, (kind, space)) in [
            (ModelKind::PlmC, ValueSpace::Linear),
            (ModelKind::PlmC, ValueSpace::Srgb),
            (ModelKind::Plm, ValueSpace::Linear),
            (ModelKind::Lm, ValueSpace::Linear),
        ]
        .into_iter()
        .enumerate()
        {
            let model = model(kind, space, 5, 3, 7, 11 + i as u64);
            let mat = Arc::new(PlmcMaterial::new(&model).unwrap());
            let bsdf = PlmcBsdf::new(mat, 1.0, false).unwrap();
            let plain = Arc::new(PlmcMaterial::new(&model).unwrap().without_avx2());
            assert!(!plain.uses_avx2());
            let sse2 = PlmcBsdf::new(plain, 1.0, false).unwrap();
            let no512 = Arc::new(PlmcMaterial::new(&model).unwrap().without_avx512());
            assert!(!no512.uses_avx512());
            let avx2 = PlmcBsdf::new(no512, 1.0, false).unwrap();
            v.push((
                kind,
                space,
                Fixture {
                    model,
                    bsdf,
                    avx2,
                    sse2,
                },
            ));
        }
        v
    });
    &all.iter()
        .find(|f| f.0 == kind && f.1 == space)
        .expect("fixture exists")
        .2
}

const ALL: [(ModelKind, ValueSpace); 4] = [
    (ModelKind::PlmC, ValueSpace::Linear),
    (ModelKind::PlmC, ValueSpace::Srgb),
    (ModelKind::Plm, ValueSpace::Linear),
    (ModelKind::Lm, ValueSpace::Linear),
];

fn close(a: f32, b: f32, rel: f32) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()) + 1e-6
}

#[test]
fn fast_math_matches_libm() {
    // The kernel's lane-wise power and sRGB decode against f64 libm: relative error well below
    // the models' own error (~1e-2).
    let mut rng = Pcg32::new(5, 5);
    let mut worst = 0f32;
    for _ in 0..50_000 {
        let b: [f32; 4] =
            std::array::from_fn(|_| (-12.0 * rng.next_f32()).exp2() * (0.5 + 0.5 * rng.next_f32()));
        let n: [f32; 4] = std::array::from_fn(|_| 0.1 + 199.9 * rng.next_f32());
        let mut check = |got: [f32; 4]| {
            for k in 0..4 {
                let want = (b[k] as f64).powf(n[k] as f64);
                if want < 1e-30 {
                    continue;
                }
                worst = worst.max(((got[k] as f64 - want) / want).abs() as f32);
            }
        };
        // (Every build of the fused exp2/log2 returns the same bits: `math::simd::approx`.)
        check(pow_f4(F4::from_array(b), F4::from_array(n)).to_array());
    }
    // n · |Δlog2 b| · ln 2 with |Δlog2| ≲ 2e-7 at n = 200, plus the exp2 series.
    assert!(worst < 1e-4, "pow relative error {worst}");
    for i in 0..=2000 {
        let v = i as f32 / 1000.0 - 0.5;
        let want = srgb_to_linear(v.max(0.0));
        let got = srgb_to_linear_f4(F4::splat(v)).to_array()[0];
        assert!(close(got, want, 2e-5), "{v}");
    }
}

/// Eval at a measured view and light, at texel centres, is the fitter's own reconstruction
/// (`PlmcModel::reconstruct_view`, independent code with libm powf) over π.
#[test]
fn eval_at_measured_directions_is_the_reconstruction() {
    let set = DirectionSet::ubo2003();
    for (kind, space) in ALL {
        let f = fixture(kind, space);
        let (w, h) = (f.model.width, f.model.height);
        let mut img = Vec::new();
        for v in [0usize, 7, 40, 80] {
            f.model.reconstruct_view(v, &mut img);
            for l in [0usize, 3, 33, 79] {
                for (x, y) in [(0, 0), (4, 2), (2, 1)] {
                    let mut si = SurfaceInteraction::for_tests(
                        set.dirs[v],
                        Vec2::new((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32),
                    );
                    si.wi = set.dirs[v];
                    for b in [&f.bsdf, &f.avx2, &f.sse2] {
                        let got = b.eval(&si, set.dirs[l]) * std::f32::consts::PI;
                        let i = 3 * ((l * h + y) * w + x);
                        for c in 0..3 {
                            assert!(
                                close(got[c], img[i + c], 2e-4),
                                "{kind:?} {space:?} view {v} light {l} texel ({x},{y}) ch {c}: {} vs {} (avx2 {} avx512 {})",
                                got[c],
                                img[i + c],
                                b.material().uses_avx2(),
                                b.material().uses_avx512()
                            );
                        }
                    }
                }
            }
        }
    }
}

/// Straightforward scalar reference of the docs/model.md rendering rule, with the two range clamps.
fn reference_b(
    m: &PlmcModel,
    interp: &DirectionInterp,
    wi: Vec3,
    wo: Vec3,
    texel: usize,
) -> [f32; 3] {
    // Views and lights share the UBO2003 set here.
    let (vi, vw) = interp.lookup(wi);
    let (li, lw) = interp.lookup(wo);
    let texels = m.width * m.height;
    let mut out = [0f32; 3];
    for a in 0..3 {
        let v = vi[a] as usize;
        for c in 0..3 {
            let lobe_of = |t: usize| m.params[v].packed(t, c).unpack();
            let y = lobe::eval(&lobe_of(texel), wo);
            if !m.kind.has_polys() {
                out[c] += vw[a] * m.space.to_linear(y);
                continue;
            }
            // Clamps: Y to its largest value at the measured lights (all texels), the output
            // to the largest output at the 3 measured lights.
            let y_max = (0..texels)
                .flat_map(|t| m.lights.dirs.iter().map(move |&u| (t, u)))
                .map(|(t, u)| lobe::eval(&lobe_of(t), u))
                .fold(0f32, f32::max);
            let out_max = li
                .iter()
                .flat_map(|&l| {
                    let l = l as usize;
                    (0..texels).map(move |t| (t, l))
                })
                .map(|(t, l)| {
                    let yl = lobe::eval(&lobe_of(t), m.lights.dirs[l]);
                    polynomial::eval(&m.poly(v, l, c), yl).max(0.0)
                })
                .fold(0f32, f32::max);
            let mut poly = [0f32; 5];
            for b in 0..3 {
                let p = m.poly(v, li[b] as usize, c);
                for j in 0..5 {
                    poly[j] += lw[b] * p[j];
                }
            }
            let o = polynomial::eval(&poly, y.min(y_max)).min(out_max);
            out[c] += vw[a] * m.space.to_linear(o);
        }
    }
    out
}

#[test]
fn eval_between_directions_matches_the_scalar_reference() {
    let mut rng = Pcg32::new(9, 1);
    let interp = DirectionSet::ubo2003().interpolator().unwrap();
    for (kind, space) in ALL {
        let f = fixture(kind, space);
        let (w, h) = (f.model.width, f.model.height);
        for _ in 0..500 {
            let wi = warp::square_to_uniform_hemisphere(rng.next_2d());
            let wo = warp::square_to_uniform_hemisphere(rng.next_2d());
            let uv = rng.next_2d();
            let si = SurfaceInteraction::for_tests(wi, uv);
            let (x, y) = f.bsdf.texel(uv);
            let want = reference_b(&f.model, &interp, wi, wo, y * w + x);
            for b in [&f.bsdf, &f.avx2, &f.sse2] {
                let got = b.eval(&si, wo) * std::f32::consts::PI;
                for c in 0..3 {
                    assert!(
                        close(got[c], want[c], 3e-4),
                        "{kind:?} {space:?} wi {wi} wo {wo}: {got} vs {want:?} (avx2 {} avx512 {})",
                        b.material().uses_avx2(),
                        b.material().uses_avx512()
                    );
                }
            }
            assert!(x < w && y < h);
        }
    }
}

#[test]
fn one_sided_and_sample_consistent_with_eval_and_pdf() {
    let f = fixture(ModelKind::PlmC, ValueSpace::Linear);
    let b = &f.bsdf;
    let up = dir(30.0, 10.0);
    let down = Vec3::new(up.x, up.y, -up.z);
    let s_up = SurfaceInteraction::for_tests(up, Vec2::new(0.3, 0.6));
    let s_down = SurfaceInteraction::for_tests(down, Vec2::new(0.3, 0.6));
    assert_eq!(b.eval(&s_up, down), Spectrum::ZERO);
    assert_eq!(b.eval(&s_down, up), Spectrum::ZERO);
    assert_eq!(b.pdf(&s_down, up), 0.0);
    assert_eq!(b.pdf(&s_up, down), 0.0);
    assert_eq!(b.eval_pdf(&s_up, down), (Spectrum::ZERO, 0.0));
    assert!(b.sample(&s_down, 0.5, Vec2::splat(0.5)).is_none());
    let mut rng = Pcg32::new(3, 4);
    for _ in 0..2000 {
        let wi = warp::square_to_uniform_hemisphere(rng.next_2d());
        let s = SurfaceInteraction::for_tests(wi, rng.next_2d());
        let Some((smp, weight)) = b.sample(&s, rng.next_f32(), rng.next_2d()) else {
            continue;
        };
        let pdf = b.pdf(&s, smp.wo);
        assert_eq!(b.eval_pdf(&s, smp.wo), (b.eval(&s, smp.wo), pdf));
        assert!((smp.pdf - pdf).abs() <= 1e-4 * pdf);
        let want = b.eval(&s, smp.wo) / pdf;
        assert!((weight - want).length() <= 1e-4 * want.length() + 1e-7);
    }
    let dbg = format!("{b:?}");
    assert!(dbg.contains("clusters: 7") && dbg.len() < 400, "{dbg}");
}

#[test]
fn bilinear_filter_interpolates_between_texel_centres() {
    let f = fixture(ModelKind::PlmC, ValueSpace::Linear);
    let lin = PlmcBsdf::new(f.bsdf.material().clone(), 1.0, true).unwrap();
    let (w, h) = (5.0, 3.0);
    let wi = dir(20.0, 30.0);
    let wo = dir(40.0, 200.0);
    let at = |b: &PlmcBsdf, u: f32, v: f32| {
        b.eval(&SurfaceInteraction::for_tests(wi, Vec2::new(u, v)), wo)
    };
    // At a texel centre: that texel alone.
    let c = at(&lin, 2.5 / w, 1.5 / h);
    assert!((c - at(&f.bsdf, 2.5 / w, 1.5 / h)).length() < 1e-6);
    // Half-way between two centres in u: their mean; across the tile border: wraps.
    let mid = at(&lin, 3.0 / w, 1.5 / h);
    let want = 0.5 * (at(&f.bsdf, 2.5 / w, 1.5 / h) + at(&f.bsdf, 3.5 / w, 1.5 / h));
    assert!((mid - want).length() < 1e-5 * want.length() + 1e-7);
    let border = at(&lin, 0.0, 1.5 / h);
    let want = 0.5 * (at(&f.bsdf, 0.5 / w, 1.5 / h) + at(&f.bsdf, 4.5 / w, 1.5 / h));
    assert!((border - want).length() < 1e-5 * want.length() + 1e-7);
}

#[test]
fn chi2_sampling_matches_pdf() {
    use crate::bsdf::chi2::Chi2Test;
    let views = [
        dir(0.0, 0.0),
        dir(37.0, 101.0),
        dir(68.0, 250.0),
        dir(82.0, 33.0),
    ];
    let kinds = [
        (ModelKind::PlmC, ValueSpace::Linear),
        (ModelKind::Lm, ValueSpace::Linear),
    ];
    let t = Chi2Test {
        cos_theta_res: 20,
        phi_res: 40,
        sample_count: 100_000,
        test_count: views.len() * kinds.len(),
        ..Default::default()
    };
    for (kind, space) in kinds {
        let bsdf = crate::bsdf::Bsdf::Plmc(fixture(kind, space).bsdf.clone());
        for &wi in &views {
            let s = SurfaceInteraction::for_tests(wi, Vec2::new(0.3, 0.6));
            // Through the per-hit object (the PLM-C hit state), as the integrators call it.
            let b = bsdf.at(&s);
            assert!(matches!(b, crate::bsdf::BsdfAt::Plmc(..)));
            let mut lobe = Pcg32::new(17, 3);
            let out = t.run(
                |u1, u2| {
                    let s1 = lobe.next_f32();
                    b.sample(&s, s1, Vec2::new(u1, u2)).map(|x| x.0.wo)
                },
                |w| b.pdf(&s, w),
            );
            assert!(out.passed, "{kind:?} wi = {wi}: {}", out.message);
            // Lobe draws below the horizon are rejected: the density integrates to the
            // accepted share.
            assert!(
                (out.pdf_integral - out.accepted).abs() < 4e-3,
                "∫pdf {} vs accepted {}",
                out.pdf_integral,
                out.accepted
            );
        }
    }
}

/// ∫ eval dω over the hemisphere by a midpoint rule in (cos θ, φ).
pub(super) fn albedo_quadrature(b: &PlmcBsdf, s: &SurfaceInteraction, nt: usize) -> Spectrum {
    let np = 2 * nt;
    let mut acc = Spectrum::ZERO;
    for i in 0..nt {
        let c = (i as f32 + 0.5) / nt as f32;
        for j in 0..np {
            let p = (j as f32 + 0.5) / np as f32 * std::f32::consts::TAU;
            let st = (1.0 - c * c).sqrt();
            acc += b.eval(s, Vec3::new(st * p.cos(), st * p.sin(), c));
        }
    }
    acc * (std::f32::consts::TAU / (nt * np) as f32)
}

/// Mean and standard error of the sample weights (one channel).
fn weight_stats(b: &PlmcBsdf, s: &SurfaceInteraction, c: usize, n: usize, seed: u64) -> (f64, f64) {
    let mut rng = Pcg32::new(seed, 5);
    let (mut s1, mut s2) = (0f64, 0f64);
    for _ in 0..n {
        let w = b
            .sample(s, rng.next_f32(), rng.next_2d())
            .map_or(0.0, |x| x.1[c] as f64);
        s1 += w;
        s2 += w * w;
    }
    let mean = s1 / n as f64;
    (
        (mean),
        ((s2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt(),
    )
}

/// White furnace: an LM whose every lobe is ρ = 1, D = n̂, n = 1 is B = cos θ_l exactly (no
/// direction interpolation is involved for LM), so the albedo is 1 at every view; the sampled
/// estimate agrees within its standard error.
#[test]
fn white_lambertian_lm_furnace() {
    let set = DirectionSet::ubo2003();
    let white = PackedLobe::pack(&[1.0, 0.0, 0.0, 1.0, 1.0]);
    let m = PlmcModel {
        kind: ModelKind::Lm,
        views: set.clone(),
        lights: set,
        width: 2,
        height: 2,
        clusters: 0,
        space: ValueSpace::Linear,
        params: vec![ViewParams::Texel(vec![white; 12]); 81],
        polys: Vec::new(),
    };
    let b = PlmcBsdf::new(Arc::new(PlmcMaterial::new(&m).unwrap()), 1.0, false).unwrap();
    for wi in [
        dir(0.0, 0.0),
        dir(45.0, 20.0),
        dir(68.0, 250.0),
        dir(85.0, 10.0),
    ] {
        let s = SurfaceInteraction::for_tests(wi, Vec2::new(0.2, 0.7));
        let quad = albedo_quadrature(&b, &s, 200);
        assert!((quad - Spectrum::ONE).abs().max_element() < 2e-3, "{quad}");
        let (mean, se) = weight_stats(&b, &s, 1, 20_000, 1);
        assert!((mean - 1.0).abs() < 4.0 * se + 1e-3, "IS {mean} ± {se}");
        // The tables make sampling nearly cosine-proportional: a weight spread well below
        // uniform sampling's (≈ 0.58); not 0, since the tables' grazing band assumes the raw
        // data's extrapolation (B held beyond 75°) while this model falls like cos θ there.
        assert!(se * (20_000f64).sqrt() < 0.35, "weight std {}", se * 141.4);
    }
}

/// The model's albedo (quadrature of eval) is what importance sampling estimates, for glossy
/// clustered and polynomial models.
#[test]
fn sampled_albedo_is_the_integral_of_eval() {
    for (kind, space) in [
        (ModelKind::PlmC, ValueSpace::Srgb),
        (ModelKind::Plm, ValueSpace::Linear),
    ] {
        let b = &fixture(kind, space).bsdf;
        for wi in [dir(30.0, 40.0), dir(60.0, 200.0)] {
            let s = SurfaceInteraction::for_tests(wi, Vec2::new(0.55, 0.4));
            let quad = albedo_quadrature(b, &s, 200);
            for c in 0..3 {
                let (mean, se) = weight_stats(b, &s, c, 40_000, 2 + c as u64);
                assert!(
                    (mean - quad[c] as f64).abs() < 4.0 * se + 2e-3 * quad[c] as f64,
                    "{kind:?} {wi} ch {c}: IS {mean} ± {se} vs quadrature {}",
                    quad[c]
                );
            }
        }
    }
}

#[test]
fn model_files_resolve_by_convention_and_errors_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let plmc = model(ModelKind::PlmC, ValueSpace::Linear, 2, 2, 3, 1);
    let lm = model(ModelKind::Lm, ValueSpace::Linear, 2, 2, 0, 2);
    codec::write(&d.join("mat.plmc"), &plmc).unwrap();
    codec::write(&d.join("mat.lm.plmc"), &lm).unwrap();
    std::fs::write(d.join("mat.btfc"), b"x").unwrap();
    let r = |f: &str, m: &str| {
        BtfModel::parse(m)
            .and_then(|m| resolve_model_file(&d.join(f), Some(m)).map(|f| f.path().to_path_buf()))
    };
    assert_eq!(r("mat.plmc", "plmc").unwrap(), d.join("mat.plmc"));
    assert_eq!(r("mat.plmc", "lm").unwrap(), d.join("mat.lm.plmc"));
    assert_eq!(r("mat.lm.plmc", "plmc").unwrap(), d.join("mat.plmc"));
    assert_eq!(r("mat.btfc", "plmc").unwrap(), d.join("mat.plmc"));
    assert_eq!(r("mat.plmc", "raw").unwrap(), d.join("mat.btfc"));
    assert_eq!(r("mat.btfc", "raw").unwrap(), d.join("mat.btfc"));
    let e = r("mat.plmc", "plm").unwrap_err().to_string();
    assert!(
        e.contains("mat.plm.plmc") && e.contains("no plm data"),
        "{e}"
    );
    let e = r("other.plmc", "raw").unwrap_err().to_string();
    assert!(e.contains("other.plmc") && e.contains("other.btfc"), "{e}");
    assert!(r("mat.plmc", "pca").is_err());
    // Without a requested model a `.plmc` file is not read to resolve it (its reader learns the
    // model): even a missing one resolves, and loading it then names it.
    for f in ["mat.plmc", "missing.plmc"] {
        assert_eq!(
            resolve_model_file(&d.join(f), None).unwrap(),
            BtfFile::Model(d.join(f))
        );
    }
    assert_eq!(
        resolve_model_file(&d.join("mat.btfc"), None).unwrap(),
        BtfFile::Raw(d.join("mat.btfc"))
    );

    // Through the scene entry point: model property, override, sharing, errors with the place.
    use crate::scene::measured_material::build_btf;
    let scene = Path::new("scene.xml");
    let mat = d.join("mat.plmc");
    let mat = mat.to_string_lossy().into_owned();
    let id = |f: &str| PathBuf::from(f);
    let build = |line: u32, file: &str, uv: f32, m: Option<&str>| {
        let m = m.map(|m| BtfModel::parse(m).unwrap());
        build_btf(scene, line, file, &id, uv, m, None)
    };
    let (a, used) = build(3, &mat, 1.0, Some("plmc")).unwrap();
    assert_eq!(used.model, BtfModel::Fitted(ModelKind::PlmC));
    assert_eq!(used.file, d.join("mat.plmc"));
    // No model: a .plmc file renders the model it holds.
    let (b, used) = build(4, &mat, 2.0, None).unwrap();
    assert_eq!(used.model, BtfModel::Fitted(ModelKind::PlmC));
    let (crate::bsdf::Bsdf::Plmc(a), crate::bsdf::Bsdf::Plmc(b)) = (a, b) else {
        panic!("not a model bsdf");
    };
    assert!(Arc::ptr_eq(a.material(), b.material()));
    assert_eq!(a.material().kind(), ModelKind::PlmC);
    let lm_file = d.join("mat.lm.plmc").to_string_lossy().into_owned();
    let (l, used) = build(5, &lm_file, 1.0, None).unwrap();
    assert_eq!(
        (used.model, used.file),
        (BtfModel::Fitted(ModelKind::Lm), d.join("mat.lm.plmc"))
    );
    let crate::bsdf::Bsdf::Plmc(l) = l else {
        panic!("not a model bsdf");
    };
    assert_eq!(l.material().kind(), ModelKind::Lm);
    let (l, _) = build(5, &mat, 1.0, Some("lm")).unwrap();
    let crate::bsdf::Bsdf::Plmc(l) = l else {
        panic!("not a model bsdf");
    };
    assert_eq!(l.material().kind(), ModelKind::Lm);
    let e = build(6, &mat, 1.0, Some("plm")).unwrap_err().to_string();
    assert!(
        e.contains("scene.xml:6") && e.contains("mat.plm.plmc"),
        "{e}"
    );
    // The raw sibling exists but is not a BTF: the raw loader's error names it.
    let e = build(7, &mat, 1.0, Some("raw")).unwrap_err().to_string();
    assert!(e.contains("scene.xml:7") && e.contains("mat.btfc"), "{e}");
    // A corrupt model file, with and without a model asked for.
    std::fs::write(d.join("bad.plmc"), b"PLMC\x01\0\0\0junk").unwrap();
    let bad = d.join("bad.plmc").to_string_lossy().into_owned();
    for m in [Some("plmc"), None] {
        let e = build(8, &bad, 1.0, m).unwrap_err().to_string();
        assert!(e.contains("scene.xml:8") && e.contains("bad.plmc"), "{e}");
    }
}

#[test]
fn every_kernel_build_returns_the_same_bits() {
    // The render promise (docs/architecture.md, "Determinism across CPUs"): the AVX-512, the
    // AVX2+FMA and the baseline builds of the kernel do the same fused multiply-adds in the same
    // order, so eval, pdf and samples are the same bits on any CPU a farm mixes.
    let mut rng = Pcg32::new(21, 4);
    for (kind, space) in ALL {
        let f = fixture(kind, space);
        for _ in 0..3000 {
            let wi = warp::square_to_uniform_hemisphere(rng.next_2d());
            let wo = warp::square_to_uniform_hemisphere(rng.next_2d());
            let si = SurfaceInteraction::for_tests(wi, rng.next_2d());
            let (u1, u2) = (rng.next_f32(), rng.next_2d());
            let want = (f.sse2.eval(&si, wo), f.sse2.pdf(&si, wo));
            let want_s = f.sse2.sample(&si, u1, u2);
            for b in [&f.bsdf, &f.avx2] {
                let got = (b.eval(&si, wo), b.pdf(&si, wo));
                assert!(
                    got.0.to_array().map(f32::to_bits) == want.0.to_array().map(f32::to_bits)
                        && got.1.to_bits() == want.1.to_bits(),
                    "{kind:?} {space:?} wi {wi} wo {wo}: {got:?} vs baseline {want:?} (avx2 {} avx512 {})",
                    b.material().uses_avx2(),
                    b.material().uses_avx512()
                );
                let got_s = b.sample(&si, u1, u2);
                assert_eq!(
                    format!("{got_s:?}"),
                    format!("{want_s:?}"),
                    "{kind:?} {space:?} wi {wi}: samples differ"
                );
            }
        }
    }
}

#[test]
fn per_hit_calls_equal_the_stateless_ones() {
    use crate::bsdf::{Bsdf, BsdfAt};
    let mut rng = Pcg32::new(8, 8);
    for (kind, space) in ALL {
        let f = fixture(kind, space);
        for bilinear in [false, true] {
            let b = PlmcBsdf::new(f.bsdf.material().clone(), 1.7, bilinear).unwrap();
            let bsdf = Bsdf::Plmc(b);
            for _ in 0..300 {
                let mut wi = warp::square_to_uniform_sphere(rng.next_2d());
                if rng.next_f32() < 0.7 {
                    wi.z = wi.z.abs();
                }
                let wo = warp::square_to_uniform_sphere(rng.next_2d());
                let si = SurfaceInteraction::for_tests(wi, rng.next_2d());
                let at = bsdf.at(&si);
                assert_eq!(matches!(at, BsdfAt::Plmc(..)), wi.z > 0.0);
                assert_eq!(at.flags(), bsdf.flags());
                assert_eq!(at.eval(&si, wo), bsdf.eval(&si, wo));
                assert_eq!(at.pdf(&si, wo), bsdf.pdf(&si, wo));
                assert_eq!(at.eval_pdf(&si, wo), bsdf.eval_pdf(&si, wo));
                let (u1, u2) = (rng.next_f32(), rng.next_2d());
                let a = at.sample(&si, u1, u2);
                let s = bsdf.sample(&si, u1, u2);
                assert_eq!(
                    a.map(|x| (x.0.wo, x.0.pdf, x.1)),
                    s.map(|x| (x.0.wo, x.0.pdf, x.1))
                );
            }
        }
    }
}

#[test]
fn floor_fast_is_floor() {
    let mut rng = Pcg32::new(2, 9);
    let specials = [
        0.0f32,
        -0.0,
        0.5,
        -0.5,
        1.0,
        -1.0,
        0.99999994,
        -0.99999994,
        8388607.5,
        -8388607.5,
        8388608.0,
        -8388608.0,
        1e10,
        -1e10,
        f32::MAX,
        f32::MIN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::MIN_POSITIVE,
        -f32::MIN_POSITIVE,
        1e-45,
        -1e-45,
    ];
    let randoms = (0..100_000).map(|_| {
        let e = rng.next_f32() * 60.0 - 30.0;
        let s = if rng.next_f32() < 0.5 { -1.0 } else { 1.0 };
        s * e.exp2() * rng.next_f32()
    });
    for x in specials.into_iter().chain(randoms) {
        assert_eq!(floor_fast(x).to_bits(), x.floor().to_bits(), "{x}");
    }
    assert!(floor_fast(f32::NAN).is_nan());
}

#[test]
fn batched_evaluation_is_the_single_query_evaluation_bit_for_bit() {
    use crate::bsdf::plmc::BATCH;
    let mut rng = Pcg32::new(21, 8);
    for (kind, space) in ALL {
        let f = fixture(kind, space);
        // PLM-C on AVX2 or AVX-512 runs the 16-query kernel (`f.avx2` its AVX2 build); the
        // other models and CPUs one by one.
        let expect_batch = kind == ModelKind::PlmC && f.bsdf.material().uses_avx2();
        assert_eq!(f.avx2.material().batches(), expect_batch);
        assert_eq!(f.bsdf.material().batches(), expect_batch);
        for bsdf in [&f.bsdf, &f.avx2] {
            for round in 0..40 {
                // Partial batches too; some light directions below the horizon.
                let n = 1 + round % BATCH;
                let mut hits = Vec::new();
                let mut wo = Vec::new();
                let mut want = Vec::new();
                while hits.len() < n {
                    let wi = warp::square_to_uniform_hemisphere(rng.next_2d());
                    let s = SurfaceInteraction::for_tests(wi, rng.next_2d());
                    let Some(h) = bsdf.prepare(&s) else { continue };
                    let mut w = warp::square_to_uniform_sphere(rng.next_2d());
                    let lights = bsdf.material().sampler.light_interp();
                    let u = rng.next_f32();
                    if u < 0.1 {
                        // Exactly at a measured light: the polynomial at its fitted point.
                        w = dir(15.0, 60.0);
                    } else if u < 0.25 {
                        // On an edge of the light triangulation (the batched light search
                        // must pick the scalar search's side), or a vertex of it.
                        let p = lights
                            .triangle_disk(rng.next_below(lights.num_triangles() as u32) as usize);
                        let (a, b) = (rng.next_below(3) as usize, rng.next_below(3) as usize);
                        let s = [0.5, rng.next_f32(), 0.0][rng.next_below(3) as usize];
                        let (x, y) = (
                            p[a][0] + s * (p[b][0] - p[a][0]),
                            p[a][1] + s * (p[b][1] - p[a][1]),
                        );
                        w = Vec3::new(x, y, (1.0 - x * x - y * y).max(0.0).sqrt());
                    } else if u < 0.35 {
                        // Grazing: just above the horizon, beyond the outermost measured ring.
                        w = dir(89.9 + 0.1 * rng.next_f32(), 360.0 * rng.next_f32());
                    }
                    hits.push(h);
                    wo.push(w);
                    want.push(rng.next_f32() < 0.7);
                }
                let mut out = vec![(Spectrum::ZERO, 0.0); n];
                bsdf.eval_pdf_batch(&hits, &wo, &want, &mut out);
                for q in 0..n {
                    let single = if want[q] {
                        bsdf.eval_pdf_hit(&hits[q], wo[q])
                    } else {
                        (bsdf.eval_hit(&hits[q], wo[q]), 0.0)
                    };
                    let bits = |(s, p): (Spectrum, f32)| {
                        [s.x.to_bits(), s.y.to_bits(), s.z.to_bits(), p.to_bits()]
                    };
                    assert_eq!(bits(out[q]), bits(single), "{kind:?} {space:?} query {q}");
                }
            }
        }
    }
}

#[test]
fn batched_sampling_is_the_single_query_sampling_bit_for_bit() {
    use crate::bsdf::plmc::BATCH;
    let mut rng = Pcg32::new(22, 9);
    let bits = |s: &Option<(BsdfSample, Spectrum)>| {
        s.map(|(b, w)| [b.wo.x, b.wo.y, b.wo.z, b.pdf, b.eta, w.x, w.y, w.z].map(f32::to_bits))
    };
    for (kind, space) in ALL {
        let f = fixture(kind, space);
        for bsdf in [&f.bsdf, &f.avx2, &f.sse2] {
            for round in 0..40 {
                // Partial batches too; grazing views, whose samples fail more often.
                let n = 1 + round % BATCH;
                let mut hits = Vec::new();
                while hits.len() < n {
                    let wi = if rng.next_f32() < 0.2 {
                        dir(89.0 + rng.next_f32(), 360.0 * rng.next_f32())
                    } else {
                        warp::square_to_uniform_hemisphere(rng.next_2d())
                    };
                    let s = SurfaceInteraction::for_tests(wi, rng.next_2d());
                    hits.extend(bsdf.prepare(&s));
                }
                let u1: Vec<f32> = (0..n).map(|_| rng.next_f32()).collect();
                let u2: Vec<Vec2> = (0..n).map(|_| rng.next_2d()).collect();
                let mut out = vec![None; n];
                bsdf.sample_batch(&hits, &u1, &u2, &mut out);
                for q in 0..n {
                    let single = bsdf.sample_hit(&hits[q], u1[q], u2[q]);
                    assert_eq!(bits(&out[q]), bits(&single), "{kind:?} {space:?} query {q}");
                }
            }
        }
    }
}

#[test]
fn huge_page_tables_keep_their_contents_and_view_prefetches_never_fault() {
    // 3 MB: spans a 2 MB-aligned block, so the madvise path runs.
    let n = (3 << 20) / 4;
    let f = |i: usize| (i as u32).wrapping_mul(2_654_435_761);
    let v = super::material::huge_vec(n, (0..n).map(f));
    assert_eq!(v.len(), n);
    assert!(v.iter().enumerate().all(|(i, &x)| x == f(i)));
    for (kind, space) in ALL {
        let m = fixture(kind, space).bsdf.material();
        let texels = m.width() * m.height();
        for t in [0, texels - 1, texels, usize::MAX / 3] {
            m.prefetch_views(t, [0, 80, u32::MAX]);
        }
    }
}

#[test]
fn prepare16_is_prepare_lane_by_lane_bit_for_bit() {
    use crate::bsdf::plmc::PREPARE_LANES;
    const N: usize = PREPARE_LANES;
    let bits = |h: &Option<PlmcHit>| {
        h.map(|h| {
            let mut b = vec![h.n as u32];
            b.extend(h.vi);
            b.extend(h.vw.map(f32::to_bits));
            for (t, w) in h.texels {
                b.extend([t as u32, (t >> 32) as u32, w.to_bits()]);
            }
            b
        })
    };
    let mut rng = Pcg32::new(5, 16);
    for (kind, space) in ALL {
        let f = fixture(kind, space);
        let m = f.bsdf.material().clone();
        // Nearest and bilinear, tiled, mirrored (negative scale), with and without prefetch;
        // the nearest texels of every kernel level the CPU has (AVX-512, AVX2, scalar).
        let mut bsdfs = vec![
            f.bsdf.clone(),
            PlmcBsdf::new(m.clone(), 1.0, true).unwrap(),
            PlmcBsdf::new(m.clone(), 3.7, false).unwrap(),
            PlmcBsdf::new(m.clone(), -2.5, true).unwrap(),
            PlmcBsdf::new(m, 1.0, false).unwrap().without_prefetch(),
        ];
        for level in [&f.avx2, &f.sse2] {
            let m = level.material().clone();
            bsdfs.push(level.clone());
            bsdfs.push(PlmcBsdf::new(m.clone(), 3.7, false).unwrap());
            bsdfs.push(PlmcBsdf::new(m, -2.5, false).unwrap());
        }
        for bsdf in &bsdfs {
            for round in 0..60 {
                let mut si = Vec::new();
                for l in 0..N {
                    let wi = match (round + l) % 7 {
                        // Below the horizon, on it, and a measured view exactly.
                        0 => -warp::square_to_uniform_hemisphere(rng.next_2d()),
                        1 => Vec3::new(1.0, 0.0, 0.0),
                        2 => dir(15.0, 60.0),
                        _ => warp::square_to_uniform_hemisphere(rng.next_2d()),
                    };
                    let uv = match (round + 3 * l) % 11 {
                        // uv on texel borders, outside [0, 1), not finite, just below 1.
                        0 => Vec2::new(0.2 * rng.next_below(6) as f32, 1.0 / 3.0),
                        1 => Vec2::new(-1.0 - rng.next_f32(), 7.0 * rng.next_f32()),
                        2 => Vec2::new(-0.0, 1.0),
                        3 => Vec2::new(f32::NAN, f32::INFINITY),
                        4 => Vec2::new(f32::NEG_INFINITY, -1e30),
                        5 => Vec2::new(1.0f32.next_down(), -f32::MIN_POSITIVE),
                        _ => rng.next_2d(),
                    };
                    si.push(SurfaceInteraction::for_tests(wi, uv));
                }
                let lanes = if round % 3 == 0 {
                    u16::MAX
                } else {
                    rng.next_below(1 << 16) as u16
                };
                let get = |f: fn(&SurfaceInteraction) -> f32| -> [f32; N] {
                    std::array::from_fn(|l| f(&si[l]))
                };
                let mut packed = [const { std::mem::MaybeUninit::uninit() }; N];
                let mut lane = [0u8; N];
                let n = bsdf.prepare16(
                    [&get(|s| s.wi.x), &get(|s| s.wi.y), &get(|s| s.wi.z)],
                    [&get(|s| s.uv.x), &get(|s| s.uv.y)],
                    lanes,
                    &mut packed,
                    &mut lane,
                );
                assert!(lane[..n].is_sorted_by(|a, b| a < b), "hits in lane order");
                let mut hits = [None; N];
                for j in 0..n {
                    // SAFETY: prepare16 wrote entries 0..n.
                    hits[lane[j] as usize] = Some(unsafe { packed[j].assume_init() });
                }
                for l in 0..N {
                    let want = if lanes & (1 << l) != 0 {
                        bsdf.prepare(&si[l])
                    } else {
                        None
                    };
                    assert_eq!(bits(&hits[l]), bits(&want), "{kind:?} lane {l} {:?}", si[l]);
                }
            }
        }
    }
}

/// The tables by libm `powf` and the scalar lobe / polynomial / decode functions, in f64
/// sums: what `tables::mean_values` approximates.
fn tables_reference(model: &PlmcModel) -> (Vec<f32>, Vec<[f32; 3]>, Vec<[f32; 4]>) {
    let (nv, nl) = (model.views.len(), model.lights.len());
    let (w, h) = (model.width, model.height);
    let mut out = vec![0f32; nv * nl * 3];
    let mut omax = vec![[0f32; 4]; nv * nl];
    let mut y_max = vec![[0f32; 3]; nv];
    for v in 0..nv {
        // Y's range: every texel's lobe (PLM-C: every cluster with members) at every light.
        let texels = w * h;
        for c in 0..3 {
            for t in 0..texels {
                let lb = model.params[v].packed(t, c).unpack();
                for u in &model.lights.dirs {
                    y_max[v][c] = y_max[v][c].max(lobe::eval(&lb, *u));
                }
            }
        }
        for l in 0..nl {
            for c in 0..3 {
                let lobes: Vec<(lobe::Lobe, f64)> = match &model.params[v] {
                    ViewParams::Clustered { k, table, index } => (0..*k)
                        .map(|j| {
                            let n = (c..index.len())
                                .step_by(3)
                                .filter(|&t| index[t] as usize == j)
                                .count();
                            (table[3 * j + c].unpack(), n as f64 / (w * h) as f64)
                        })
                        .filter(|p| p.1 > 0.0)
                        .collect(),
                    ViewParams::Texel(p) => {
                        let n = (w * h) as f64;
                        (0..w * h)
                            .map(|t| (p[3 * t + c].unpack(), 1.0 / n))
                            .collect()
                    }
                };
                let mut s = 0f64;
                for (lb, wt) in &lobes {
                    let o = polynomial::eval(
                        &model.poly(v, l, c),
                        lobe::eval(lb, model.lights.dirs[l]),
                    );
                    s += wt * model.space.to_linear(o) as f64;
                    omax[v * nl + l][c] = omax[v * nl + l][c].max(o);
                }
                out[(v * nl + l) * 3 + c] = s as f32;
            }
        }
    }
    (out, y_max, omax)
}

#[test]
fn material_tables_match_the_libm_reference() {
    for (kind, space) in ALL {
        let m = &fixture(kind, space).model;
        let (mean, y_max, omax) = super::tables::mean_values(m);
        let (rmean, ry_max, romax) = tables_reference(m);
        // The clamp on Y is libm's powf of the same maxima: the same bits.
        assert_eq!(y_max, ry_max, "{kind:?} {space:?}");
        let close = |a: f32, b: f32| (a - b).abs() <= 2e-5 * b.abs().max(1e-3);
        for (i, (a, b)) in mean.iter().zip(&rmean).enumerate() {
            assert!(close(*a, *b), "{kind:?} {space:?} mean {i}: {a} vs {b}");
        }
        for (i, (a, b)) in omax.iter().zip(&romax).enumerate() {
            for c in 0..3 {
                assert!(
                    close(a[c], b[c]),
                    "{kind:?} {space:?} max {i}/{c}: {a:?} {b:?}"
                );
            }
        }
    }
}
