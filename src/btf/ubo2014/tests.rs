//! Reading factorised files back, every header variant and colour model, and corrupt input.

use super::*;

/// Deterministic small values exactly representable in f16 (multiples of 1/64 in [-1, 1]).
fn vals(n: usize, seed: u64) -> Vec<f64> {
    let mut s = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (0..n)
        .map(|_| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 40) % 129) as f64 / 64.0 - 1.0
        })
        .collect()
}

fn dirs() -> (DirectionSet, DirectionSet) {
    (
        DirectionSet::from_angles_deg(vec![(0.0, 0.0), (30.0, 90.0)]),
        DirectionSet::from_angles_deg(vec![(0.0, 0.0), (45.0, 0.0), (60.0, 270.0)]),
    )
}

fn fmf(
    scalar_size: u8,
    cosine_flag: u32,
    extended: bool,
    rotations: bool,
    version: u32,
) -> FactorisedBtf {
    let (views, lights) = dirs();
    let (w, h, k) = (3, 2, 5);
    let n_lv = views.len() * lights.len();
    FactorisedBtf {
        kind: PayloadKind::Fmf { extended },
        color: ColorModel::Rgb,
        drr: false,
        version,
        cosine_flag,
        rgb_scale: [1.0, 0.5, 2.0],
        rotations,
        scalar_size,
        views,
        lights,
        width: w,
        height: h,
        u: vec![vals(3 * n_lv * k, 1)],
        sxv: vec![vals(w * h * k, 2)],
        components: vec![k],
    }
}

/// The value the spec says texel (x, y) of channel c has, computed directly from the factors.
fn expected(f: &FactorisedBtf, view: usize, light: usize, x: usize, y: usize) -> [f32; 3] {
    let nl = f.lights.len();
    let xy = y * f.width + x;
    let raw: [f64; 3] = std::array::from_fn(|c| {
        let (ui, row) = match f.kind {
            PayloadKind::Fmf { .. } => (0, (view * nl + light) * 3 + c),
            PayloadKind::Dfmf => (c, view * nl + light),
        };
        let k = f.components[ui];
        let si = if matches!(f.kind, PayloadKind::Fmf { .. }) {
            0
        } else {
            c
        };
        (0..k)
            .map(|j| f.u[ui][row * k + j] * f.sxv[si][xy * k + j])
            .sum()
    });
    let raw = raw.map(|v| v as f32);
    let rgb = match f.kind {
        PayloadKind::Dfmf => f.color.decode(raw),
        _ => raw,
    };
    let cos = f.lights.dirs[light].z;
    std::array::from_fn(|c| {
        // The header's RGB scale is not applied (as btflib and btf.hh).
        let mut v = if f.drr {
            rgb[c].exp() - DRR_EPS
        } else {
            rgb[c]
        };
        // Version 1 headers carry no cosine flag: the reader then assumes 0.
        if f.cosine_flag == 0 || f.version < 2 {
            v *= cos;
        }
        v.max(0.0)
    })
}

fn check_all(f: &FactorisedBtf, btf: &RawBtf, tol: f32) {
    let mut nonzero = 0;
    for v in 0..f.views.len() {
        for l in 0..f.lights.len() {
            for y in 0..f.height {
                for x in 0..f.width {
                    let e = expected(f, v, l, x, y);
                    let g = btf.texel(v, l, x, y);
                    for c in 0..3 {
                        // f16 storage of the decoded value: relative 2^-11.
                        let bound = tol + e[c].abs() * 1.0e-3;
                        assert!(
                            (e[c] - g[c]).abs() <= bound,
                            "v{v} l{l} ({x},{y}) c{c}: {} vs {}",
                            e[c],
                            g[c]
                        );
                        nonzero += (e[c] > 0.0) as usize;
                    }
                }
            }
        }
    }
    assert!(nonzero > 10, "test data should not decode to all zeros");
}

