//! Mitsuba's `aov` and `moment` integrators: btfpt's extra EXR channels against Mitsuba 3.9.1
//! (`reference-images/mitsuba-aov/`, written by `reference-images/aov_reference.py` at 4096 spp)
//! and the second moment against btfpt's own variance image.
//!
//! Tolerance. An AOV pixel is the mean of its samples' first-hit values, so it is noisy only
//! where the pixel's samples see different values (silhouettes, curved surfaces, depth across a
//! pixel). The reference stores each channel's per-sample variance (Mitsuba's own `moment`
//! around its `aov`, box filter), so a 64-spp btfpt pixel minus the reference has variance
//! var·(1/64 + 1/4096). Two floors cover what that estimate cannot see: Mitsuba accumulates
//! m2 and the mean in f32 over 4096 samples, so m2 − mean² loses about 1e-5 of mean² to
//! rounding (depth ≈ 4: a per-sample variance of 1.6e-4, 1.6e-3 at 5σ in a 64-spp mean, 0.04 %
//! of the depth), and unit normals round differently in the two renderers at ~1e-7 (floor
//! 1e-10). Every pixel of every channel must then be within 5.5σ (Šidák for 1200 pixels × 26
//! channels at α = 0.01 is 5.0σ; measured max |z| 3.9 at seed 12345), and the channel's mean z
//! within 0.25 (measured ≤ 0.06).
//! Where the two renderers differ by design the test maps: Mitsuba numbers shapes with the
//! analytic ones first (sphere 1, rectangle 2, cube 3; btfpt: file order, 1, 2, 3) and splits
//! the rectangle along the other diagonal (prim_index), so `si.I` is compared through that
//! mapping on pixels whose samples all hit one shape, and `pi.I` on the cube's pixels.

use crate::reference::root;
use btfpt::render::RenderScene;
use btfpt::render::film::{RenderSettings, RenderState};
use btfpt::scene::LoadOptions;
use std::collections::BTreeMap;

const SPP: u32 = 64;
const REF_SPP: f64 = 4096.0;
const SEED: u64 = 12345;
const Z_MAX: f64 = 5.5;
const MEAN_Z_MAX: f64 = 0.25;

type Channels = BTreeMap<String, Vec<f32>>;

fn read_channels(path: &std::path::Path) -> (usize, usize, Channels) {
    use exr::prelude::*;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let size = image.layer_data.size;
    let ch = image
        .layer_data
        .channel_data
        .list
        .iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect();
    (size.width(), size.height(), ch)
}

/// btfpt's render of scenes/mitsuba-aov (or `xml`) through the library: every output channel
/// (R, G, B and the extra ones) by name.
fn render(xml: &str, defines: &[(&str, &str)], spp: u32) -> (RenderState, Channels) {
    let d: Vec<(String, String)> = defines
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    let scene = btfpt::scene::load(&root().join(xml), &LoadOptions::with_defines(&d))
        .unwrap_or_else(|e| panic!("{e}"));
    let n = scene.channels.per_sample.len();
    let rs = RenderScene::new(scene).unwrap();
    let (w, h) = (rs.scene.camera.width, rs.scene.camera.height);
    let st = RenderSettings {
        width: w,
        height: h,
        crop: [0, 0, w, h],
        spp_begin: 0,
        spp_end: spp,
        seed: SEED,
    };
    let mut state = RenderState::with_channels(st, rs.scene.camera.filter, n).unwrap();
    btfpt::render::driver::render_all(&rs, &mut state);
    let img = state.mean_image();
    let extra =
        btfpt::render::channels::output_channels(&rs.scene.channels, &img, &state.extra_means());
    let mut ch: Channels = extra.into_iter().collect();
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        let v = (0..img.width * img.height)
            .map(|i| img.data[i * 3 + c])
            .collect();
        ch.insert(name.to_string(), v);
    }
    (state, ch)
}

/// Max |z| and mean z of `test` (at SPP) against the reference mean `m` with per-sample
/// variance `var` over the pixels `keep` selects.
fn z_scores(test: &[f32], m: &[f32], var: &[f32], keep: impl Fn(usize) -> bool) -> (f64, f64) {
    let (mut max, mut sum, mut n) = (0f64, 0f64, 0usize);
    for i in (0..test.len()).filter(|&i| keep(i)) {
        let m64 = m[i] as f64;
        let v = (var[i] as f64 + 1e-5 * m64 * m64 + 1e-10) * (1.0 / SPP as f64 + 1.0 / REF_SPP);
        let z = (test[i] as f64 - m64) / v.sqrt();
        // A NaN (in either image) is a failure, not a pixel to skip.
        max = if z.is_nan() {
            f64::INFINITY
        } else {
            max.max(z.abs())
        };
        sum += z;
        n += 1;
    }
    (max, sum / n.max(1) as f64)
}

