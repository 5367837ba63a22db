//! The pipeline end to end on small synthetic BTFs.

use super::*;
use crate::btf::RawBtf;
use crate::btf::StoredEncoding;
use crate::fit::report::view_error;
use crate::math::Pcg32;
use crate::model::codec;
use crate::model::lobe::{self, Lobe};

/// A synthetic BTF: texels drawn from 6 material types (one lobe per channel each), plus a
/// monotone per-image tone curve y ↦ y^γ (what one lobe cannot model, PLM can), plus noise.
fn synth(views: usize, side: usize, seed: u64) -> RawBtf {
    let lights = DirectionSet::ubo2003();
    let vdirs = DirectionSet::from_angles_deg(lights.angles_deg[..views].to_vec());
    let mut rng = Pcg32::new(seed, 11);
    let types: Vec<[Lobe; 3]> = (0..6)
        .map(|_| {
            let th = rng.next_f32() * 0.6;
            let ph = rng.next_f32() * std::f32::consts::TAU;
            let n = 1.0 + rng.next_f32() * 8.0;
            std::array::from_fn(|_| {
                [
                    0.2 + rng.next_f32(),
                    th.sin() * ph.cos(),
                    th.sin() * ph.sin(),
                    th.cos(),
                    n,
                ]
            })
        })
        .collect();
    let texel_type: Vec<usize> = (0..side * side)
        .map(|_| rng.next_below(6) as usize)
        .collect();
    let gamma: Vec<f32> = (0..views * 81).map(|_| 0.5 + rng.next_f32()).collect();
    let mut data = Vec::new();
    for v in 0..views {
        for l in 0..81 {
            for &ty in &texel_type {
                for lobe in &types[ty] {
                    let y = lobe::eval(lobe, lights.dirs[l]);
                    data.push((y.powf(gamma[v * 81 + l]) + 0.01 * (rng.next_f32() - 0.5)).max(0.0));
                }
            }
        }
    }
    RawBtf::from_f32(vdirs, lights, side, side, StoredEncoding::Linear, &data).unwrap()
}

/// One view of `side`² texels, each with its own lobe (direction, exponent and albedo drawn
/// continuously) plus uniform per-sample noise of amplitude `noise` (linear values).
fn noisy_continuum(side: usize, noise: f32, seed: u64) -> RawBtf {
    let lights = DirectionSet::ubo2003();
    let vdirs = DirectionSet::from_angles_deg(vec![(0.0, 0.0)]);
    let mut rng = Pcg32::new(seed, 5);
    let lobes: Vec<Lobe> = (0..side * side)
        .map(|_| {
            let th = rng.next_f32() * 0.5;
            let ph = rng.next_f32() * std::f32::consts::TAU;
            [
                0.2 + 0.6 * rng.next_f32(),
                th.sin() * ph.cos(),
                th.sin() * ph.sin(),
                th.cos(),
                1.0 + 6.0 * rng.next_f32(),
            ]
        })
        .collect();
    let mut data = Vec::new();
    for l in 0..81 {
        for lobe in &lobes {
            let y = lobe::eval(lobe, lights.dirs[l]) + noise * (rng.next_f32() - 0.5);
            data.extend([y.max(0.0); 3]);
        }
    }
    RawBtf::from_f32(vdirs, lights, side, side, StoredEncoding::Linear, &data).unwrap()
}

#[test]
fn clustering_lm_values_beats_clustering_noisy_originals() {
    // Texels whose lobes vary continuously, under noise as strong as the lobes' detail:
    // K-means on the measured values partly groups texels by their noise, K-means on the LM
    // values by their lobes, so the refitted cluster lobes represent the members better.
    // Errors are measured against the noiseless values (same lobes, same seed): the noise
    // itself would otherwise dominate both errors.
    let btf = noisy_continuum(24, 0.3, 3);
    let clean = noisy_continuum(24, 0.0, 3);
    let fit = |cluster_on| {
        let o = FitOptions {
            clusters: 12,
            cluster_on,
            ..FitOptions::default()
        };
        mae(
            &clean,
            &fit_model(&btf, &o, None, &|_, _| {}).unwrap().model,
        )
    };
    let plm = FitOptions {
        kind: ModelKind::Plm,
        ..FitOptions::default()
    };
    let e_plm = mae(
        &clean,
        &fit_model(&btf, &plm, None, &|_, _| {}).unwrap().model,
    );
    let (e_orig, e_lm) = (fit(ClusterOn::Original), fit(ClusterOn::LmModel));
    eprintln!("PLM {e_plm} PLM-C original {e_orig} PLM-C lm {e_lm}");
    assert!(e_lm < e_orig, "PLM {e_plm} original {e_orig} lm {e_lm}");
}

fn mae(btf: &RawBtf, m: &PlmcModel) -> f64 {
    let mut r = Vec::new();
    (0..m.views.len())
        .map(|v| {
            m.reconstruct_view(v, &mut r);
            view_error(&btf.load_view(v).unwrap(), &r, btf.encoding()).mae
        })
        .sum::<f64>()
        / m.views.len() as f64
}