#[test]
fn fmf_round_trips_for_every_scalar_size_and_header_variant() {
    let dir = tempfile::tempdir().unwrap();
    for (i, (s, cos, ext, rot, ver)) in [
        (2u8, 0u32, true, true, 4u32),
        (4, 1, false, false, 1),
        (8, 0, false, true, 3),
        (2, 1, true, false, 2),
    ]
    .into_iter()
    .enumerate()
    {
        let f = fmf(s, cos, ext, rot, ver);
        let p = dir.path().join(format!("t{i}.btf"));
        f.write(&p).unwrap();
        let btf = load_btf(&p).unwrap();
        assert_eq!(btf.views(), &f.views);
        assert_eq!(btf.lights().len(), 3);
        assert!((btf.lights().angles_deg[2].1 - 270.0).abs() < 1e-3);
        check_all(&f, &btf, 1e-5);
        let src = open_btf(&p).unwrap();
        assert_eq!(src.header().cosine_flag, if ver > 1 { cos } else { 0 });
    }
}

#[test]
fn decoding_spans_several_light_groups_and_texel_blocks() {
    // 10 lights (> 8 per task) and 20 × 15 = 300 texels (> one 256-texel block).
    let dir = tempfile::tempdir().unwrap();
    let mut f = fmf(4, 0, false, false, 2);
    f.lights = DirectionSet::from_rings(&[(0.0, 1, 0.0), (40.0, 9, 5.0)]);
    (f.width, f.height) = (20, 15);
    let n_lv = f.views.len() * f.lights.len();
    f.u = vec![vals(3 * n_lv * 5, 3)];
    f.sxv = vec![vals(300 * 5, 4)];
    let p = dir.path().join("big.btf");
    f.write(&p).unwrap();
    check_all(&f, &load_btf(&p).unwrap(), 1e-5);
}

#[test]
fn fmf_dynamic_range_reduction_is_inverted() {
    let dir = tempfile::tempdir().unwrap();
    let mut f = fmf(4, 1, true, false, 4);
    f.drr = true;
    let p = dir.path().join("drr.btf");
    f.write(&p).unwrap();
    check_all(&f, &load_btf(&p).unwrap(), 1e-5);
}

#[test]
fn dfmf_inverts_every_colour_model() {
    let dir = tempfile::tempdir().unwrap();
    let (views, lights) = dirs();
    let (w, h) = (2, 3);
    let n_lv = views.len() * lights.len();
    let ks = vec![4, 2, 3];
    let pca = ColorModel::Pca {
        mean: [0.25, 0.5, 0.125],
        matrix: [0.5, 0.25, 0.0, 0.125, 1.0, 0.0, 0.0, 0.5, 0.75],
    };
    for color in [
        ColorModel::Rgb,
        ColorModel::Yuv,
        pca,
        ColorModel::YCoCg,
        ColorModel::YlogUv,
        ColorModel::YlogUlogVlog,
        ColorModel::YlogUdivYVdivY,
        ColorModel::LogRgb,
    ] {
        let f = FactorisedBtf {
            kind: PayloadKind::Dfmf,
            color,
            drr: false,
            version: 4,
            cosine_flag: 0,
            rgb_scale: [1.0, 1.0, 1.0],
            rotations: true,
            scalar_size: 2,
            views: views.clone(),
            lights: lights.clone(),
            width: w,
            height: h,
            u: ks
                .iter()
                .enumerate()
                .map(|(c, &k)| vals(n_lv * k, 10 + c as u64))
                .collect(),
            sxv: ks
                .iter()
                .enumerate()
                .map(|(c, &k)| vals(w * h * k, 20 + c as u64))
                .collect(),
            components: ks.clone(),
        };
        let p = dir.path().join(format!("dfmf{}.btf", color.code()));
        f.write(&p).unwrap();
        check_all(&f, &load_btf(&p).unwrap(), 1e-4);
    }
    // YUV inverse against a hand-computed value: Y = 0.5, U = 0.1, V = -0.2.
    let rgb = ColorModel::Yuv.decode([0.5, 0.1, -0.2]);
    assert!((rgb[0] - (0.5 - 0.2 * 1.13983)).abs() < 1e-6);
    assert!((rgb[1] - (0.5 - 0.039465 + 0.11612)).abs() < 1e-6);
    assert!((rgb[2] - (0.5 + 0.203211)).abs() < 1e-6);
}