/// [`render`] of scenes/mitsuba-aov at [`SPP`] with `defines`, the scene's sample count set to
/// the reference's: Mitsuba scales the ray differentials behind `duv_dx`/`duv_dy` by
/// 1/√(sample count), and the reference was rendered at [`REF_SPP`].
fn render_aov_scene(defines: &[(&str, &str)]) -> (RenderState, Channels) {
    let spp = format!("{REF_SPP}");
    let mut d = vec![("spp", spp.as_str())];
    d.extend_from_slice(defines);
    render("scenes/mitsuba-aov/scene.xml", &d, SPP)
}

/// The channels that fail against the box-filter reference, with their max |z| and mean z.
fn failures(test: &Channels) -> Vec<(String, f64, f64)> {
    let (_, _, r) =
        read_channels(&root().join("reference-images/mitsuba-aov/mitsuba-aov_aovs.exr"));
    let mut bad = Vec::new();
    let si = &test["si.I"];
    let single = |i: usize| si[i].fract() == 0.0;
    for (name, m) in r.iter().filter(|(n, _)| !n.starts_with("var.")) {
        let var = &r[&format!("var.{name}")];
        let t = test
            .get(name)
            .unwrap_or_else(|| panic!("btfpt wrote no channel {name}"));
        let (max, mean) = match name.as_str() {
            // Mitsuba's shape order: sphere 1, rectangle 2, cube 3 (btfpt: sphere, cube, rectangle).
            "si.I" => {
                let mapped: Vec<f32> = t
                    .iter()
                    .map(|&k| [0.0, 1.0, 3.0, 2.0][k as usize])
                    .collect();
                z_scores(&mapped, m, var, single)
            }
            "pi.I" => z_scores(t, m, var, |i| si[i] == 2.0),
            // Mitsuba's duv of a sample whose ray escapes is NaN (its partials of a zeroed
            // interaction: 0/0), which poisons the pixel; btfpt writes 0 there as for every
            // AOV. Compared where Mitsuba's pixel is finite.
            n if n.starts_with("dx.") || n.starts_with("dy.") => {
                z_scores(t, m, var, |i| m[i].is_finite())
            }
            _ => z_scores(t, m, var, |_| true),
        };
        if !(max <= Z_MAX && mean.abs() <= MEAN_Z_MAX) {
            bad.push((name.clone(), max, mean));
        }
    }
    bad
}

#[test]
fn aov_channels_match_mitsuba() {
    let (_, test) = render_aov_scene(&[]);
    let bad = failures(&test);
    assert!(bad.is_empty(), "channels off Mitsuba's: {bad:?}");
}

#[test]
fn aov_channels_with_a_wrong_depth_fail() {
    // The negative twin: depth 0.5 % too long (as a depth measured to a point behind the
    // camera would be) must fail the same test.
    let (_, mut test) = render_aov_scene(&[]);
    for v in test.get_mut("dd.y.T").unwrap() {
        *v *= 1.005;
    }
    let bad = failures(&test);
    assert!(
        bad.iter().any(|b| b.0 == "dd.y.T"),
        "a 0.5 % depth error passed: {bad:?}"
    );
}

#[test]
fn aov_albedo_off_by_three_percent_fails() {
    // The negative twin of the albedo (a diffuse reflectance, a checkerboard through twosided
    // roughplastic, a metal's π·f(wi, n)): 3 % too dark must fail.
    let (_, mut test) = render_aov_scene(&[]);
    for c in ["al.R", "al.G", "al.B"] {
        for v in test.get_mut(c).unwrap() {
            *v *= 0.97;
        }
    }
    let bad = failures(&test);
    assert!(
        bad.iter().any(|b| b.0.starts_with("al.")),
        "a 3 % albedo error passed: {bad:?}"
    );
}

#[test]
fn aov_duv_scaled_for_another_sample_count_fails() {
    // The negative twin of duv_dx/duv_dy: the scene's own 64 samples instead of the
    // reference's 4096 scale the ray differentials by 1/8 instead of 1/64.
    let (_, test) = render("scenes/mitsuba-aov/scene.xml", &[], SPP);
    let bad = failures(&test);
    for c in ["dx.U", "dx.V", "dy.U", "dy.V"] {
        assert!(bad.iter().any(|b| b.0 == c), "{c} passed: {bad:?}");
    }
}

