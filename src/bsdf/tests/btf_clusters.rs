//! The raw BTF's per-cluster light-sampling tables (`bsdf/btf_clusters.rs`) on a small synthetic
//! BTF whose texels come in three kinds: a glossy lobe about a normal tilted +25° in x, the same
//! lobe tilted −25° (two sides of a bump), and a Lambertian one; every texel has its own
//! brightness and the kinds interleave, so only the shape of B over the lights tells them apart.

use super::si;
use crate::bsdf::Bxdf;
use crate::bsdf::btf::{BtfBsdf, BtfMaterial};
use crate::bsdf::btf_clusters::{MAX_CLUSTERS, clusters_within};
use crate::bsdf::btf_sampler::{BtfLightSampler, SAMPLE_LANES};
use crate::bsdf::chi2::Chi2Test;
use crate::btf::{BtfSource, RawBtf};
use crate::geometry::SurfaceInteraction;
use crate::math::color::luminance;
use crate::math::frame::from_spherical;
use crate::math::{Pcg32, Spectrum, Vec2, Vec3};
use std::sync::{Arc, OnceLock};

/// Texels per row and rows of the test BTF.
const W: usize = 6;
const H: usize = 4;

/// The kind of texel (x, y): 0 and 1 glossy, tilted +x and −x; 2 Lambertian.
fn kind(x: usize, y: usize) -> usize {
    (x + 2 * y) % 3
}

/// B of a texel of `kind` (cosine-baked), scaled by the texel's own brightness.
fn b_value(kind: usize, v: Vec3, l: Vec3, x: usize, y: usize) -> [f32; 3] {
    let tint = 1.0 + 0.08 * (x + W * y) as f32;
    let b = match kind {
        2 => 0.7 * l.z,
        k => {
            let s = if k == 0 { 1.0 } else { -1.0 };
            let n = Vec3::new(s * 0.4226, 0.0, 0.9063);
            let h = (v + l).normalize();
            l.z * (0.05 + 4.0 * n.dot(h).max(0.0).powi(40))
        }
    };
    [b * tint, 0.8 * b * tint, 0.6 * b * tint]
}

/// A UBO2003-direction BTF of W × H texels with B = `f(view, light, x, y)`.
fn table(f: impl Fn(Vec3, Vec3, usize, usize) -> [f32; 3]) -> RawBtf {
    crate::bsdf::btf::tests::table(W, H, f)
}

fn mixed_btf() -> &'static Arc<RawBtf> {
    static B: OnceLock<Arc<RawBtf>> = OnceLock::new();
    B.get_or_init(|| Arc::new(table(|v, l, x, y| b_value(kind(x, y), v, l, x, y))))
}

/// The mixed BTF as a material with the default clusters and budget.
fn clustered() -> &'static Arc<BtfMaterial> {
    static M: OnceLock<Arc<BtfMaterial>> = OnceLock::new();
    M.get_or_init(|| Arc::new(BtfMaterial::new(mixed_btf().clone()).unwrap()))
}

/// The mixed BTF with one material-wide table.
fn single() -> &'static Arc<BtfMaterial> {
    static M: OnceLock<Arc<BtfMaterial>> = OnceLock::new();
    M.get_or_init(|| {
        Arc::new(BtfMaterial::with_clusters(mixed_btf().clone(), 1, usize::MAX).unwrap())
    })
}

fn dir(theta_deg: f32, phi_deg: f32) -> Vec3 {
    from_spherical(theta_deg.to_radians(), phi_deg.to_radians())
}

/// A hit at the centre of texel (x, y) seen from `wi`.
fn hit(wi: Vec3, (x, y): (usize, usize)) -> SurfaceInteraction {
    let mut s = si(wi);
    s.uv = Vec2::new((x as f32 + 0.5) / W as f32, (y as f32 + 0.5) / H as f32);
    s
}

/// The first texel of each kind.
fn texel_of_kind(k: usize) -> (usize, usize) {
    (0..H)
        .flat_map(|y| (0..W).map(move |x| (x, y)))
        .find(|&(x, y)| kind(x, y) == k)
        .unwrap()
}

