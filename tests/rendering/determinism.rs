//! Determinism and exactness of split work: thread counts, checkpoint/resume, crop and
//! sample-range merges.

use crate::common::*;
use btfpt::geometry::generate::{quad, sphere};
use btfpt::math::filter::Filter;
use btfpt::math::{Spectrum, Vec3};
use btfpt::render::film::{RenderSettings, RenderState};
use btfpt::render::partial::{PartialMeta, merge, read_partial_exr, write_partial_exr};
use btfpt::render::{RenderScene, checkpoint};
use btfpt::scene::Emitter;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

fn test_scene() -> RenderScene {
    let floor = quad(
        Vec3::new(-2.0, -1.0, 2.0),
        Vec3::new(4.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -4.0),
    );
    let mut light = quad(
        Vec3::new(-0.5, 1.5, -0.5),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, 0.0),
    );
    light.emitter = Some(Spectrum::new(5.0, 4.0, 3.0));
    let s = scene(
        Vec3::new(0.3, 1.0, 3.0),
        Vec3::ZERO,
        50.0,
        (40, 35),
        vec![floor, light, sphere(Vec3::ZERO, 0.7, 12, 24, false, true)],
        vec![diffuse(0.7)],
        vec![Emitter::Constant {
            radiance: Spectrum::new(0.2, 0.3, 0.4),
        }],
    );
    RenderScene::new(s).unwrap()
}

fn meta_of(st: &RenderState) -> PartialMeta {
    let s = st.settings;
    PartialMeta {
        width: s.width,
        height: s.height,
        crop: s.crop,
        spp_begin: s.spp_begin,
        spp_end: s.spp_end,
        seed: s.seed,
        scene: 7,
        whole: None,
    }
}

#[test]
fn identical_exr_bytes_with_one_and_two_threads() {
    let rs = test_scene();
    let dir = tempfile::tempdir().unwrap();
    let mut files = Vec::new();
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let st = pool.install(|| render(&rs, settings(&rs.scene, 6, 9)));
        let p = dir.path().join(format!("t{threads}.exr"));
        write_partial_exr(&p, &st.mean_image(), &meta_of(&st)).unwrap();
        files.push(std::fs::read(&p).unwrap());
    }
    assert_eq!(files[0], files[1]);
    // And a different seed gives a different image (the test can fail).
    let other = render(&rs, settings(&rs.scene, 6, 10));
    assert_ne!(
        other.mean_image(),
        render(&rs, settings(&rs.scene, 6, 9)).mean_image()
    );
}

#[test]
fn interrupted_and_resumed_render_is_bit_identical() {
    let rs = test_scene();
    let st = settings(&rs.scene, 7, 5);
    let full = render(&rs, st);
    let dir = tempfile::tempdir().unwrap();
    let ck = dir.path().join("r.ckpt");
    // Interrupt in the middle of a pass: some tiles are ahead of others.
    let mut state = RenderState::new(st).unwrap();
    let stop = AtomicBool::new(false);
    btfpt::render::driver::run_pass(&rs, &mut state, 2, &stop, &|_, _| {});
    let seen = AtomicU64::new(0);
    btfpt::render::driver::run_pass(&rs, &mut state, 3, &stop, &|n, _| {
        if seen.fetch_add(n, Ordering::SeqCst) > 2000 {
            stop.store(true, Ordering::SeqCst);
        }
    });
    assert!(!state.is_complete());
    checkpoint::save(&ck, &state, 42).unwrap();
    // Wrong fingerprint or settings are refused.
    assert!(checkpoint::load(&ck, &st, 43).is_err());
    let mut other = st;
    other.seed = 6;
    assert!(checkpoint::load(&ck, &other, 42).is_err());
    let mut resumed = checkpoint::load(&ck, &st, 42).unwrap();
    assert_eq!(resumed, state);
    let go = AtomicBool::new(false);
    while !resumed.is_complete() {
        btfpt::render::driver::run_pass(&rs, &mut resumed, 2, &go, &|_, _| {});
    }
    let a = full.mean_image();
    let b = resumed.mean_image();
    assert!(
        a.data
            .iter()
            .zip(&b.data)
            .all(|(x, y)| x.to_bits() == y.to_bits())
    );
    // A corrupted checkpoint is an error naming the file.
    let mut bytes = std::fs::read(&ck).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 1;
    std::fs::write(&ck, &bytes).unwrap();
    let e = checkpoint::load(&ck, &st, 42).unwrap_err().to_string();
    assert!(e.contains("r.ckpt") && e.contains("corrupt"), "{e}");
}

