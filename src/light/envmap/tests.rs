use super::*;
use crate::math::Pcg32;
use crate::math::simd::f16::{M16, V2x, V3x};

fn test_map() -> RgbImage {
    let (w, h) = (8, 5);
    let mut img = RgbImage::new(w, h);
    for j in 0..h {
        for i in 0..w {
            let v = 0.1 + (i * 7 + j * 3) as f32 % 5.0 + if (i, j) == (2, 1) { 40.0 } else { 0.0 };
            img.set(i, j, [v, 0.5 * v, 0.25]);
        }
    }
    img
}

#[test]
fn mitsuba_mapping_up_is_row_zero_and_texel_centres_are_exact() {
    let img = test_map();
    let env = EnvMapLight::new(&img, Mat4::IDENTITY, 2.0, Path::new("t.exr")).unwrap();
    // +y (θ = 0) is row 0; with u at a texel centre the lookup is exact.
    let want = Spectrum::from(img.get(0, 0)) * 2.0;
    // Texel (i, j) sits at u = (i + ½)/W, v = j/(H−1).
    let u = 0.5 / 8.0;
    let phi = 2.0 * PI * u;
    let theta = PI * 1.0 / 4.0; // row 1
    let d = Vec3::new(
        theta.sin() * phi.sin(),
        theta.cos(),
        -theta.sin() * phi.cos(),
    );
    let got = env.eval(d);
    let want1 = Spectrum::from(img.get(0, 1)) * 2.0;
    assert!((got - want1).length() < 1e-4, "{got} vs {want1}");
    let top = env.eval(Vec3::new(0.0, 1.0, 0.0));
    // At the pole v = 0 the lookup interpolates along row 0 only.
    assert!((top.z - want.z).abs() < 1e-5);
}

/// A zero or non-finite direction looks up the map at (½, ½), as the normalised zero
/// vector did before the atan2 mapping, instead of returning NaN.
#[test]
fn degenerate_directions_map_to_the_centre() {
    let img = test_map();
    let env = EnvMapLight::new(&img, Mat4::IDENTITY, 1.0, Path::new("t.exr")).unwrap();
    let centre = env.lookup(env.column(0.5), 0.5);
    for d in [Vec3::ZERO, Vec3::NAN, Vec3::new(f32::INFINITY, 0.0, 1.0)] {
        assert_eq!(env.lat_long(d), Vec2::splat(0.5));
        assert_eq!(env.eval(d), centre);
        assert!(env.pdf(d).is_finite());
    }
}

#[test]
fn rotation_moves_the_map() {
    let img = test_map();
    let rot = Mat4::from_rotation_x(0.5 * PI);
    let a = EnvMapLight::new(&img, Mat4::IDENTITY, 1.0, Path::new("t.exr")).unwrap();
    let b = EnvMapLight::new(&img, rot, 1.0, Path::new("t.exr")).unwrap();
    let d = Vec3::new(0.3, 0.5, -0.2).normalize();
    let rd = rot.transform_vector3(d);
    assert!((a.eval(d) - b.eval(rd)).length() < 1e-4);
    assert!((a.pdf(d) - b.pdf(rd)).abs() < 1e-3 * a.pdf(d));
}