#[test]
fn transposed_images_stacked_payloads_decode() {
    // U rows = texels, S·V rows = (view, light): FMF with channel-interleaved texel rows, and
    // DFMF per channel. The writer stores whatever matrices it is given.
    let dir = tempfile::tempdir().unwrap();
    let (views, lights) = dirs();
    let (w, h, k) = (4usize, 2usize, 3usize);
    let (nl, n_lv, n_xy) = (lights.len(), views.len() * lights.len(), w * h);
    for kind in [PayloadKind::Fmf { extended: false }, PayloadKind::Dfmf] {
        let fmf = matches!(kind, PayloadKind::Fmf { .. });
        let (u, sxv) = if fmf {
            (vec![vals(3 * n_xy * k, 5)], vec![vals(n_lv * k, 6)])
        } else {
            let u = (0..3).map(|c| vals(n_xy * k, 7 + c)).collect();
            (u, (0..3).map(|c| vals(n_lv * k, 17 + c)).collect())
        };
        let f = FactorisedBtf {
            kind,
            color: ColorModel::Rgb,
            drr: false,
            version: 2,
            cosine_flag: 1,
            rgb_scale: [1.0; 3],
            rotations: false,
            scalar_size: 4,
            views: views.clone(),
            lights: lights.clone(),
            width: w,
            height: h,
            components: vec![k; if fmf { 1 } else { 3 }],
            u,
            sxv,
        };
        let p = dir.path().join("t.btf");
        f.write(&p).unwrap();
        let btf = load_btf(&p).unwrap();
        for (v, l, x, y) in [(0, 0, 0, 0), (1, 2, 3, 1), (1, 1, 2, 0), (0, 2, 1, 1)] {
            let xy = y * w + x;
            let lv = v * nl + l;
            for c in 0..3 {
                let (ui, urow, si) = if fmf { (0, xy * 3 + c, 0) } else { (c, xy, c) };
                let want: f64 = (0..k)
                    .map(|j| f.u[ui][urow * k + j] * f.sxv[si][lv * k + j])
                    .sum();
                let got = btf.texel(v, l, x, y)[c];
                let want = want.max(0.0) as f32;
                assert!(
                    (got - want).abs() <= 1e-5 + want * 1e-3,
                    "{kind:?}: {got} vs {want}"
                );
            }
        }
    }
}

#[test]
fn colour_models_follow_the_btflib_formulas() {
    // Hand-evaluated inverses (btflib `undecorrelate`), independent of `to_rgb`'s code paths.
    let close = |a: [f32; 3], b: [f32; 3]| a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-5);
    assert!(close(
        ColorModel::YCoCg.decode([0.5, 0.1, 0.2]),
        [0.4, 0.7, 0.2]
    ));
    let pca = ColorModel::Pca {
        mean: [1.0, 2.0, 3.0],
        // M row by row: rgb_j = Σ_i v_i M(i, j) + mean_j; M(1, 0) = 2 is file element 3.
        matrix: [1.0, 0.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0],
    };
    assert!(close(pca.decode([1.0, 1.0, 1.0]), [4.0, 3.0, 4.0]));
    assert!(close(pca.decode([0.0, 1.0, 0.0]), [3.0, 3.0, 3.0]));
    let y = (0.5f32).ln();
    // Y = exp(ln 0.5) − ε, U = 0.2 · (Y + ε) = 0.1, V = −0.4 · 0.5 = −0.2.
    let got = ColorModel::YlogUdivYVdivY.decode([y, 0.2, -0.4]);
    let yy = 0.5 - DRR_EPS;
    let want = [yy - 0.2 * 1.13983, yy - 0.039465 + 0.11612, yy + 0.203211];
    assert!(close(got, want), "{got:?}");
    assert!(close(
        ColorModel::LogRgb.decode([0.0, y, 0.0]),
        [1.0 - DRR_EPS, 0.5 - DRR_EPS, 1.0 - DRR_EPS]
    ));
}

