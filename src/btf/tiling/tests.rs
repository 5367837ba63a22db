//! Cuts, stitches, tiled sources and seams.

use super::cut::blend_radii;
use super::quilt::dist;
use super::*;
use crate::btf::RawBtf;
use crate::btf::{BtfSource, DirectionSet, StoredEncoding};
use crate::math::Pcg32;
use std::path::Path;

/// A random texture `[texel][rgb]`.
fn noise(w: usize, h: usize, seed: u64) -> Vec<f32> {
    let mut r = Pcg32::new(seed, 3);
    (0..w * h * 3).map(|_| r.next_f32()).collect()
}

/// A smooth-ish texture: blurred noise (neighbours correlated like a real material).
fn blurred(w: usize, h: usize, seed: u64) -> Vec<f32> {
    let n = noise(w, h, seed);
    let mut out = vec![0.0; n.len()];
    for y in 0..h {
        for x in 0..w {
            for c in 0..3 {
                let mut s = 0.0;
                let mut k = 0.0;
                for dy in 0..3 {
                    for dx in 0..3 {
                        let (xx, yy) = ((x + dx).min(w - 1), (y + dy).min(h - 1));
                        s += n[3 * (yy * w + xx) + c];
                        k += 1.0;
                    }
                }
                out[3 * (y * w + x) + c] = s / k;
            }
        }
    }
    out
}

fn tile_of(st: &Stitch, img: &[f32]) -> Vec<f32> {
    let mut out = vec![0.0; st.texels() * 3];
    st.apply(img, &mut out);
    out
}

#[test]
fn the_cut_between_two_identical_images_has_zero_error() {
    let img = noise(20, 12, 1);
    let (len, band) = (20, 6);
    // Error map of the band between the image and itself.
    let err: Vec<f32> = (0..len)
        .flat_map(|x| (0..band).map(move |j| (x, j)))
        .map(|(x, j)| {
            let t = 3 * (j * 20 + x);
            dist(&img[t..t + 3], &img[t..t + 3])
        })
        .collect();
    for cyclic in [false, true] {
        let (path, cost) = min_error_cut(&err, len, band, cyclic);
        assert_eq!(cost, 0.0);
        assert_eq!(path.len(), len);
        assert!(path.windows(2).all(|w| w[0].abs_diff(w[1]) <= 1));
    }
    // And a zero-error band gives hard cuts (no blending).
    assert!(
        blend_radii(&err, band, &vec![3; len])
            .iter()
            .all(|&r| r == 0)
    );
}

#[test]
fn the_cut_is_the_optimal_path_and_cyclic_paths_close() {
    // A cheap corridor that moves one cell per step: the DP must follow it exactly.
    let (len, band) = (9, 5);
    let corridor = [0, 1, 2, 3, 4, 3, 2, 1, 0];
    let mut err = vec![1.0f32; len * band];
    for (i, &j) in corridor.iter().enumerate() {
        err[i * band + j] = 0.0;
    }
    let (p, c) = min_error_cut(&err, len, band, false);
    assert_eq!(p, corridor);
    assert_eq!(c, 0.0);
    // Cyclic: a path ending far from its start is not allowed.
    let mut err = vec![1.0f32; 6 * 4];
    for (i, &j) in [0usize, 1, 2, 3, 3, 3].iter().enumerate() {
        err[i * 4 + j] = 0.0;
    }
    let (open, c_open) = min_error_cut(&err, 6, 4, false);
    assert_eq!(c_open, 0.0);
    assert_eq!(open, [0, 1, 2, 3, 3, 3]);
    let (closed, c_closed) = min_error_cut(&err, 6, 4, true);
    assert!(closed[0].abs_diff(closed[5]) <= 1);
    assert!(c_closed > 0.0);
    // Brute force over all cyclic paths agrees.
    let mut best = f64::INFINITY;
    for code in 0..4usize.pow(6) {
        let p: Vec<usize> = (0..6).map(|i| code / 4usize.pow(i) % 4).collect();
        let ok = p.windows(2).all(|w| w[0].abs_diff(w[1]) <= 1) && p[0].abs_diff(p[5]) <= 1;
        if ok {
            best = best.min((0..6).map(|i| err[i * 4 + p[i]] as f64).sum());
        }
    }
    assert_eq!(c_closed, best);
}

#[test]
fn a_tile_of_a_periodic_texture_wraps_exactly() {
    // Period 16 × 12; the sample holds 3 × 3 periods.
    let (pw, ph) = (16, 12);
    let base = blurred(pw, ph, 5);
    let (sw, sh) = (3 * pw, 3 * ph);
    let img: Vec<f32> = (0..sw * sh)
        .flat_map(|t| {
            let (x, y) = (t % sw % pw, t / sw % ph);
            base[3 * (y * pw + x)..3 * (y * pw + x) + 3].to_vec()
        })
        .collect();
    let st = find_stitch_in(
        &[&img],
        sw,
        sh,
        StoredEncoding::Linear,
        &TileSpec::new(pw, ph),
    )
    .unwrap();
    assert_eq!(st.cut_error, 0.0);
    let tile = tile_of(&st, &img);
    let (x0, y0) = st.origin;
    for y in 0..ph {
        for x in 0..pw {
            let s = 3 * (((y0 + y) % ph) * pw + (x0 + x) % pw);
            let t = 3 * (y * pw + x);
            assert_eq!(&tile[t..t + 3], &base[s..s + 3], "texel ({x}, {y})");
        }
    }
    // So its wrap-around neighbours are exactly the texture's neighbours.
    let mut seams = SeamStats::default();
    seams.add_image(&tile, pw, ph, StoredEncoding::Linear);
    let mut periodic = SeamStats::default();
    periodic.add_image(&base, pw, ph, StoredEncoding::Linear);
    assert_eq!(seams.wrap, periodic.wrap);
}

