//! `btfpt compare` end to end on small synthetic EXRs: pass, fail, and every kind of bad input
//! gives a non-zero exit code with a message naming the problem.
use crate::common::btfpt;

use btfpt::io::{RgbImage, write_exr};
use std::path::{Path, PathBuf};
use std::process::Output;

fn image(w: usize, h: usize, f: impl Fn(usize) -> f32) -> RgbImage {
    RgbImage {
        width: w,
        height: h,
        data: (0..3 * w * h).map(f).collect(),
    }
}

/// A 32×16 reference `ref.exr` with `ref_var.exr` (1e-8) and `ref_sample_var.exr` (0.01 per
/// sample, so σ = 0.0125 at 64 spp), and a test image within noise of it.
fn setup(dir: &Path) -> (PathBuf, PathBuf) {
    let (w, h) = (32, 16);
    let r = image(w, h, |i| 0.3 + 0.01 * (i % 13) as f32);
    write_exr(&dir.join("ref.exr"), &r).unwrap();
    write_exr(&dir.join("ref_var.exr"), &image(w, h, |_| 1e-8)).unwrap();
    write_exr(&dir.join("ref_sample_var.exr"), &image(w, h, |_| 0.01)).unwrap();
    // Deterministic "noise" of ±0.5 σ.
    let t = image(w, h, |i| {
        r.data[i] + if i % 2 == 0 { 0.006 } else { -0.006 }
    });
    write_exr(&dir.join("test.exr"), &t).unwrap();
    (dir.join("test.exr"), dir.join("ref.exr"))
}

fn run(args: &[&dyn AsRef<std::ffi::OsStr>]) -> Output {
    let mut c = btfpt();
    c.arg("compare");
    for a in args {
        c.arg(a);
    }
    c.output().unwrap()
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

#[test]
fn passes_and_writes_json_and_diff() {
    let dir = tempfile::tempdir().unwrap();
    let (t, r) = setup(dir.path());
    let json = dir.path().join("out.json");
    let diff = dir.path().join("diff.png");
    // --spp alone finds ref_sample_var.exr and ref_var.exr beside the reference.
    let o = run(&[&t, &r, &"--spp", &"64", &"--json", &json, &"--diff", &diff]);
    let s = text(&o);
    assert!(o.status.success(), "{s}");
    assert!(s.contains("PASS") && s.contains("relMSE") && s.contains("ref_sample_var.exr"));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["passed"], true);
    assert_eq!(v["comparison"]["pixel_test"]["failing"], 0);
    assert_eq!(v["comparison"]["block_test"]["cells"], 8 * 4);
    // z = ±0.006 / 0.0125 = ±0.48 everywhere.
    let mz = v["comparison"]["pixel_test"]["max_abs_z"].as_f64().unwrap();
    assert!((mz - 0.48).abs() < 0.01, "{mz}");
    assert!(std::fs::metadata(&diff).unwrap().len() > 0);
    // No variance at all: metrics only, exit 0.
    let o = run(&[&t, &r]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("no z-test"));
}

#[test]
fn fails_on_bias_with_a_clear_message() {
    let dir = tempfile::tempdir().unwrap();
    let (_, r) = setup(dir.path());
    let biased = dir.path().join("biased.exr");
    let img = btfpt::io::read_image(&r).unwrap();
    let scaled = image(img.width, img.height, |i| img.data[i] * 1.25);
    write_exr(&biased, &scaled).unwrap();
    let o = run(&[&biased, &r, &"--spp", &"64"]);
    let s = text(&o);
    assert!(!o.status.success(), "{s}");
    assert!(
        s.contains("comparison FAILED") && s.contains("blocks fail the z-test"),
        "{s}"
    );
    // At 2 spp (σ ≈ 0.07) no pixel fails (z ≤ 1.5), but 4×4 blocks (z ≈ 5) and mean z do.
    let o = run(&[
        &biased,
        &r,
        &"--sample-variance",
        &dir.path().join("ref_sample_var.exr"),
        &"--spp",
        &"2",
        &"--max-failing-blocks",
        &"0",
        &"--max-abs-mean-z",
        &"0.1",
    ]);
    let s = text(&o);
    assert!(!o.status.success(), "{s}");
    assert!(
        s.contains("blocks fail") && s.contains("global bias"),
        "{s}"
    );
    // relMSE bound alone.
    let o = run(&[&biased, &r, &"--max-relmse", &"1e-6"]);
    assert!(!o.status.success());
    assert!(text(&o).contains("relMSE"));
}

#[test]
fn bad_input_is_reported() {
    let dir = tempfile::tempdir().unwrap();
    let (t, r) = setup(dir.path());
    let d = dir.path();
    // Missing file.
    let o = run(&[&d.join("nope.exr"), &r]);
    assert!(!o.status.success());
    assert!(text(&o).contains("nope.exr"), "{}", text(&o));
    // Different sizes.
    let small = d.join("small.exr");
    write_exr(&small, &image(8, 8, |_| 0.5)).unwrap();
    let o = run(&[&small, &r]);
    assert!(!o.status.success());
    assert!(text(&o).contains("sizes differ"), "{}", text(&o));
    // NaN in the test image.
    let nan = d.join("nan.exr");
    write_exr(
        &nan,
        &image(32, 16, |i| if i == 40 { f32::NAN } else { 0.5 }),
    )
    .unwrap();
    let o = run(&[&nan, &r]);
    assert!(!o.status.success());
    let s = text(&o);
    assert!(s.contains("non-finite") && s.contains("(13, 0)"), "{s}");
    // Variance of the wrong size.
    let o = run(&[&t, &r, &"--variance", &small]);
    assert!(!o.status.success());
    assert!(text(&o).contains("sizes differ"));
    // --spp without a sample variance beside the reference.
    let lone = d.join("lone");
    std::fs::create_dir(&lone).unwrap();
    std::fs::copy(&r, lone.join("ref.exr")).unwrap();
    let o = run(&[&t, &lone.join("ref.exr"), &"--spp", &"64"]);
    assert!(!o.status.success());
    assert!(
        text(&o).contains("ref_sample_var.exr does not exist"),
        "{}",
        text(&o)
    );
    // Bad numbers.
    for bad in [
        vec!["--spp", "0"],
        vec!["--alpha", "2"],
        vec!["--block", "0"],
        vec!["--block", "64"],
        vec!["--max-relmse", "-1"],
    ] {
        let mut c = btfpt();
        c.arg("compare").arg(&t).arg(&r).args(&bad);
        let o = c.output().unwrap();
        assert!(!o.status.success(), "{bad:?} accepted");
    }
}
