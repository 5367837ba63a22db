//! A UBO2014-direction material (151 views × 151 lights, only a `.btfc` cache can hold it) fits
//! end to end through the memory-mapped cache, whole and split by views, to the same bytes.
use crate::common::btfpt_output as btfpt;
use std::path::Path;

fn s(p: &Path) -> &str {
    p.to_str().expect("utf-8 temp path")
}

#[test]
fn ubo2014_directions_fit_from_the_mapped_cache_whole_and_split() {
    let dir = tempfile::tempdir().expect("tempdir");
    let data = dir.path().join("w14.btfc");
    let (ok, _, err) = btfpt(&[
        "synth",
        "wool",
        "--size",
        "3",
        "--directions",
        "ubo2014",
        "--strata",
        "1",
        "-o",
        s(&data),
    ]);
    assert!(ok, "synth failed: {err}");
    let fit = |model: &Path, extra: &[&str]| {
        let mut a = vec![
            "fit",
            s(&data),
            "-o",
            s(model),
            "--clusters",
            "4",
            "--features",
            "6",
        ];
        a.extend_from_slice(extra);
        btfpt(&a)
    };
    let whole = dir.path().join("whole.plmc");
    let (ok, out, err) = fit(&whole, &[]);
    assert!(ok, "fit failed: {err}");
    assert!(out.contains("plmc model"), "{out}");
    let (ok, info, err) = btfpt(&["info", s(&whole)]);
    assert!(ok, "info failed: {err}");
    assert!(
        info.contains("151"),
        "expected the 151 UBO2014 views: {info}"
    );

    // Split over two "machines" by views, then assembled: the same bytes as the one-process fit.
    let split = dir.path().join("split.plmc");
    for part in ["0/2", "1/2"] {
        let (ok, out, err) = fit(&split, &["--views", part]);
        assert!(ok, "fit --views {part} failed: {err}");
        assert!(!split.exists(), "{out}");
    }
    let (ok, out, err) = fit(&split, &[]);
    assert!(ok, "assembly failed: {err}");
    assert!(out.contains("151 views resumed"), "{out}");
    assert_eq!(
        std::fs::read(&whole).expect("whole model"),
        std::fs::read(&split).expect("split model"),
        "a fit split by views must assemble to the one-process bytes"
    );
}
