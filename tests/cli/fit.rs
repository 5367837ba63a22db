//! `btfpt fit` / `btfpt eval` end to end on a tiny simulated material: fit, evaluate to JSON and
//! PNG, resume from part files, and clear errors for corrupt or truncated model files.
use crate::common::btfpt_output as btfpt;
use std::path::Path;

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 temp path")
}

#[test]
fn fit_eval_resume_and_corrupt_files() {
    let dir = tempfile::tempdir().expect("tempdir");
    let data = dir.path().join("wool8");
    let (ok, _, err) = btfpt(&[
        "synth",
        "wool",
        "--size",
        "8",
        "--format",
        "exr",
        "--strata",
        "1",
        "-o",
        s(&data),
    ]);
    assert!(ok, "synth failed: {err}");

    // Fit PLM-C (K = 16 of 64 texels, 6 feature images) and keep the per-view parts.
    let model = dir.path().join("wool.plmc");
    let fit = |extra: &[&str]| {
        let mut a = vec![
            "fit",
            s(&data),
            "-o",
            s(&model),
            "--model",
            "plmc",
            "--clusters",
            "16",
            "--features",
            "6",
        ];
        a.extend_from_slice(extra);
        btfpt(&a)
    };
    let (ok, out, err) = fit(&["--keep-parts"]);
    assert!(ok, "fit failed: {err}");
    assert!(out.contains("plmc model"), "{out}");
    let first = std::fs::read(&model).expect("model written");
    let parts = dir.path().join("wool.plmc.parts");
    assert_eq!(std::fs::read_dir(&parts).expect("parts kept").count(), 81);

    // Resume: one part deleted, one corrupted; the other 79 views are reused and the model is
    // identical; without --keep-parts the part directory is removed afterwards.
    std::fs::remove_file(parts.join("view00005.part")).expect("delete a part");
    let p7 = parts.join("view00007.part");
    let mut b = std::fs::read(&p7).expect("read a part");
    let mid = b.len() / 2;
    b[mid] ^= 0x5a;
    std::fs::write(&p7, b).expect("corrupt a part");
    let (ok, out, err) = fit(&[]);
    assert!(ok, "resumed fit failed: {err}");
    assert!(out.contains("79 views resumed"), "{out}");
    assert_eq!(std::fs::read(&model).expect("model"), first);
    assert!(!parts.exists());

    // Evaluate: the table as JSON with all four models and a per-view plot.
    let json = dir.path().join("r.json");
    let png = dir.path().join("r.png");
    let (ok, out, err) = btfpt(&[
        "eval",
        s(&model),
        "--against",
        s(&data),
        "--json",
        s(&json),
        "--plot",
        s(&png),
    ]);
    assert!(ok, "eval failed: {err}");
    assert!(out.contains("plmc") && out.contains("(file)"), "{out}");
    let r: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json).expect("json written")).expect("valid json");
    let raw = r["raw_bytes"].as_f64().expect("raw_bytes");
    assert_eq!(raw, (81 * 81 * 64 * 3) as f64);
    for m in ["lm", "plm", "plmc", "pca"] {
        let e = &r["models"][m];
        for key in ["mae", "mae_linear", "rmse", "bytes", "ratio"] {
            let v = e[key].as_f64().unwrap_or(f64::NAN);
            assert!(v.is_finite() && v >= 0.0, "{m}.{key} = {v}");
        }
        assert_eq!(
            e["per_view_mae"].as_array().map(|a| a.len()),
            Some(81),
            "{m}"
        );
    }
    let mae = |m: &str| r["models"][m]["mae"].as_f64().unwrap_or(f64::NAN);
    assert!(
        mae("plm") < mae("lm"),
        "PLM {} vs LM {}",
        mae("plm"),
        mae("lm")
    );
    assert_eq!(
        r["models"]["plmc"]["bytes"].as_f64(),
        Some(first.len() as f64),
        "PLM-C size is the file's"
    );
    assert!(std::fs::metadata(&png).expect("plot written").len() > 1000);

    // Corrupt and truncated model files: clear errors naming the file.
    let bad = dir.path().join("bad.plmc");
    let mut b = first.clone();
    let mid = b.len() / 2;
    b[mid] ^= 0x01;
    std::fs::write(&bad, &b).expect("write");
    let (ok, _, err) = btfpt(&["eval", s(&bad), "--against", s(&data)]);
    assert!(!ok);
    assert!(err.contains("bad.plmc") && err.contains("CRC"), "{err}");
    std::fs::write(&bad, &first[..first.len() / 3]).expect("write");
    let (ok, _, err) = btfpt(&["eval", s(&bad), "--against", s(&data)]);
    assert!(!ok);
    assert!(err.contains("bad.plmc"), "{err}");
    // A model against data of another size is refused.
    let other = dir.path().join("wool4");
    let (ok, _, _) = btfpt(&[
        "synth",
        "wool",
        "--size",
        "4",
        "--format",
        "exr",
        "--strata",
        "1",
        "-o",
        s(&other),
    ]);
    assert!(ok);
    let (ok, _, err) = btfpt(&["eval", s(&model), "--against", s(&other)]);
    assert!(!ok);
    assert!(err.contains("does not match"), "{err}");
}
