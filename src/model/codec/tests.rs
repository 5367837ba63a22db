//! Round trips and corruption handling of the `.plmc` codec.

use super::*;
use crate::btf::DirectionSet;
use crate::fit::mapping::fit_pairs_in;
use crate::math::Pcg32;
use crate::model::{Lobe, ModelKind, PackedLobe, ValueSpace, ViewParams, polynomial};

fn model(kind: ModelKind, clusters: usize) -> PlmcModel {
    let mut rng = Pcg32::new(4, 4);
    let views = DirectionSet::from_rings(&[(0.0, 1, 0.0), (45.0, 3, 0.0)]);
    let lights = DirectionSet::from_rings(&[(0.0, 1, 0.0), (30.0, 4, 0.0), (60.0, 4, 0.0)]);
    let (w, h) = (5, 3);
    let lobe = |rng: &mut Pcg32| {
        let l: Lobe = [
            rng.next_f32(),
            rng.next_f32() - 0.5,
            rng.next_f32() - 0.5,
            1.0,
            1.0 + 20.0 * rng.next_f32(),
        ];
        PackedLobe::pack(&l)
    };
    let params = (0..views.len())
        .map(|_| match kind {
            ModelKind::PlmC => {
                let k = clusters.min(7);
                ViewParams::Clustered {
                    k,
                    table: (0..3 * k).map(|_| lobe(&mut rng)).collect(),
                    index: (0..w * h * 3)
                        .map(|_| rng.next_below(k as u32) as u16)
                        .collect(),
                }
            }
            _ => ViewParams::Texel((0..w * h * 3).map(|_| lobe(&mut rng)).collect()),
        })
        .collect();
    let polys = if kind.has_polys() {
        (0..views.len() * lights.len() * 3)
            .map(|_| [rng.next_f32(), 1.0, -0.5, 0.25, 1e-3])
            .collect()
    } else {
        Vec::new()
    };
    PlmcModel {
        kind,
        views,
        lights,
        width: w,
        height: h,
        clusters,
        space: if kind == ModelKind::Plm {
            ValueSpace::Srgb
        } else {
            ValueSpace::Linear
        },
        params,
        polys,
    }
}

#[test]
fn round_trip_is_bit_exact_for_every_kind() {
    let dir = tempfile::tempdir().unwrap();
    for (kind, k) in [
        (ModelKind::Lm, 0),
        (ModelKind::Plm, 0),
        (ModelKind::PlmC, 7),
        (ModelKind::PlmC, 300),
    ] {
        let m = model(kind, k);
        let p = dir.path().join(format!("{}-{k}.plmc", kind.name()));
        write(&p, &m).unwrap();
        let r = read(&p).unwrap();
        assert_eq!(r, m);
        assert_eq!(to_bytes(&r).unwrap(), std::fs::read(&p).unwrap());
    }
}

#[test]
fn version_1_files_are_read_and_snapped_polynomials_take_12_bytes() {
    let mut m = model(ModelKind::PlmC, 7);
    let p = Path::new("old.plmc");
    let v1 = to_bytes_version(&m, None, 1).unwrap();
    assert_eq!(v1[4..8], 1u32.to_le_bytes());
    assert_eq!(from_bytes(&v1, p).unwrap(), m);
    // Arbitrary coefficients have no packed form: f32 records keep them exact.
    let raw = to_bytes(&m).unwrap();
    assert_eq!(from_bytes(&raw, p).unwrap(), m);
    assert!(m.polys.iter().all(|a| polynomial::encode(a).is_none()));
    // Mappings as the fitter leaves them (snapped) are packed, and still exact.
    let mut rng = Pcg32::new(2, 2);
    for a in m.polys.iter_mut() {
        let x: Vec<f32> = (0..100).map(|i| i as f32 / 99.0).collect();
        let g = 0.5 + rng.next_f32();
        let y: Vec<f32> = x.iter().map(|&v| 0.9 * v.powf(g) + 0.02).collect();
        *a = fit_pairs_in(&x, &y, 1.0);
    }
    let packed = to_bytes(&m).unwrap();
    assert_eq!(from_bytes(&packed, p).unwrap(), m);
    assert!(m.polys.iter().all(|a| polynomial::encode(a).is_some()));
    assert!(poly_bytes(&m.polys).unwrap() <= 1 + 12 * m.polys.len());
    let mut future = packed.clone();
    future[4] = 3;
    let e = from_bytes(&future, p).unwrap_err().to_string();
    assert!(e.contains("version 3") && e.contains("old.plmc"), "{e}");
}

#[test]
fn tile_sections_round_trip_and_tile_sizes_must_divide_the_planes() {
    let mut m = model(ModelKind::PlmC, 7);
    let t = TileSection {
        tile_w: 5,
        tile_h: 1,
        payload: vec![1, 2, 3],
    };
    let bytes = to_bytes_tiled(&m, Some(&t)).unwrap();
    let p = Path::new("tiled.plmc");
    assert_eq!(from_bytes_tiled(&bytes, p).unwrap(), (m.clone(), Some(t)));
    assert_eq!(from_bytes(&bytes, p).unwrap(), m);
    assert_eq!(from_bytes_tiled(&to_bytes(&m).unwrap(), p).unwrap().1, None);
    let bad = TileSection {
        tile_w: 2,
        tile_h: 3,
        payload: Vec::new(),
    };
    assert!(to_bytes_tiled(&m, Some(&bad)).is_err());
    m.kind = ModelKind::Lm;
    assert!(to_bytes_tiled(&m, Some(&bad)).is_err());
}

#[test]
fn corrupt_and_truncated_files_give_clear_errors() {
    let m = model(ModelKind::PlmC, 7);
    let bytes = to_bytes(&m).unwrap();
    let p = Path::new("mat.plmc");
    // Every single-byte flip after the magic is caught (CRC or structural check).
    for i in 4..bytes.len() {
        let mut b = bytes.clone();
        b[i] ^= 0x41;
        let e = from_bytes(&b, p).expect_err("corruption not detected");
        assert!(e.to_string().contains("mat.plmc"), "{e}");
    }
    for cut in [0, 3, 10, 40, bytes.len() / 2, bytes.len() - 1] {
        let e = from_bytes(&bytes[..cut], p).unwrap_err().to_string();
        assert!(e.contains("mat.plmc"), "{e}");
    }
    let mut b = bytes.clone();
    b[30] ^= 1;
    assert!(from_bytes(&b, p).unwrap_err().to_string().contains("CRC"));
    let e = from_bytes(&bytes[..bytes.len() - 10], p)
        .unwrap_err()
        .to_string();
    assert!(e.contains("truncated") || e.contains("remain"), "{e}");
    assert!(
        read(Path::new("/nonexistent/x.plmc"))
            .unwrap_err()
            .to_string()
            .contains("x.plmc")
    );
}
