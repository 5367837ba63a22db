//! The committed Mitsuba references (`reference-images/<name>/`) and how a test render is scored
//! against them: shared by the raw-BTF and PLM-C regression tests.
#![allow(dead_code)]

use btfpt::io::{RgbImage, read_image};
use btfpt::metrics::{Comparison, predicted_variance};
use btfpt::render::RenderScene;
use btfpt::render::film::{RenderSettings, RenderState};
use btfpt::scene::Scene;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

/// Block size of the block z-test, in pixels.
pub const BLOCK: usize = 4;
/// Family-wise significance level of the block z-test.
pub const ALPHA: f64 = 0.01;

/// The repository root (scenes/ and reference-images/ are found from here).
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The committed Mitsuba reference of a scene.
pub struct Reference {
    pub mean: RgbImage,
    /// Variance of the reference mean.
    pub var: RgbImage,
    /// Per-sample variance (predicts the variance of a test render at n spp as sample_var / n).
    pub sample_var: RgbImage,
}

/// Reads `reference-images/<name>/<name>{,_var,_sample_var}.exr`.
pub fn reference(name: &str) -> Reference {
    let dir = root().join("reference-images").join(name);
    let read = |suffix: &str| {
        let p = dir.join(format!("{name}{suffix}.exr"));
        read_image(&p).unwrap_or_else(|e| panic!("reference {}: {e}", p.display()))
    };
    Reference {
        mean: read(""),
        var: read("_var"),
        sample_var: read("_sample_var"),
    }
}

/// Renders the whole film of `scene` at `spp`, asserting that no sample was NaN/Inf.
pub fn render(scene: Scene, spp: u32, seed: u64) -> RgbImage {
    let (w, h) = (scene.camera.width, scene.camera.height);
    let rs = RenderScene::new(scene).unwrap();
    let mut state = RenderState::new(RenderSettings {
        width: w,
        height: h,
        crop: [0, 0, w, h],
        spp_begin: 0,
        spp_end: spp,
        seed,
    })
    .unwrap();
    let stop = AtomicBool::new(false);
    while !state.is_complete() {
        btfpt::render::driver::run_pass(&rs, &mut state, 1 << 20, &stop, &|_, _| {});
    }
    assert_eq!(state.invalid_samples(), 0, "NaN/inf samples");
    state.mean_image()
}

/// The runs of the committed calibration (`reference-images/<name>/<name>_calibration.json`,
/// written by `calibrate.py`: independent Mitsuba renders scored against the reference) at
/// `spp`; panics unless there are at least `min` of them.
pub fn calibration_runs(name: &str, spp: u32, min: usize) -> Vec<serde_json::Value> {
    let p = root()
        .join("reference-images")
        .join(name)
        .join(format!("{name}_calibration.json"));
    let text = std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let json: serde_json::Value =
        serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    let runs: Vec<serde_json::Value> = json["runs"]
        .as_array()
        .unwrap_or_else(|| panic!("{}: calibration without runs", p.display()))
        .iter()
        .filter(|r| r["spp"].as_u64() == Some(spp as u64))
        .cloned()
        .collect();
    assert!(
        runs.len() >= min,
        "{name}: need ≥ {min} calibration runs at {spp} spp, found {}",
        runs.len()
    );
    runs
}

/// What a test render scores against a reference: `btfpt::metrics` (the code behind
/// `btfpt compare`, the same scoring as reference-images/calibrate.py, so the calibration ranges
/// apply), with the test's variance predicted from the reference's per-sample variance.
pub fn score(test: &RgbImage, spp: u32, r: &Reference) -> Comparison {
    let var = predicted_variance(Some(&r.sample_var), spp, Some(&r.var)).unwrap();
    Comparison::new(test, &r.mean, Some(&var), BLOCK, ALPHA).unwrap()
}
