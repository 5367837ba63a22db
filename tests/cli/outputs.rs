//! What the commands write, checked on the real binary: a BTF folder is never a mix of two BTFs
//! or two encodings, clipping to 8 bits is always announced, every image output holds the
//! encoding its extension names, `eval` says when model and data encodings differ, and `info`
//! describes only what it could open.

use crate::common;

use crate::common::btfpt_output;
use btfpt::btf::{self, BtfSource, DirectionSet, RawBtf, StoredEncoding};
use std::path::{Path, PathBuf};

/// A 2×2-texel BTF on the 81 UBO2003 directions whose values reach 3 (above what PNG holds).
fn bright_btf() -> RawBtf {
    let d = DirectionSet::ubo2003();
    let data: Vec<f32> = (0..81 * 81 * 4 * 3)
        .map(|i| 0.05 + 3.0 * ((i * 7919) % 1000) as f32 / 1000.0)
        .collect();
    RawBtf::from_f32(d.clone(), d, 2, 2, StoredEncoding::Linear, &data).unwrap()
}

/// Extensions of the files in `dir`, with their counts.
fn extensions(dir: &Path) -> Vec<(String, usize)> {
    let mut m = std::collections::BTreeMap::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        let ext = p
            .extension()
            .map_or(String::new(), |e| e.to_string_lossy().into_owned());
        *m.entry(ext).or_insert(0) += 1;
    }
    m.into_iter().collect()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn a_btf_folder_is_replaced_whole_and_only_with_force() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src.btfc");
    btf::cache::write_raw(&bright_btf(), &src).unwrap();
    let folder = dir.path().join("out");
    let (ok, _, err) = btfpt_output(&["convert", s(&src), s(&folder), "--images", "exr"]);
    assert!(ok, "{err}");
    assert_eq!(extensions(&folder), vec![("exr".into(), 6561)]);
    std::fs::write(folder.join("notes.txt"), b"mine").unwrap();

    // Without --force: refused, nothing touched.
    for args in [
        vec!["convert", s(&src), s(&folder), "--images", "png8"],
        vec!["synth", "foil", "--size", "2", "-o", s(&folder)],
    ] {
        let (ok, _, err) = btfpt_output(&args);
        assert!(!ok, "{args:?}");
        assert!(
            err.contains("not empty") && err.contains("--force"),
            "{err}"
        );
        assert_eq!(
            extensions(&folder),
            vec![("exr".into(), 6561), ("txt".into(), 1)]
        );
    }
    // With --force: the images are replaced, all in the new encoding; other files are kept.
    let (ok, _, err) = btfpt_output(&[
        "convert",
        s(&src),
        s(&folder),
        "--images",
        "png8",
        "--force",
    ]);
    assert!(ok, "{err}");
    assert!(err.contains("removed the 6561 UBO2003 images"), "{err}");
    assert_eq!(
        extensions(&folder),
        vec![("png".into(), 6561), ("txt".into(), 1)]
    );
    std::fs::remove_file(folder.join("notes.txt")).unwrap();
    assert_eq!(btf::load_raw(&folder).unwrap().width(), 2);
    // The input folder itself is never the output.
    let (ok, _, err) = btfpt_output(&["convert", s(&folder), s(&folder), "--force"]);
    assert!(!ok && err.contains("input folder"), "{err}");
}

#[test]
fn png_conversions_say_how_many_values_they_clip() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src.btfc");
    let raw = bright_btf();
    btf::cache::write_raw(&raw, &src).unwrap();
    let above = raw.data().iter().filter(|v| v.to_f32() > 1.0).count();
    assert!(above > 0);
    for images in ["png8", "png16"] {
        let out = dir.path().join(images);
        let (ok, _, err) = btfpt_output(&["convert", s(&src), s(&out), "--images", images]);
        assert!(ok, "{err}");
        assert!(
            err.contains("warning:")
                && err.contains(&format!("{above} of {}", raw.data().len()))
                && err.contains("clipped"),
            "{images}: {err}"
        );
    }
    let out = dir.path().join("exr");
    let (ok, _, err) = btfpt_output(&["convert", s(&src), s(&out), "--images", "exr"]);
    assert!(ok && !err.contains("clipped"), "{err}");
}