#[test]
fn truncated_and_corrupt_files_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let good = fmf(2, 0, true, true, 4).to_bytes();
    let p = dir.path().join("bad.btf");
    let err = |bytes: &[u8]| {
        std::fs::write(&p, bytes).unwrap();
        let e = load_btf(&p).unwrap_err().to_string();
        assert!(e.contains("bad.btf"), "{e}");
        e
    };
    // Every truncation point fails cleanly (never panics).
    for cut in (0..good.len()).step_by(7) {
        err(&good[..cut]);
    }
    assert!(err(&good[..good.len() - 1]).contains("truncated"));
    let mut long = good.clone();
    long.extend_from_slice(&[0; 3]);
    assert!(err(&long).contains("trailing"));
    assert!(err(b"!PVF06FC and so on").contains("not supported"));
    assert!(err(b"GIF89a").contains("not a UBO2014"));
    // Absurd view count: refused from the file length, no huge allocation.
    let sig = "!FMF12FCER".len();
    let size = u32::from_le_bytes(good[sig..sig + 4].try_into().unwrap()) as usize;
    let mut huge = good.clone();
    huge[sig + size..sig + size + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(err(&huge).contains("view count"));
    // Wrong header size field.
    let mut hs = good.clone();
    hs[sig] ^= 1;
    err(&hs);
    // Random byte flips anywhere never panic.
    for i in (0..good.len()).step_by(13) {
        let mut b = good.clone();
        b[i] ^= 0xA5;
        std::fs::write(&p, &b).unwrap();
        let _ = load_btf(&p);
    }
}

/// A PCA colour matrix M (rows = principal axes in RGB), row by row as in the file, and its mean.
const PCA_M: [f32; 9] = [0.5, 0.5, 0.5, 0.75, 0.0, -0.75, -0.25, 0.5, -0.25];
const PCA_MEAN: [f32; 3] = [0.0625, 0.125, 0.03125];
/// A decorrelated texel value v.
const PCA_V: [f32; 3] = [0.49079, -0.00509, 0.05361];
/// btflib's rgb = v · M + mean for PCA_V, by hand:
/// r = 0.5·0.49079 + 0.75·(−0.00509) − 0.25·0.05361 + 0.0625 = 0.290675,
/// g = 0.5·0.49079 + 0 + 0.5·0.05361 + 0.125 = 0.3972,
/// b = 0.5·0.49079 − 0.75·(−0.00509) − 0.25·0.05361 + 0.03125 = 0.26706.
/// (The transpose, rgb = M · vᵀ + mean, would give (0.332155, 0.452885, −0.107395 → 0).)
const PCA_RGB: [f32; 3] = [0.290675, 0.3972, 0.26706];

#[test]
fn pca_colour_model_decodes_as_btflib_hand_computed() {
    let pca = ColorModel::Pca {
        mean: PCA_MEAN,
        matrix: PCA_M,
    };
    let got = pca.decode(PCA_V);
    for c in 0..3 {
        assert!((got[c] - PCA_RGB[c]).abs() < 1e-6, "{got:?} vs {PCA_RGB:?}");
    }
}

#[test]
fn a_pca_file_in_btflib_layout_decodes_to_the_hand_computed_texel_and_ignores_rgb_scale() {
    // One texel, one light and view, one component per channel: U = 1, S·V = v_c.
    let one = DirectionSet::from_angles_deg(vec![(0.0, 0.0)]);
    let f = FactorisedBtf {
        kind: PayloadKind::Dfmf,
        color: ColorModel::Pca {
            mean: PCA_MEAN,
            matrix: PCA_M,
        },
        drr: false,
        version: 4,
        cosine_flag: 1,
        rgb_scale: [2.0, 4.0, 8.0],
        rotations: false,
        scalar_size: 4,
        views: one.clone(),
        lights: one,
        width: 1,
        height: 1,
        u: vec![vec![1.0]; 3],
        sxv: PCA_V.iter().map(|&v| vec![v as f64]).collect(),
        components: vec![1; 3],
    };
    let bytes = f.to_bytes();
    // The file holds mean then M row by row (btflib: fwrite(mean), fwrite(M')).
    let mut expect = Vec::new();
    for x in PCA_MEAN.iter().chain(&PCA_M) {
        expect.extend_from_slice(&x.to_le_bytes());
    }
    assert!(
        bytes.windows(expect.len()).any(|w| w == expect.as_slice()),
        "mean and M are not stored in btflib's order"
    );
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("pca.btf");
    std::fs::write(&p, &bytes).unwrap();
    let btf = load_btf(&p).unwrap();
    let got = btf.texel(0, 0, 0, 0);
    for c in 0..3 {
        // f16 storage of the decoded value.
        assert!((got[c] - PCA_RGB[c]).abs() < 4e-4, "{got:?} vs {PCA_RGB:?}");
    }
    assert_eq!(open_btf(&p).unwrap().header().rgb_scale, [2.0, 4.0, 8.0]);
}
