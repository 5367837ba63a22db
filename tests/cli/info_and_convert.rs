//! `btfpt info` / `btfpt convert` end to end on a tiny BTF made here.
use crate::common::btfpt;

use btfpt::btf::{self, DirectionSet, RawBtf, StoredEncoding};

#[test]
fn info_reports_a_cache_and_fails_clearly_on_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let d = DirectionSet::from_angles_deg(vec![(0.0, 0.0), (30.0, 0.0), (60.0, 180.0)]);
    // R = 0.25 everywhere, G from 0 to 1, B = 2 (values above 1 are legal in linear data).
    let n = 3 * 3 * 2 * 2;
    let data: Vec<f32> = (0..n)
        .flat_map(|i| [0.25, i as f32 / (n - 1) as f32, 2.0])
        .collect();
    let raw = RawBtf::from_f32(d.clone(), d, 2, 2, StoredEncoding::Linear, &data).unwrap();
    let cache = dir.path().join("t.btfc");
    btf::cache::write_raw(&raw, &cache).unwrap();

    let out = btfpt().arg("info").arg(&cache).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("btfpt cache .btfc"), "{text}");
    assert!(text.contains("3 (θ up to 60.0°) views × 3"), "{text}");
    assert!(text.contains("2 × 2 texels"), "{text}");
    assert!(
        text.contains("R: min 0.25000  max 0.25000  mean 0.25000"),
        "{text}"
    );
    // G's mean is 0.5 before the f16 rounding of the stored values (0.49994 after).
    assert!(
        text.contains("G: min 0.00000  max 1.00000  mean 0.4999"),
        "{text}"
    );
    assert!(text.contains("B: min 2.00000  max 2.00000"), "{text}");

    // Converting the cache to a .btfc again gives identical data.
    let again = dir.path().join("u.btfc");
    let st = btfpt()
        .arg("convert")
        .arg(&cache)
        .arg(&again)
        .status()
        .unwrap();
    assert!(st.success());
    assert_eq!(btf::load_raw(&again).unwrap().data(), raw.data());

    let bad = dir.path().join("broken.btfc");
    std::fs::write(&bad, b"BTFC but far too short to be a cache").unwrap();
    let out = btfpt().arg("info").arg(&bad).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("broken.btfc"));
}

#[test]
fn info_and_convert_read_a_ubo2014_file() {
    use btfpt::btf::ubo2014::{ColorModel, FactorisedBtf, PayloadKind};
    let dir = tempfile::tempdir().unwrap();
    let views = DirectionSet::from_angles_deg(vec![(0.0, 0.0), (45.0, 90.0)]);
    let lights = DirectionSet::from_angles_deg(vec![(0.0, 0.0), (60.0, 0.0)]);
    // Rank-1 FMF: U = 1 for every (view, light, channel) row, S·V = 0.5 per texel → 0.5 · cos θ_l.
    let f = FactorisedBtf {
        kind: PayloadKind::Fmf { extended: true },
        color: ColorModel::Rgb,
        drr: false,
        version: 4,
        cosine_flag: 0,
        rgb_scale: [1.0; 3],
        rotations: true,
        scalar_size: 2,
        views,
        lights,
        width: 3,
        height: 2,
        u: vec![vec![1.0; 3 * 4]],
        sxv: vec![vec![0.5; 6]],
        components: vec![1],
    };
    let p = dir.path().join("m.btf");
    f.write(&p).unwrap();
    let out = btfpt().arg("info").arg(&p).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("!FMF12FCER version 4, cosine flag 0"),
        "{text}"
    );
    // Lights at θ = 0 and 60°: values 0.5 and 0.25, mean 0.375.
    assert!(
        text.contains("R: min 0.25000  max 0.50000  mean 0.37500"),
        "{text}"
    );
    let cache = dir.path().join("m.btfc");
    assert!(
        btfpt()
            .arg("convert")
            .arg(&p)
            .arg(&cache)
            .status()
            .unwrap()
            .success()
    );
    assert_eq!(
        btf::load_raw(&cache).unwrap().data(),
        btf::load_raw(&p).unwrap().data()
    );
}

#[test]
fn info_summarises_a_plmc_model_and_names_a_truncated_one() {
    let model = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/showcase/materials/leather.plmc"
    );
    let out = btfpt().args(["info", model]).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(
        text.contains("model:       plmc") && text.contains("clusters:    256"),
        "{text}"
    );
    assert!(text.contains("64 × 64 texels"), "{text}");

    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("cut.plmc");
    let bytes = std::fs::read(model).unwrap();
    std::fs::write(&bad, &bytes[..2000]).unwrap();
    let out = btfpt().args(["info"]).arg(&bad).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("cut.plmc") && err.contains("truncated") && !err.contains("panicked"),
        "{err}"
    );
}
