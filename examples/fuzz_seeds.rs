//! Writes small, valid seed inputs for the `ubo2014` and `btfc` fuzz targets, which have no
//! natural corpus: every UBO2014 payload kind, scalar size and header variant our reader accepts,
//! and `.btfc` caches of two shapes. The fuzzer mutates from these, so it reaches the payload
//! decoders instead of stopping at the signature check.
//!
//! `cargo run --release --example fuzz_seeds -- fuzz/corpus`

use btfpt::btf::ubo2014::{ColorModel, FactorisedBtf, PayloadKind};
use btfpt::btf::{DirectionSet, RawBtf, StoredEncoding, cache};
use std::path::PathBuf;

/// Deterministic values in [-1, 1], exactly representable in f16.
fn vals(n: usize, seed: u64) -> Vec<f64> {
    let mut s = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            ((s >> 40) % 129) as f64 / 64.0 - 1.0
        })
        .collect()
}

fn main() -> anyhow::Result<()> {
    let root = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "fuzz/corpus".into()),
    );
    let ubo = root.join("ubo2014");
    let btfc = root.join("btfc");
    std::fs::create_dir_all(&ubo)?;
    std::fs::create_dir_all(&btfc)?;

    let views = DirectionSet::from_angles_deg(vec![(0.0, 0.0), (30.0, 90.0)]);
    let lights = DirectionSet::from_angles_deg(vec![(0.0, 0.0), (45.0, 0.0), (60.0, 270.0)]);
    let (w, h, k) = (3usize, 2usize, 2usize);
    let n_lv = views.len() * lights.len();
    let colors = [
        ColorModel::Rgb,
        ColorModel::Yuv,
        ColorModel::Pca {
            mean: [0.1, 0.2, 0.3],
            matrix: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        },
        ColorModel::YCoCg,
        ColorModel::YlogUv,
        ColorModel::YlogUlogVlog,
        ColorModel::YlogUdivYVdivY,
    ];
    let mut n = 0;
    for scalar_size in [2u8, 4, 8] {
        for (version, rotations, cosine_flag) in [(1, false, 0), (2, false, 1), (4, true, 0)] {
            for extended in [false, true] {
                let f = FactorisedBtf {
                    kind: PayloadKind::Fmf { extended },
                    color: ColorModel::Rgb,
                    drr: extended,
                    version,
                    cosine_flag,
                    rgb_scale: [1.0, 0.5, 2.0],
                    rotations,
                    scalar_size,
                    views: views.clone(),
                    lights: lights.clone(),
                    width: w,
                    height: h,
                    u: vec![vals(3 * n_lv * k, n)],
                    sxv: vec![vals(w * h * k, n + 1)],
                    components: vec![k],
                };
                f.write(&ubo.join(format!("fmf-{n}.btf")))?;
                n += 1;
            }
        }
        for color in colors {
            let f = FactorisedBtf {
                kind: PayloadKind::Dfmf,
                color,
                drr: false,
                version: 3,
                cosine_flag: 1,
                rgb_scale: [1.0, 1.0, 1.0],
                rotations: false,
                scalar_size,
                views: views.clone(),
                lights: lights.clone(),
                width: w,
                height: h,
                u: (0..3).map(|c| vals(n_lv * k, n + c)).collect(),
                sxv: (0..3).map(|c| vals(w * h * k, n + 7 + c)).collect(),
                components: vec![k; 3],
            };
            f.write(&ubo.join(format!("dfmf-{n}.btf")))?;
            n += 1;
        }
    }

    for (i, (v, l, w, h)) in [(&views, &lights, 3, 2), (&lights, &views, 1, 4)]
        .into_iter()
        .enumerate()
    {
        let count = v.len() * l.len() * w * h * 3;
        let data: Vec<f32> = vals(count, 99 + i as u64)
            .iter()
            .map(|x| x.abs() as f32)
            .collect();
        let raw = RawBtf::from_f32(v.clone(), l.clone(), w, h, StoredEncoding::Linear, &data)?;
        cache::write_raw(&raw, &btfc.join(format!("seed-{i}.btfc")))?;
    }
    println!(
        "wrote {n} .btf seeds and 2 .btfc seeds under {}",
        root.display()
    );
    Ok(())
}