#[test]
fn crop_and_sample_range_merges_equal_a_single_render() {
    let rs = test_scene();
    let base = settings(&rs.scene, 6, 2);
    let full = render(&rs, base).mean_image();
    let dir = tempfile::tempdir().unwrap();
    // Four crops (uneven split, one not tile-aligned) with samples split 0..2 / 2..6 on two.
    let crops = [[0, 0, 17, 20], [17, 0, 23, 20], [0, 20, 40, 15]];
    let mut paths = Vec::new();
    for (i, c) in crops.iter().enumerate() {
        let ranges: &[(u32, u32)] = if i == 2 { &[(0, 2), (2, 6)] } else { &[(0, 6)] };
        for (k, &(a, b)) in ranges.iter().enumerate() {
            let mut st = base;
            st.crop = *c;
            st.spp_begin = a;
            st.spp_end = b;
            let r = render(&rs, st);
            let p = dir.path().join(format!("part{i}_{k}.exr"));
            write_partial_exr(&p, &r.mean_image(), &meta_of(&r)).unwrap();
            paths.push(p);
        }
    }
    let parts: Vec<_> = paths.iter().map(|p| read_partial_exr(p).unwrap()).collect();
    let names: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
    let (img, meta) = merge(&parts, &names).unwrap();
    assert_eq!(meta.crop, [0, 0, 40, 35]);
    assert_eq!((meta.spp_begin, meta.spp_end), (0, 6));
    for y in 0..35 {
        for x in 0..40 {
            let (a, b) = (full.get(x, y), img.get(x, y));
            for c in 0..3 {
                if y < 20 {
                    assert_eq!(a[c].to_bits(), b[c].to_bits(), "crop pixel ({x},{y})");
                } else {
                    assert!(
                        (a[c] - b[c]).abs() <= 4.0 * f32::EPSILON * a[c].abs().max(1e-30),
                        "range pixel ({x},{y}): {} vs {}",
                        a[c],
                        b[c]
                    );
                }
            }
        }
    }
    // Overlapping sample ranges and holes are refused.
    let dup = vec![parts[0].clone(), parts[0].clone()];
    assert!(
        merge(&dup, &names)
            .unwrap_err()
            .to_string()
            .contains("twice")
    );
    let hole = vec![parts[0].clone(), parts[3].clone()];
    assert!(merge(&hole, &names).is_err());
}

/// Renders to completion with a reconstruction filter on the current thread pool.
fn render_filtered(rs: &RenderScene, st: RenderSettings, f: Filter) -> RenderState {
    let mut state = RenderState::with_filter(st, f).unwrap();
    let stop = AtomicBool::new(false);
    while !state.is_complete() {
        btfpt::render::driver::run_pass(rs, &mut state, 1 << 20, &stop, &|_, _| {});
    }
    state
}