#[test]
fn plm_beats_lm_and_plmc_stays_close_to_plm() {
    let btf = synth(2, 12, 1);
    let fit = |kind, clusters| {
        let o = FitOptions {
            kind,
            clusters,
            features: 20,
            ..FitOptions::default()
        };
        fit_model(&btf, &o, None, &|_, _| {}).unwrap().model
    };
    let (lm, plm, plmc) = (
        fit(ModelKind::Lm, 0),
        fit(ModelKind::Plm, 0),
        fit(ModelKind::PlmC, 16),
    );
    let (e_lm, e_plm, e_plmc) = (mae(&btf, &lm), mae(&btf, &plm), mae(&btf, &plmc));
    assert!(e_plm < 0.7 * e_lm, "LM {e_lm} PLM {e_plm}");
    assert!(e_plmc < 1.1 * e_plm, "PLM {e_plm} PLM-C {e_plmc}");
    // K larger than the texel count is handled (K-means stops at the distinct texels).
    let big = fit(ModelKind::PlmC, 1000);
    assert!(mae(&btf, &big) < 1.1 * e_plm);
    // Round trip through the file keeps the reconstruction.
    let bytes = codec::to_bytes(&plmc).unwrap();
    let back = codec::from_bytes(&bytes, Path::new("m.plmc")).unwrap();
    assert_eq!(back, plmc);
}

#[test]
fn constant_data_do_not_break_plmc() {
    let lights = DirectionSet::ubo2003();
    let v = DirectionSet::from_angles_deg(vec![(0.0, 0.0)]);
    let btf = RawBtf::from_f32(
        v,
        lights,
        4,
        4,
        StoredEncoding::Srgb8,
        &vec![0.25; 81 * 16 * 3],
    )
    .unwrap();
    let o = FitOptions {
        clusters: 256,
        ..FitOptions::default()
    };
    let m = fit_model(&btf, &o, None, &|_, _| {}).unwrap().model;
    let mut r = Vec::new();
    m.reconstruct_view(0, &mut r);
    assert!(r.iter().all(|&x| (x - 0.25).abs() < 2e-3), "{:?}", &r[..3]);
    let zero = RawBtf::from_f32(
        btf.views().clone(),
        btf.lights().clone(),
        4,
        4,
        StoredEncoding::Linear,
        &vec![0.0; 81 * 48],
    )
    .unwrap();
    let m = fit_model(&zero, &o, None, &|_, _| {}).unwrap().model;
    m.reconstruct_view(0, &mut r);
    assert!(r.iter().all(|&x| x == 0.0));
}

#[test]
fn killed_fits_resume_from_parts() {
    let btf = synth(3, 6, 2);
    let dir = tempfile::tempdir().unwrap();
    let parts = parts_dir(&dir.path().join("m.plmc"));
    let o = FitOptions {
        clusters: 8,
        ..FitOptions::default()
    };
    let first = fit_model(&btf, &o, Some(&parts), &|_, _| {}).unwrap();
    assert_eq!(first.resumed_views, 0);
    // Simulate a kill: one view missing, one part corrupt; the rest are reused.
    std::fs::remove_file(parts.join("view00001.part")).unwrap();
    let p2 = parts.join("view00002.part");
    let mut b = std::fs::read(&p2).unwrap();
    let last = b.len() - 30;
    b[last] ^= 0xff;
    std::fs::write(&p2, b).unwrap();
    let fitted = AtomicUsize::new(0);
    let second = fit_model(&btf, &o, Some(&parts), &|_, s| {
        if s == Stage::Lm {
            fitted.fetch_add(1, Ordering::Relaxed);
        }
    })
    .unwrap();
    assert_eq!(second.resumed_views, 1);
    assert_eq!(fitted.into_inner(), 2);
    assert_eq!(second.model, first.model);
    // Parts of a fit with other options are not reused.
    let other = FitOptions { seed: 9, ..o };
    assert_eq!(
        fit_model(&btf, &other, Some(&parts), &|_, _| {})
            .unwrap()
            .resumed_views,
        0
    );
}

/// Sharp lobes over a constant floor: at grazing lights the LM images are ~1e-18 while the
/// measured images are 0.02, the case where the old mapping fit (scaled by the image's own
/// largest value) wrote coefficients up to 1e38.
#[test]
fn sharp_lobes_give_bounded_polynomial_coefficients() {
    let lights = DirectionSet::ubo2003();
    let views = DirectionSet::from_angles_deg(vec![(0.0, 0.0)]);
    let mut rng = Pcg32::new(5, 5);
    let side = 8;
    let lobes: Vec<Lobe> = (0..side * side)
        .map(|_| {
            let th = 0.1 * rng.next_f32();
            [
                0.5 + 0.5 * rng.next_f32(),
                th.sin(),
                0.0,
                th.cos(),
                20.0 + 40.0 * rng.next_f32(),
            ]
        })
        .collect();
    let mut data = Vec::new();
    for l in 0..81 {
        for lobe in &lobes {
            for _ in 0..3 {
                let y = lobe::eval(lobe, lights.dirs[l]);
                data.push(y + 0.02 + 0.004 * rng.next_f32());
            }
        }
    }
    let btf = RawBtf::from_f32(views, lights, side, side, StoredEncoding::Linear, &data).unwrap();
    for kind in [ModelKind::Plm, ModelKind::PlmC] {
        let o = FitOptions {
            kind,
            clusters: 16,
            ..FitOptions::default()
        };
        let m = fit_model(&btf, &o, None, &|_, _| {}).unwrap().model;
        // Lobe values reach ~1: every mapping must stay within a few times the data there.
        for a in &m.polys {
            let growth: f32 = a.iter().map(|v| v.abs()).sum();
            assert!(growth < 100.0, "{kind:?} {a:?}");
        }
        let lm = fit_model(
            &btf,
            &FitOptions {
                kind: ModelKind::Lm,
                ..o
            },
            None,
            &|_, _| {},
        );
        assert!(mae(&btf, &m) < mae(&btf, &lm.unwrap().model), "{kind:?}");
    }
}