/// Per AOV channel, the RMS over the image of `test` − Mitsuba's Gaussian-filter render, over
/// the RMS noise of a 64-spp box-filtered pixel (sqrt of the mean per-sample variance · (1/64 +
/// 1/4096) from the box reference). A Gaussian render at 64 spp scores 0.55–0.7 (its weights
/// average more samples than a box pixel holds); a box render scores 2.2–3.1 against it (its
/// pixels are not blurred across silhouettes as Mitsuba's film blurs them). A channel
/// without noise (the nested image's alpha) gives its RMS difference alone.
fn gaussian_scores(test: &Channels) -> Vec<(String, f64)> {
    let (_, _, g) =
        read_channels(&root().join("reference-images/mitsuba-aov/mitsuba-aov_gaussian.exr"));
    let (_, _, r) =
        read_channels(&root().join("reference-images/mitsuba-aov/mitsuba-aov_aovs.exr"));
    let mut scores = Vec::new();
    for (name, var) in r.iter().filter(|(n, _)| n.starts_with("var.")) {
        let name = &name[4..];
        if name == "si.I" || name == "pi.I" {
            continue;
        }
        // The pixels where Mitsuba wrote a number (its duv is NaN where a sample escapes).
        let keep: Vec<usize> = (0..var.len())
            .filter(|&i| var[i].is_finite() && g[name][i].is_finite())
            .collect();
        let n = keep.len() as f64;
        let noise = (keep.iter().map(|&i| var[i] as f64).sum::<f64>() / n
            * (1.0 / SPP as f64 + 1.0 / REF_SPP))
            .sqrt();
        let rms = (keep
            .iter()
            .map(|&i| (test[name][i] as f64 - g[name][i] as f64).powi(2))
            .sum::<f64>()
            / n)
            .sqrt();
        scores.push((
            name.to_string(),
            if noise > 0.0 { rms / noise } else { rms },
        ));
    }
    scores
}

#[test]
fn aov_channels_are_filtered_as_mitsuba_filters_them() {
    // Mitsuba's film weighs every channel, the AOVs too, by the reconstruction filter: btfpt's
    // Gaussian render matches Mitsuba's Gaussian one, and writes exactly its channel names;
    // the box-filtered render (the negative twin) does not match it.
    let (_, gauss) = render_aov_scene(&[("filter", "gaussian")]);
    let (_, _, g) =
        read_channels(&root().join("reference-images/mitsuba-aov/mitsuba-aov_gaussian.exr"));
    let names = |c: &Channels| c.keys().cloned().collect::<Vec<_>>();
    assert_eq!(
        names(&gauss),
        names(&g),
        "channel names differ from Mitsuba's film"
    );
    let scores = gaussian_scores(&gauss);
    assert!(
        scores.iter().all(|s| s.1 <= 1.0),
        "Gaussian AOVs off Mitsuba's: {scores:?}"
    );
    let (_, boxed) = render_aov_scene(&[]);
    let scores = gaussian_scores(&boxed);
    // The duv channels are left out: Mitsuba's are NaN wherever a sample escapes, so their
    // silhouettes, where the filters differ, are not compared.
    assert!(
        scores
            .iter()
            .filter(|s| s.0 != "image.A" && !s.0.starts_with("dx.") && !s.0.starts_with("dy."))
            .all(|s| s.1 > 1.5),
        "box-filtered AOVs pass against the Gaussian reference: {scores:?}"
    );
}

#[test]
fn moment_second_moment_agrees_with_the_variance_image() {
    // A grey scene (R = G = B per sample, so Mitsuba's Y equals R up to f32 rounding): the
    // per-sample variance from `moment`'s channels, (m2_Y − Y²)·n/(n − 1), is the variance
    // image's R channel times n (box filter).
    let xml = root().join("target/tmp-moment-grey.xml");
    let text = std::fs::read_to_string(root().join("scenes/mitsuba-aov/scene.xml")).unwrap();
    let start = text.find("<integrator type=\"aov\">").unwrap();
    let end = text.find("<sensor").unwrap();
    let text = text[..start].to_string()
        + "<integrator type=\"moment\"><integrator type=\"path\"><integer name=\"max_depth\" value=\"3\"/></integrator></integrator>\n    "
        + &text[end..];
    std::fs::write(&xml, text.replace("0.2, 0.5, 0.8", "0.4, 0.4, 0.4")).unwrap();
    let spp = 16;
    let (state, ch) = render("target/tmp-moment-grey.xml", &[], spp);
    let names: Vec<&String> = ch.keys().collect();
    assert_eq!(
        names,
        [
            "B",
            "G",
            "R",
            "_arg_0.X",
            "_arg_0.Y",
            "_arg_0.Z",
            "m2__arg_0.X",
            "m2__arg_0.Y",
            "m2__arg_0.Z"
        ],
        "Mitsuba's moment names an unnamed nested integrator _arg_0"
    );
    let var = state.variance_image().unwrap();
    let n = spp as f64;
    let (y, m2) = (&ch["_arg_0.Y"], &ch["m2__arg_0.Y"]);
    let mut checked = 0;
    for i in 0..y.len() {
        let (yi, m2i) = (y[i] as f64, m2[i] as f64);
        let from_moment = (m2i - yi * yi) * n / (n - 1.0);
        let from_variance = var.data[i * 3] as f64 * n;
        let tol = 1e-3 * from_variance + 1e-6 * m2i;
        assert!(
            (from_moment - from_variance).abs() <= tol,
            "pixel {i}: moment gives {from_moment}, the variance image {from_variance}"
        );
        checked += (from_variance > 1e-4) as usize;
    }
    assert!(checked > 100, "only {checked} noisy pixels");
}