/// Fits an LM model (small and fast) of `data` to `out`.
fn fit_lm(data: &Path, out: &Path) {
    let (ok, _, err) = btfpt_output(&["fit", s(data), "-o", s(out), "--model", "lm"]);
    assert!(ok, "{err}");
}

#[test]
fn image_outputs_hold_the_encoding_their_extension_names() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("d.btfc");
    btf::cache::write_raw(&bright_btf(), &data).unwrap();
    let model = dir.path().join("m.plmc");
    fit_lm(&data, &model);
    let exr_magic = [0x76u8, 0x2f, 0x31, 0x01];
    let png_magic = [0x89u8, b'P', b'N', b'G'];
    for (name, magic) in [("t.exr", &exr_magic), ("t.png", &png_magic)] {
        let out = dir.path().join(name);
        let (ok, _, err) = btfpt_output(&["tile-preview", s(&model), "-o", s(&out)]);
        assert!(ok, "{err}");
        assert_eq!(&std::fs::read(&out).unwrap()[..4], magic, "{name}");
    }
    let exr = btfpt::io::read_image(&dir.path().join("t.exr")).unwrap();
    let png = btfpt::io::read_image(&dir.path().join("t.png")).unwrap();
    assert_eq!((exr.width, exr.height), (png.width, png.height));
    // Names whose extension is not the output's encoding are refused before any work.
    let a = dir.path().join("a.exr");
    btfpt::io::write_exr(&a, &btfpt::io::RgbImage::new(2, 2)).unwrap();
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            ["compare", s(&a), s(&a), "--diff", "d.exr"]
                .map(String::from)
                .to_vec(),
            "d.exr",
        ),
        (
            ["eval", s(&model), "--against", s(&data), "--plot", "p.jpg"]
                .map(String::from)
                .to_vec(),
            "p.jpg",
        ),
        (
            ["merge", s(&a), "-o", "m.png"].map(String::from).to_vec(),
            "m.png",
        ),
    ];
    for (args, name) in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = common::btfpt()
            .args(&args)
            .current_dir(dir.path())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(name), "{args:?}: {err}");
        assert!(!dir.path().join(name).exists(), "{name} was written");
    }
}

/// The same 2×2 BTF as 8-bit PNG images and as EXR images.
fn png_and_exr_folders(dir: &Path) -> (PathBuf, PathBuf) {
    let d = DirectionSet::ubo2003();
    let data: Vec<f32> = (0..81 * 81 * 4 * 3)
        .map(|i| 0.1 + 0.8 * ((i * 7919) % 1000) as f32 / 1000.0)
        .collect();
    let raw = RawBtf::from_f32(d.clone(), d, 2, 2, StoredEncoding::Linear, &data).unwrap();
    let png = dir.join("png");
    let exr = dir.join("exr");
    btf::ubo2003::write_folder(&raw, &png, btf::ubo2003::ImageKind::Png8).unwrap();
    btf::ubo2003::write_folder(&raw, &exr, btf::ubo2003::ImageKind::Exr).unwrap();
    (png, exr)
}

#[test]
fn eval_warns_when_model_and_data_encodings_differ() {
    let dir = tempfile::tempdir().unwrap();
    let (png, exr) = png_and_exr_folders(dir.path());
    let model = dir.path().join("m.plmc");
    fit_lm(&png, &model);
    let (ok, _, err) = btfpt_output(&["eval", s(&model), "--against", s(&exr)]);
    assert!(ok, "{err}");
    assert!(
        err.contains("warning:") && err.contains("8-bit sRGB") && err.contains("linear floats"),
        "{err}"
    );
    let (ok, _, err) = btfpt_output(&["eval", s(&model), "--against", s(&png)]);
    assert!(ok && !err.contains("warning:"), "{err}");
}

#[test]
fn info_names_a_format_only_for_what_it_could_open() {
    let dir = tempfile::tempdir().unwrap();
    let junk = dir.path().join("junk");
    std::fs::create_dir(&junk).unwrap();
    std::fs::write(junk.join("notes.txt"), b"x").unwrap();
    let (ok, out, err) = btfpt_output(&["info", s(&junk)]);
    assert!(!ok && err.contains("not a UBO2003"), "{err}");
    assert!(!out.contains("format:"), "{out}");
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let (ok, out, err) = btfpt_output(&["info", s(&empty)]);
    assert!(
        !ok && err.contains("not a UBO2003") && !out.contains("format:"),
        "{err}"
    );
}
