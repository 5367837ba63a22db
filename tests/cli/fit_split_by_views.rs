//! `btfpt fit --views`: a fit split by views over several processes assembles to the byte-identical
//! model of a one-process fit without refitting, also with `--tile`; malformed or overlapping
//! `--views` and parts of another fit are refused with clear errors.

use btfpt::btf::{self, DirectionSet, RawBtf, StoredEncoding};
use std::path::{Path, PathBuf};

/// Runs btfpt; returns (exit code, stdout, stderr).
fn btfpt(args: &[&str]) -> (i32, String, String) {
    let out = crate::common::btfpt()
        .args(args)
        .env("RAYON_NUM_THREADS", "2")
        .output()
        .expect("run btfpt");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A 5×4-texel BTF on the 81 UBO2003 directions (or `views` of them) with texture.
fn write_data(path: &Path, w: usize, h: usize, views: usize) {
    let lights = DirectionSet::ubo2003();
    let vdirs = DirectionSet::from_angles_deg(lights.angles_deg[..views].to_vec());
    let mut data = Vec::with_capacity(views * 81 * w * h * 3);
    for v in 0..views {
        for l in 0..81 {
            let k = lights.dirs[l].z.max(0.05);
            for t in 0..w * h {
                let g = 0.2 + 0.5 * (((v * 7 + l * 3 + t * 11) % 13) as f32 / 13.0);
                data.extend_from_slice(&[g * k, g * k * 0.7, g * k * 0.4]);
            }
        }
    }
    let raw = RawBtf::from_f32(vdirs, lights, w, h, StoredEncoding::Linear, &data).unwrap();
    btf::cache::write_raw(&raw, path).unwrap();
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

const OPTS: [&str; 4] = ["--clusters", "4", "--features", "5"];

/// `btfpt fit data -o out` with [`OPTS`], then `model` (the options that define the model) and
/// `extra` (how this run is split).
fn fit_with(data: &Path, out: &Path, model: &[&str], extra: &[&str]) -> (i32, String, String) {
    let mut a = vec!["fit", s(data), "-o", s(out)];
    a.extend_from_slice(model);
    a.extend_from_slice(&OPTS);
    a.extend_from_slice(extra);
    btfpt(&a)
}

/// The one-process fit of `data` (beside it, as `ref.plmc`) that split fits must reproduce.
fn reference_fit(data: &Path, model: &[&str]) -> PathBuf {
    let reference = data.with_file_name("ref.plmc");
    let (code, _, err) = fit_with(data, &reference, model, &[]);
    assert_eq!(code, 0, "{err}");
    reference
}

#[test]
fn fit_split_by_views_assembles_byte_identically_and_refuses_bad_views_and_foreign_parts() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("m.btfc");
    write_data(&data, 5, 4, 81);
    let fit = |out: &Path, extra: &[&str]| fit_with(&data, out, &[], extra);
    let reference = reference_fit(&data, &[]);

    let out = dir.path().join("split.plmc");
    let parts = dir.path().join("split.plmc.parts");
    // Bad --views: clear error, exit 1, nothing fitted or created.
    for (views, msg) in [
        ("5..", "end '' is not a non-negative integer"),
        ("0..10,5..15", "0..10 and 5..15 overlap"),
        ("10..5", "empty"),
        ("0..82", "beyond the 81 views"),
        ("3/3", "part must be in 0..3"),
        ("two", "'two' is not a non-negative integer"),
    ] {
        let (code, _, err) = fit(&out, &["--views", views]);
        assert_eq!(code, 1, "--views {views}: {err}");
        assert!(
            err.contains(&format!("--views '{views}'")) && err.contains(msg),
            "--views {views}: {err}"
        );
        assert!(!parts.exists() && !out.exists(), "--views {views}");
    }

    // Three processes: part 1 of 3, then an explicit list that overlaps part 1's views (reused,
    // not refitted), then the rest. None writes the model; each says what is still missing.
    let (code, text, err) = fit(&out, &["--views", "1/3"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        text.contains("views 27..54: 27 fitted, 0 already"),
        "{text}"
    );
    assert!(
        text.contains("54 of 81 views still missing: 0..27, 54..81"),
        "{text}"
    );
    assert!(!out.exists(), "a --views run must not write the model");
    let (code, text, err) = fit(&out, &["--views", "0..30,60..81"]);
    assert_eq!(code, 0, "{err}");
    assert!(text.contains("48 fitted, 3 already"), "{text}");
    assert!(
        text.contains("6 of 81 views still missing: 54..60"),
        "{text}"
    );
    let (code, text, err) = fit(&out, &["--views", "54..60"]);
    assert_eq!(code, 0, "{err}");
    assert!(text.contains("all 81 views have parts"), "{text}");
    assert!(!out.exists());

    // Parts of another fit are refused, never mixed, and left as they were.
    let before = std::fs::read(parts.join("view00000.part")).unwrap();
    for other in [
        &["--views", "0..3", "--refine-iters", "0"][..],
        &["--seed", "4"],
    ] {
        let (code, _, err) = fit(&out, other);
        assert_eq!(code, 1, "{other:?}: {err}");
        assert!(
            err.contains("view00000.part")
                && err.contains("other options")
                && err.contains("never mixed"),
            "{other:?}: {err}"
        );
    }
    assert_eq!(std::fs::read(parts.join("view00000.part")).unwrap(), before);
    assert!(!out.exists());

    // Assembly: every part found, nothing refitted, the one-process model's bytes.
    let (code, text, err) = fit(&out, &[]);
    assert_eq!(code, 0, "{err}");
    assert!(text.contains("81 views resumed"), "{text}");
    assert!(
        std::fs::read(&reference).unwrap() == std::fs::read(&out).unwrap(),
        "the assembled model differs from the one-process fit"
    );
    assert!(!parts.exists(), "parts are removed after assembly");
}

#[test]
fn tile_fit_split_by_views_assembles_byte_identically() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("t.btfc");
    write_data(&data, 24, 20, 3);
    let tile = ["--tile", "12x10"];
    let fit = |out: &Path, extra: &[&str]| fit_with(&data, out, &tile, extra);
    let reference = reference_fit(&data, &tile);
    let out = dir.path().join("split.plmc");
    for views in ["0/2", "1/2"] {
        let (code, text, err) = fit(&out, &["--views", views]);
        assert_eq!(code, 0, "{err}");
        assert!(!out.exists(), "{text}");
    }
    // Another tile is another fit: its parts would differ, so the views are refused.
    let (code, _, err) = fit_with(&data, &out, &["--tile", "10x10"], &[]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("other options"), "{err}");
    let (code, text, err) = fit(&out, &[]);
    assert_eq!(code, 0, "{err}");
    assert!(text.contains("3 views resumed"), "{text}");
    assert!(
        std::fs::read(&reference).unwrap() == std::fs::read(&out).unwrap(),
        "the assembled tile model differs from the one-process fit"
    );
}