#[test]
fn filtered_render_is_exact_across_threads_crops_and_resume() {
    let rs = test_scene();
    let base = settings(&rs.scene, 4, 3);
    let f = Filter::default();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let full = one.install(|| render_filtered(&rs, base, f)).mean_image();
    let two = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let again = two.install(|| render_filtered(&rs, base, f)).mean_image();
    let bits = |i: &btfpt::io::RgbImage| i.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&full), bits(&again));
    // The filter changes the image (the test can fail), and a window renders its border:
    // a crop's pixels are the full render's, bit for bit, and the crops merge into it.
    assert_ne!(bits(&full), bits(&render(&rs, base).mean_image()));
    let crops = [[0, 0, 17, 20], [17, 0, 23, 20], [0, 20, 40, 15]];
    let mut parts = Vec::new();
    for c in crops {
        let mut st = base;
        st.crop = c;
        let r = render_filtered(&rs, st, f);
        let img = r.mean_image();
        for y in 0..c[3] as usize {
            for x in 0..c[2] as usize {
                let a = full.get(c[0] as usize + x, c[1] as usize + y);
                let b = img.get(x, y);
                assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "{c:?} ({x},{y})");
            }
        }
        parts.push((img, meta_of(&r)));
    }
    let names: Vec<String> = (0..3).map(|i| format!("crop{i}")).collect();
    let (merged, _) = merge(&parts, &names).unwrap();
    assert_eq!(bits(&merged), bits(&full));
    // Interrupted, checkpointed and resumed: bit-identical; another filter is refused.
    let dir = tempfile::tempdir().unwrap();
    let ck = dir.path().join("f.ckpt");
    let mut state = RenderState::with_filter(base, f).unwrap();
    let stop = AtomicBool::new(false);
    btfpt::render::driver::run_pass(&rs, &mut state, 1, &stop, &|_, _| {});
    let seen = AtomicU64::new(0);
    btfpt::render::driver::run_pass(&rs, &mut state, 2, &stop, &|n, _| {
        if seen.fetch_add(n, Ordering::SeqCst) > 800 {
            stop.store(true, Ordering::SeqCst);
        }
    });
    assert!(!state.is_complete());
    checkpoint::save(&ck, &state, 7).unwrap();
    assert!(checkpoint::load(&ck, &base, 7).is_err());
    let tent = Filter::tent(1.0).unwrap();
    assert!(checkpoint::load_filtered(&ck, &base, &tent, 7).is_err());
    let mut resumed = checkpoint::load_filtered(&ck, &base, &f, 7).unwrap();
    assert_eq!(resumed, state);
    let go = AtomicBool::new(false);
    while !resumed.is_complete() {
        btfpt::render::driver::run_pass(&rs, &mut resumed, 1, &go, &|_, _| {});
    }
    assert_eq!(bits(&resumed.mean_image()), bits(&full));
    // Variance of a filtered pixel: finite and positive where the floor is lit.
    let var = resumed.variance_image().unwrap();
    assert!(var.data.iter().all(|v| v.is_finite() && *v >= 0.0));
    assert!(var.data.iter().any(|v| *v > 0.0));
}

#[test]
fn a_render_without_moments_gives_the_same_image_and_checkpoints_as_such() {
    let rs = test_scene();
    let base = settings(&rs.scene, 4, 3);
    let bits = |i: &btfpt::io::RgbImage| i.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    for f in [Filter::BOX, Filter::default()] {
        let with = render_filtered(&rs, base, f);
        assert!(with.has_moments());
        let run = |mut state: RenderState| {
            let stop = AtomicBool::new(false);
            while !state.is_complete() {
                btfpt::render::driver::run_pass(&rs, &mut state, 1 << 20, &stop, &|_, _| {});
            }
            state
        };
        let fresh = || RenderState::with_filter(base, f).unwrap().without_moments();
        let without = run(fresh());
        assert!(!without.has_moments());
        assert_eq!(
            bits(&without.mean_image()),
            bits(&with.mean_image()),
            "{f:?}"
        );
        let err = without.variance_image().unwrap_err().to_string();
        assert!(err.contains("second moments"), "{err}");
        assert!(with.variance_image().is_ok());
        // Interrupted without moments: the checkpoint keeps none, and resumes to the same bits.
        let dir = tempfile::tempdir().unwrap();
        let ck = dir.path().join("m.ckpt");
        let mut state = fresh();
        let stop = AtomicBool::new(false);
        btfpt::render::driver::run_pass(&rs, &mut state, 1, &stop, &|_, _| {});
        assert!(!state.is_complete());
        checkpoint::save(&ck, &state, 3).unwrap();
        let loaded = checkpoint::load_filtered(&ck, &base, &f, 3).unwrap();
        assert!(!loaded.has_moments());
        assert_eq!(loaded, state);
        assert_eq!(bits(&run(loaded).mean_image()), bits(&with.mean_image()));
        // A checkpoint with moments still loads with them.
        let mut state = RenderState::with_filter(base, f).unwrap();
        btfpt::render::driver::run_pass(&rs, &mut state, 1, &stop, &|_, _| {});
        checkpoint::save(&ck, &state, 3).unwrap();
        assert!(
            checkpoint::load_filtered(&ck, &base, &f, 3)
                .unwrap()
                .has_moments()
        );
    }
}