#[test]
fn stitched_tiles_wrap_better_than_crops_and_share_borders() {
    let (sw, sh) = (72, 64);
    let imgs = [blurred(sw, sh, 7), blurred(sw, sh, 8)];
    let refs: Vec<&[f32]> = imgs.iter().map(|i| i.as_slice()).collect();
    let spec = TileSpec {
        width: 32,
        height: 24,
        count: 3,
        overlap: None,
    };
    let st = find_stitch_in(&refs, sw, sh, StoredEncoding::Linear, &spec).unwrap();
    assert_eq!((st.texels(), st.patches.len()), (32 * 24 * 3, 2));
    // Every texel is a convex combination of sample texels.
    for t in 0..st.texels() {
        let s: f32 = st.sources(t).iter().map(|e| e.1).sum();
        assert!((s - 1.0).abs() < 1e-5 && st.sources(t).iter().all(|e| e.1 > 0.0));
    }
    let crop = Stitch::crop(sw, sh, st.origin, 32, 24);
    let (mut a, mut b) = (SeamStats::default(), SeamStats::default());
    for img in &imgs {
        a.add_image(&tile_of(&st, img), 32, 24, StoredEncoding::Linear);
        b.add_image(&tile_of(&crop, img), 32, 24, StoredEncoding::Linear);
    }
    assert!(a.ratio() < 1.25, "stitched {}", a.ratio());
    assert!(
        b.ratio() > 1.5 * a.ratio(),
        "crop {} stitched {}",
        b.ratio(),
        a.ratio()
    );
    // Tiles 1 and 2 differ inside but keep the template's border ring, so they are
    // interchangeable; the patches come from elsewhere.
    let t = tile_of(&st, &imgs[0]);
    let n = 32 * 24 * 3;
    let (m, o) = (st.overlap, st.overlap);
    for k in 1..3 {
        let tk = &t[k * n..(k + 1) * n];
        let mut inner_diff = 0.0;
        for y in 0..24 {
            for x in 0..32 {
                let i = 3 * (y * 32 + x);
                let ring = x < m || y < m || x >= 32 - m || y >= 24 - m;
                if ring {
                    assert_eq!(&tk[i..i + 3], &t[i..i + 3], "tile {k} ({x}, {y})");
                } else {
                    inner_diff += (tk[i] - t[i]).abs();
                }
            }
        }
        assert!(inner_diff > 1.0, "tile {k} has no variety");
        let _ = o;
    }
    // Serialisation round trip.
    let bytes = st.to_bytes().unwrap();
    assert_eq!(Stitch::from_bytes(&bytes, Path::new("t.plmc")).unwrap(), st);
    let e = Stitch::from_bytes(&bytes[..20], Path::new("t.plmc")).unwrap_err();
    assert!(e.to_string().contains("t.plmc"), "{e}");
}

#[test]
fn tiles_larger_than_the_sample_are_an_error() {
    let img = noise(16, 16, 2);
    for (w, h) in [(17, 8), (8, 20), (16, 16), (15, 15)] {
        let e = find_stitch_in(
            &[&img],
            16,
            16,
            StoredEncoding::Linear,
            &TileSpec::new(w, h),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains(&format!("{w}×{h}")), "{e}");
    }
    assert!(parse_size("64x32").unwrap() == (64, 32) && parse_size("8").unwrap() == (8, 8));
    assert!(parse_size("0x4").is_err() && parse_size("ax4").is_err());
    // Through a BTF source as well.
    let d = DirectionSet::from_angles_deg(vec![(0.0, 0.0)]);
    let btf = RawBtf::from_f32(d.clone(), d, 4, 4, StoredEncoding::Linear, &[0.5; 48]).unwrap();
    let e = find_stitch(&btf, &TileSpec::new(8, 8))
        .unwrap_err()
        .to_string();
    assert!(e.contains("larger than the 4×4 sample"), "{e}");
}

#[test]
fn the_tiled_source_gathers_every_image_with_the_same_stitch() {
    let views = DirectionSet::from_angles_deg(vec![(0.0, 0.0), (30.0, 0.0)]);
    let lights = DirectionSet::from_angles_deg(vec![(0.0, 0.0), (45.0, 90.0), (60.0, 0.0)]);
    let (sw, sh) = (40, 36);
    // Every image is the same structure under another light: one texture, scaled.
    let base = blurred(sw, sh, 20);
    let data: Vec<f32> = (0..6)
        .flat_map(|k| base.iter().map(move |&v| v * (0.4 + 0.1 * k as f32)))
        .collect();
    let btf = RawBtf::from_f32(views, lights, sw, sh, StoredEncoding::Linear, &data).unwrap();
    let st = find_stitch(&btf, &TileSpec::new(16, 16)).unwrap();
    let ts = TiledSource::new(&btf, &st).unwrap();
    assert_eq!((ts.width(), ts.height()), (16, 16));
    let full = btf.load_view(1).unwrap();
    let tiled = ts.load_view(1).unwrap();
    let n_in = sw * sh * 3;
    for l in 0..3 {
        assert_eq!(
            &tiled[l * 768..(l + 1) * 768],
            &tile_of(&st, &full[l * n_in..(l + 1) * n_in])[..]
        );
    }
    let seams = source_seams(&ts, 16).unwrap();
    assert!(seams.ratio() < 1.25, "{}", seams.ratio());
    let other = Stitch::crop(8, 8, (0, 0), 4, 4);
    assert!(TiledSource::new(&btf, &other).is_err());
}