/// Views at the centre, at a measured direction, between views, between the outer rings and
/// beyond the outermost ring.
fn test_views() -> Vec<Vec3> {
    vec![
        dir(0.0, 0.0),
        dir(45.0, 20.0),
        dir(37.0, 101.0),
        dir(68.0, 250.0),
        dir(82.0, 33.0),
    ]
}

/// Luminance of B averaged over the texels `member` picks, `[view][light]`: RGB summed in
/// row-major order, divided by the count, then the luminance (how the single table was built
/// before texels were clustered).
fn averaged_luminance(btf: &RawBtf, member: impl Fn(usize, usize) -> bool) -> Vec<f32> {
    let (nv, nl) = (btf.views().len(), btf.lights().len());
    let mut lum = Vec::with_capacity(nv * nl);
    for v in 0..nv {
        for l in 0..nl {
            let mut sum = Spectrum::ZERO;
            let mut n = 0u32;
            for y in 0..btf.height() {
                for x in 0..btf.width() {
                    if member(x, y) {
                        sum += Spectrum::from(btf.texel(v, l, x, y));
                        n += 1;
                    }
                }
            }
            let b = luminance(sum / n as f32);
            lum.push(if b.is_finite() { b.max(0.0) } else { 0.0 });
        }
    }
    lum
}

/// A one-set sampler over `btf`'s lights built from `lum`.
fn sampler_from(btf: &RawBtf, lum: &[f32]) -> BtfLightSampler {
    BtfLightSampler::new(
        btf.lights().interpolator().unwrap(),
        &btf.lights().dirs,
        lum,
    )
}

/// Asserts that table set `set` of `m`'s sampler has the same densities and draws, bit for
/// bit, as `want` (a one-set sampler), over random views, directions and numbers.
fn assert_same_tables(m: &BtfMaterial, set: u32, want: &BtfLightSampler, what: &str) {
    let got = m.sampler();
    let mut rng = Pcg32::new(7, set as u64);
    for _ in 0..2000 {
        let wi = crate::math::warp::square_to_uniform_hemisphere(rng.next_2d());
        let (vi, vw) = m.view_interp().lookup(wi);
        let wo = crate::math::warp::square_to_uniform_hemisphere(rng.next_2d());
        assert_eq!(
            got.pdf(set, vi, vw, wo).to_bits(),
            want.pdf(0, vi, vw, wo).to_bits(),
            "{what}: pdf of set {set} at wi {wi}, wo {wo}"
        );
        let (u1, u2) = (rng.next_f32(), rng.next_2d());
        let (a, b) = (
            got.sample(set, vi, vw, u1, u2),
            want.sample(0, vi, vw, u1, u2),
        );
        assert!(
            a.0 == b.0 && a.1 == b.1,
            "{what}: sample of set {set}: {a:?} vs {b:?}"
        );
    }
}

#[test]
fn texels_of_one_shape_share_a_cluster_and_other_shapes_do_not() {
    let m = clustered();
    assert_eq!(m.sampler().sets(), 3, "{m:?}");
    for y in 0..H {
        for x in 0..W {
            for (x2, y2) in [(0, 0), (1, 0), (2, 0)] {
                assert_eq!(
                    m.cluster(x, y) == m.cluster(x2, y2),
                    kind(x, y) == kind(x2, y2),
                    "texels ({x}, {y}) and ({x2}, {y2})"
                );
            }
        }
    }
}

#[test]
fn a_texels_tables_are_its_clusters_average() {
    let btf = mixed_btf();
    // The default material, and one allowed only two sets (so one cluster holds two kinds).
    let per_set =
        BtfLightSampler::bytes_per_set(81, clustered().sampler().light_interp().num_triangles());
    let two = BtfMaterial::with_clusters(btf.clone(), MAX_CLUSTERS, 2 * per_set + W * H).unwrap();
    assert_eq!(two.sampler().sets(), 2);
    for (m, what) in [
        (clustered().clone(), "default"),
        (Arc::new(two), "two sets"),
    ] {
        for set in 0..m.sampler().sets() as u32 {
            let lum = averaged_luminance(btf, |x, y| m.cluster(x, y) == set);
            assert_same_tables(&m, set, &sampler_from(btf, &lum), what);
        }
        // A hit's density is its texel's cluster's.
        let b = BtfBsdf::new(m.clone(), 1.0).unwrap();
        for y in 0..H {
            for x in 0..W {
                let wi = dir(40.0, 30.0);
                let s = hit(wi, (x, y));
                let (vi, vw) = m.view_interp().lookup(wi);
                for wo in [dir(20.0, 190.0), dir(50.0, 0.0), dir(85.0, 300.0)] {
                    let want = m.sampler().pdf(m.cluster(x, y), vi, vw, wo);
                    assert_eq!(b.pdf(&s, wo), want, "{what}: texel ({x}, {y})");
                    assert_eq!(b.eval_pdf(&s, wo).1, want, "{what}: texel ({x}, {y})");
                }
            }
        }
    }
}