/// Chi-square test of the sampled directions (alias-table rows and columns, uniform in
/// (φ, cos θ) inside a cell) against the pdf, on a (cos θ, φ) grid of equal-solid-angle bins
/// whose expected counts come from integrating `pdf` numerically.
#[test]
fn sampling_matches_pdf_chi_square() {
    let img = test_map();
    let rot = Mat4::from_rotation_z(0.3) * Mat4::from_rotation_x(0.2);
    let env = EnvMapLight::new(&img, rot, 1.0, Path::new("t.exr")).unwrap();
    let (nt, np) = (10usize, 20usize);
    let n = 200_000;
    let mut hist = vec![0f64; nt * np];
    let mut rng = Pcg32::new(11, 12);
    let bin = |d: Vec3| {
        let t = (((1.0 - d.z) * 0.5 * nt as f32) as usize).min(nt - 1);
        let mut phi = d.y.atan2(d.x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let p = ((phi / (2.0 * PI) * np as f32) as usize).min(np - 1);
        t * np + p
    };
    // Directions on a cell boundary (u on a bin edge: uy or ux exactly 0) may map back to the
    // neighbouring cell, whose pdf differs; that is a set of measure zero, so rare.
    let mut boundary = 0;
    for _ in 0..n {
        let (d, val, pdf) = env.sample(rng.next_2d()).unwrap();
        assert!((d.length() - 1.0).abs() < 1e-4);
        if (pdf - env.pdf(d)).abs() > 1e-3 * pdf {
            boundary += 1;
        }
        // The radiance comes from the sampled lat-long point, eval from the direction mapped
        // back: the same up to rounding.
        assert!((val - env.eval(d)).length() < 1e-4 * (1.0 + val.length()));
        hist[bin(d)] += 1.0;
    }
    assert!(
        boundary <= n / 10_000,
        "{boundary} samples with another pdf"
    );
    // Expected: integrate pdf over each bin with a fine stratified grid.
    let sub = 64;
    let mut expect = vec![0f64; nt * np];
    let mut total = 0.0;
    for t in 0..nt * sub {
        for p in 0..np * sub {
            let z = 1.0 - 2.0 * (t as f32 + 0.5) / (nt * sub) as f32;
            let phi = 2.0 * PI * (p as f32 + 0.5) / (np * sub) as f32;
            let r = (1.0 - z * z).sqrt();
            let d = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            let w = env.pdf(d) as f64 * 4.0 * std::f64::consts::PI / (nt * np * sub * sub) as f64;
            expect[bin(d)] += w;
            total += w;
        }
    }
    assert!((total - 1.0).abs() < 0.01, "pdf integrates to {total}");
    let mut chi2 = 0.0;
    let mut dof = 0;
    let mut pooled = (0.0, 0.0);
    for k in 0..nt * np {
        let e = expect[k] * n as f64;
        if e < 5.0 {
            pooled.0 += hist[k];
            pooled.1 += e;
            continue;
        }
        chi2 += (hist[k] - e).powi(2) / e;
        dof += 1;
    }
    if pooled.1 >= 5.0 {
        chi2 += (pooled.0 - pooled.1).powi(2) / pooled.1;
        dof += 1;
    }
    // Critical value at α = 0.001 for ≈200 dof is ≈ 267; Wilson–Hilferty bound used.
    let k = (dof - 1) as f64;
    let z = 3.09;
    let crit = k * (1.0 - 2.0 / (9.0 * k) + z * (2.0 / (9.0 * k)).sqrt()).powi(3);
    assert!(chi2 < crit, "chi2 {chi2} > {crit} (dof {k})");
}

/// A map with a bright spot, a black band of two rows (a sampling row of black cells) and a
/// black band of two columns (a black cell in every sampling row).
fn patchy_map() -> RgbImage {
    let (w, h) = (23, 11);
    let mut img = RgbImage::new(w, h);
    for j in 0..h {
        for i in 0..w {
            let v = if j == 0 || j == 5 || j == 6 || i == 7 || i == 8 {
                0.0
            } else {
                0.05 + ((i * 13 + j * 7) % 9) as f32 + if (i, j) == (3, 8) { 200.0 } else { 0.0 }
            };
            img.set(i, j, [v, 0.3 * v, 0.1 * v]);
        }
    }
    img
}

/// ∫ pdf dω = 1 over the sphere (a fine midpoint rule in (cos θ, φ), where the pdf is constant
/// on cells), and the pdf is 0 exactly where the map is black all around.
#[test]
fn pdf_integrates_to_one() {
    for (img, rot) in [
        (test_map(), Mat4::IDENTITY),
        (
            patchy_map(),
            Mat4::from_rotation_y(0.7) * Mat4::from_rotation_x(-0.4),
        ),
    ] {
        let env = EnvMapLight::new(&img, rot, 1.5, Path::new("t.exr")).unwrap();
        let (nz, np) = (1200usize, 1200usize);
        let mut total = 0.0f64;
        for a in 0..nz {
            let z = 1.0 - 2.0 * (a as f64 + 0.5) / nz as f64;
            let r = (1.0 - z * z).sqrt();
            for b in 0..np {
                let phi = 2.0 * std::f64::consts::PI * (b as f64 + 0.5) / np as f64;
                let d = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
                total += env.pdf(d) as f64;
            }
        }
        total *= 4.0 * std::f64::consts::PI / (nz * np) as f64;
        assert!((total - 1.0).abs() < 2e-3, "∫ pdf = {total}");
    }
}

/// A cell whose four corners are black has pdf 0 and is never sampled; a black map samples
/// nothing.
#[test]
fn black_cells_are_never_sampled() {
    let img = patchy_map();
    let env = EnvMapLight::new(&img, Mat4::IDENTITY, 1.0, Path::new("t.exr")).unwrap();
    let mut rng = Pcg32::new(2, 5);
    for _ in 0..20_000 {
        let (d, val, pdf) = env.sample(rng.next_2d()).unwrap();
        assert!(pdf > 0.0 && val.max_element() >= 0.0);
        // (The pdf is 0 on the black cells: sampling row 5, cell column 7.)
        assert!(env.pdf(d) > 0.0, "{d}");
    }
    let black = RgbImage::new(6, 4);
    let env = EnvMapLight::new(&black, Mat4::IDENTITY, 1.0, Path::new("t.exr")).unwrap();
    assert!(env.sample(Vec2::splat(0.3)).is_none());
    assert_eq!(env.pdf(Vec3::Y), 0.0);
    let (_, _, _, ok) = env.sample_x(V2x::ZERO);
    assert_eq!(ok, M16::splat(false));
}

fn bits3(v: Vec3) -> [u32; 3] {
    v.to_array().map(f32::to_bits)
}

/// The 16-lane sampler gives the scalar one's directions, radiance and pdfs bit for bit, and
/// fails on the same lanes, on random numbers and on the edges of the tables.
#[test]
fn sample_x_is_sample_per_lane() {
    let rot = Mat4::from_rotation_z(0.3) * Mat4::from_rotation_x(0.2);
    for img in [test_map(), patchy_map()] {
        let env = EnvMapLight::new(&img, rot, 2.0, Path::new("t.exr")).unwrap();
        let mut rng = Pcg32::new(8, 1);
        let mut us: Vec<Vec2> = (0..3000).map(|_| rng.next_2d()).collect();
        for e in [
            0.0f32,
            1.0 / 3.0,
            0.5,
            1.0 - f32::EPSILON / 2.0,
            1.0,
            -0.25,
            f32::NAN,
        ] {
            us.extend([Vec2::new(e, 0.4), Vec2::new(0.6, e), Vec2::splat(e)]);
        }
        for c in us.chunks(16) {
            let mut u = V2x::ZERO;
            for (l, &v) in c.iter().enumerate() {
                u.set(l, v);
            }
            let (d, val, pdf, ok) = env.sample_x(u);
            for l in 0..c.len() {
                let s = env.sample(u.get(l));
                assert_eq!(ok.0[l], s.is_some(), "u = {}", u.get(l));
                if let Some((sd, sv, sp)) = s {
                    assert_eq!(bits3(d.get(l)), bits3(sd), "u = {}", u.get(l));
                    assert_eq!(bits3(val.get(l)), bits3(sv), "u = {}", u.get(l));
                    assert_eq!(pdf.0[l].to_bits(), sp.to_bits());
                }
            }
        }
    }
}

/// The 16-lane escaped-ray lookup gives the scalar one's radiance and pdf bit for bit, on
/// random directions of any length and on the degenerate ones (zero, NaN, ∞, the poles, the
/// seam at u = 0).
#[test]
fn eval_pdf_x_is_eval_pdf_per_lane() {
    let rot = Mat4::from_rotation_y(0.9) * Mat4::from_rotation_x(0.2);
    for img in [test_map(), patchy_map()] {
        let env = EnvMapLight::new(&img, rot, 1.0, Path::new("t.exr")).unwrap();
        let to_world = glam::Mat3::from_mat4(rot);
        let mut rng = Pcg32::new(6, 6);
        let mut ds: Vec<Vec3> = (0..3000)
            .map(|k| {
                let v = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
                v * [1.0, 1e-3, 40.0][k % 3]
            })
            .collect();
        ds.extend([
            Vec3::ZERO,
            Vec3::NAN,
            Vec3::new(f32::INFINITY, 0.0, 1.0),
            to_world * Vec3::Y,
            to_world * -Vec3::Y,
            to_world * -Vec3::Z,
            to_world * Vec3::new(-0.0, 0.3, -1.0),
            to_world * Vec3::new(1e-30, 0.0, -1.0),
        ]);
        for c in ds.chunks(16) {
            let mut d = V3x::ZERO;
            for (l, &v) in c.iter().enumerate() {
                d.set(l, v);
            }
            let (le, pdf) = env.eval_pdf_x(d);
            for (l, &v) in c.iter().enumerate() {
                let (sle, spdf) = env.eval_pdf(v);
                assert_eq!(bits3(le.get(l)), bits3(sle), "d = {v}");
                assert_eq!(pdf.0[l].to_bits(), spdf.to_bits(), "d = {v}");
            }
        }
    }
}
