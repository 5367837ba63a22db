//! `btfpt fit --tile`, `eval` (seam_ratio) and `tile-preview` on a small generated BTF.
use crate::common::btfpt_output as btfpt;
use btfpt::math::Pcg32;

/// 2 views × 81 lights of a 40 × 36 blurred-noise texture lit by a cosine-like factor.
fn write_sample(path: &std::path::Path) {
    let (w, h) = (40usize, 36usize);
    let mut rng = Pcg32::new(9, 9);
    let noise: Vec<f32> = (0..w * h).map(|_| rng.next_f32()).collect();
    let tex: Vec<f32> = (0..w * h)
        .map(|t| {
            let (x, y) = (t % w, t / w);
            let mut s = 0.0;
            for d in 0..4 {
                s += noise[((y + d / 2) % h) * w + (x + d % 2) % w];
            }
            0.2 + 0.15 * s
        })
        .collect();
    crate::common::write_two_view_btf(path, w, h, &tex);
}

#[test]
fn fit_a_tile_evaluate_its_seams_and_preview_it() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("s.btfc");
    write_sample(&data);
    let (d, m, j, png) = (
        data.to_str().unwrap(),
        dir.path().join("t.plmc"),
        dir.path().join("t.json"),
        dir.path().join("t.png"),
    );
    let (m, j, png) = (
        m.to_str().unwrap(),
        j.to_str().unwrap(),
        png.to_str().unwrap(),
    );
    let (ok, out, err) = btfpt(&[
        "fit",
        d,
        "-o",
        m,
        "--tile",
        "20x20",
        "--tiles",
        "2",
        "--clusters",
        "8",
    ]);
    assert!(ok, "{out}\n{err}");
    assert!(
        out.contains("tile: 20×20 × 2 from the 40×36 sample"),
        "{out}"
    );
    let (ok, out, err) = btfpt(&["eval", m, "--against", d, "--json", j]);
    assert!(ok, "{out}\n{err}");
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(j).unwrap()).unwrap();
    let seam = v["seam_ratio"].as_f64().unwrap();
    let crop = v["seams"]["seam_ratio_crop"].as_f64().unwrap();
    assert!(seam < 1.25 && seam < crop, "seam {seam} crop {crop}");
    assert_eq!(v["tile"]["count"], 2);
    assert!(v["tile"]["region_mae"].as_f64().unwrap() < 0.1);
    let (ok, out, err) = btfpt(&[
        "tile-preview",
        m,
        "-o",
        png,
        "--repeat",
        "3x2",
        "--light",
        "5",
    ]);
    assert!(ok, "{out}\n{err}");
    let img = btfpt::io::read_image(std::path::Path::new(png)).unwrap();
    assert_eq!((img.width, img.height), (60, 40));
    // Errors: a tile larger than the sample, a view out of range, eval against other data.
    let (ok, _, err) = btfpt(&["fit", d, "-o", m, "--tile", "48x32"]);
    assert!(!ok && err.contains("larger than the 40×36 sample"), "{err}");
    let (ok, _, err) = btfpt(&["tile-preview", m, "-o", png, "--view", "7"]);
    assert!(!ok && err.contains("--view 7"), "{err}");
    let (ok, _, err) = btfpt(&["fit", d, "-o", m, "--tiles", "3"]);
    assert!(!ok && err.contains("--tile"), "{err}");
}