#[test]
fn one_cluster_is_the_material_wide_table() {
    let btf = mixed_btf();
    let whole = sampler_from(btf, &averaged_luminance(btf, |_, _| true));
    let m = single();
    assert_eq!(m.sampler().sets(), 1);
    assert_eq!(
        m.sampling_bytes(),
        m.sampler().table_bytes(),
        "no texel index"
    );
    assert_eq!((m.cluster(0, 0), m.cluster(W - 1, H - 1)), (0, 0));
    assert_same_tables(m, 0, &whole, "one cluster");
    // Texels that differ in brightness and tint only: one set by default, the same table.
    let tinted = Arc::new(table(|v, l, x, y| b_value(0, v, l, x, y)));
    let m = BtfMaterial::new(tinted.clone()).unwrap();
    assert_eq!(m.sampler().sets(), 1);
    let lum = averaged_luminance(&tinted, |_, _| true);
    assert_same_tables(&m, 0, &sampler_from(&tinted, &lum), "one shape");
}

#[test]
fn the_budget_limits_the_clusters() {
    // Sets that fit after the one-byte-per-texel index, between 1 and the maximum.
    assert_eq!(clusters_within(1000 + 10, 100, 10, 16), 10);
    assert_eq!(clusters_within(1000 + 9, 100, 10, 16), 9);
    assert_eq!(clusters_within(usize::MAX, 100, 10, 16), 16);
    assert_eq!(clusters_within(0, 100, 10, 16), 1);
    assert_eq!(clusters_within(usize::MAX, 100, 10, 1), 1);
    assert_eq!(
        clusters_within(usize::MAX, 100, 10, 1000),
        256,
        "u8 texel index"
    );
    // 81 × 81 UBO2003 directions: 136 light triangles, under 0.35 MiB per set.
    let nt = clustered().sampler().light_interp().num_triangles();
    assert_eq!(nt, 136);
    let per_set = BtfLightSampler::bytes_per_set(81, nt);
    assert!((300_000..370_000).contains(&per_set), "{per_set}");
    let btf = mixed_btf();
    for (budget, sets) in [
        (0, 1),
        (per_set, 1),
        (2 * per_set + W * H - 1, 1),
        (2 * per_set + W * H, 2),
        (16 * per_set, 3),
    ] {
        let m = BtfMaterial::with_clusters(btf.clone(), MAX_CLUSTERS, budget).unwrap();
        assert_eq!(m.sampler().sets(), sets, "budget {budget}");
        let index = if sets == 1 { 0 } else { W * H };
        assert_eq!(m.sampling_bytes(), sets * per_set + index);
        assert!(sets == 1 || m.sampling_bytes() <= budget);
    }
}

#[test]
fn chi2_of_every_clusters_density() {
    let m = clustered();
    let b = BtfBsdf::new(m.clone(), 1.0).unwrap();
    let views = test_views();
    let t = Chi2Test {
        cos_theta_res: 20,
        phi_res: 40,
        sample_count: 200_000,
        test_count: 3 * views.len(),
        ..Default::default()
    };
    let mut failures = Vec::new();
    for k in 0..3 {
        let texel = texel_of_kind(k);
        for &wi in &views {
            let s = hit(wi, texel);
            let mut lobe = Pcg32::new(17, k as u64);
            let out = t.run(
                |u1, u2| {
                    let s1 = lobe.next_f32();
                    b.sample(&s, s1, Vec2::new(u1, u2)).map(|x| x.0.wo)
                },
                |w| b.pdf(&s, w),
            );
            if !out.passed || (out.pdf_integral - 1.0).abs() > 5e-3 {
                failures.push(format!(
                    "kind {k} wi {wi}: ∫pdf {} {}",
                    out.pdf_integral, out.message
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// ∫ eval dω over the hemisphere (first channel) by a fine midpoint rule in (cos θ, φ).
fn albedo_quadrature(b: &BtfBsdf, s: &SurfaceInteraction) -> f64 {
    let (nt, np) = (200, 400);
    let mut acc = 0f64;
    for i in 0..nt {
        let c = (i as f32 + 0.5) / nt as f32;
        for j in 0..np {
            let p = (j as f32 + 0.5) / np as f32 * 2.0 * std::f32::consts::PI;
            let st = (1.0 - c * c).sqrt();
            acc += b.eval(s, Vec3::new(st * p.cos(), st * p.sin(), c)).x as f64;
        }
    }
    acc * 2.0 * std::f64::consts::PI / (nt * np) as f64
}

/// Mean and standard error of the first channel of `b`'s sample weights at `s`, `n` samples.
fn weight_stats(b: &BtfBsdf, s: &SurfaceInteraction, n: usize, seed: u64) -> (f64, f64) {
    crate::bsdf::btf::tests::weight_stats(|u1, u2| b.sample(s, u1, u2).map(|x| x.1.x), n, seed)
}

#[test]
fn sampled_weights_integrate_to_the_albedo() {
    // eval · cos / pdf of sampled directions, averaged, is ∫ eval dω at every kind of texel.
    let b = BtfBsdf::new(clustered().clone(), 1.0).unwrap();
    for k in 0..3 {
        for wi in [
            dir(0.0, 0.0),
            dir(30.0, 0.0),
            dir(60.0, 200.0),
            dir(82.0, 33.0),
        ] {
            let s = hit(wi, texel_of_kind(k));
            let quad = albedo_quadrature(&b, &s);
            let (mean, se) = weight_stats(&b, &s, 40_000, 11 + k as u64);
            assert!(
                (mean - quad).abs() < 4.0 * se + 2e-3 * quad,
                "kind {k} wi {wi}: IS {mean} ± {se} vs quadrature {quad}"
            );
        }
    }
}

#[test]
fn cluster_tables_sample_glossy_texels_better_than_the_material_wide_table() {
    let per_cluster = BtfBsdf::new(clustered().clone(), 1.0).unwrap();
    let whole = BtfBsdf::new(single().clone(), 1.0).unwrap();
    for k in [0, 1] {
        for wi in [dir(30.0, 0.0), dir(45.0, 180.0)] {
            let s = hit(wi, texel_of_kind(k));
            let (m_c, se_c) = weight_stats(&per_cluster, &s, 40_000, 3);
            let (m_1, se_1) = weight_stats(&whole, &s, 40_000, 3);
            assert!((m_c - m_1).abs() < 4.0 * (se_c * se_c + se_1 * se_1).sqrt());
            assert!(
                se_c < 0.7 * se_1,
                "kind {k} wi {wi}: standard error {se_c} per cluster vs {se_1} whole"
            );
        }
    }
}

#[test]
fn sample_batch_draws_each_querys_own_set() {
    let m = clustered();
    let sampler = m.sampler();
    let mut rng = Pcg32::new(5, 9);
    for _ in 0..50 {
        let mut set = [0u32; SAMPLE_LANES];
        let mut vi = [[0u32; 3]; SAMPLE_LANES];
        let mut vw = [[0f32; 3]; SAMPLE_LANES];
        let mut u1 = [0f32; SAMPLE_LANES];
        let mut u2 = [Vec2::ZERO; SAMPLE_LANES];
        for q in 0..SAMPLE_LANES {
            set[q] = rng.next_below(sampler.sets() as u32);
            let wi = crate::math::warp::square_to_uniform_hemisphere(rng.next_2d());
            (vi[q], vw[q]) = m.view_interp().lookup(wi);
            (u1[q], u2[q]) = (rng.next_f32(), rng.next_2d());
        }
        let mut out = [(Vec3::ZERO, None); SAMPLE_LANES];
        sampler.sample_batch(&set, &vi, &vw, &u1, &u2, &mut out);
        for q in 0..SAMPLE_LANES {
            let want = sampler.sample(set[q], vi[q], vw[q], u1[q], u2[q]);
            assert!(out[q].0 == want.0 && out[q].1 == want.1, "query {q}");
        }
    }
}
