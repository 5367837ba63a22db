//! Model-space refinement of a PLM-C clustering (a departure from the paper, which stops after
//! K-means in feature space and one refit per cluster).
//!
//! K-means minimises the squared distance of ~20 selected feature values; what the model is judged
//! by is the absolute error of the cluster's lobe over all lights. This alternates, Lloyd-style,
//! on that objective: (a) reassign every texel to the candidate cluster whose lobe curve over all
//! lights is closest in L1 (candidates: the current cluster's nearest clusters by curve distance,
//! so a pass costs `texels × candidates × lights`), re-seeding clusters left empty with the texels
//! fitted worst; (b) per cluster, replace the lobe by a refit on its members (LSQ on the members'
//! mean curve, and on their per-light median curve, each from the LSQ start and from the current
//! lobe) when that lowers the members' L1 error. Both steps only accept changes that lower the
//! error, so the total never rises.

use super::lafortune::{self, LobeFitter};
use crate::math::color::linear_to_srgb;
use crate::math::order_key;
use crate::math::simd::isa;
use crate::model::PackedLobe;
use crate::model::lobe::Lobe;
use crate::model::polynomial::{self, Poly};
use rayon::prelude::*;

/// Settings of [`refine`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RefineOptions {
    /// Reassign/refit rounds at most (0: no refinement).
    pub iterations: usize,
    /// Clusters a texel may move to: the nearest ones (by curve distance) to its current cluster.
    pub candidates: usize,
}

/// What [`refine`] did.
#[derive(Clone, Debug, Default)]
pub struct RefineStats {
    /// Total L1 error (all texels, all lights, metric space) before and after every round.
    pub errors: Vec<f64>,
    /// Texel moves over all rounds.
    pub moves: usize,
    /// Cluster lobes replaced by a better refit over all rounds.
    pub refits: usize,
    /// Empty clusters re-seeded with a badly fitted texel.
    pub reseeds: usize,
}

/// The lobe as the file stores it (so errors are those of the quantised model).
fn quantised(l: &Lobe) -> Lobe {
    PackedLobe::pack(l).unpack()
}

/// Curve of `lobe` over the fitter's lights, through the per-light mappings `map` if given
/// (negative outputs clamped to 0), in the metric space.
fn curve(fitter: &LobeFitter, lobe: &Lobe, map: Option<&[Poly]>, srgb: bool, out: &mut [f32]) {
    lafortune::eval_all(lobe, fitter, out);
    if let Some(map) = map {
        for (v, a) in out.iter_mut().zip(map) {
            *v = polynomial::eval(a, *v).max(0.0);
        }
    }
    if srgb {
        out.iter_mut()
            .for_each(|v| *v = linear_to_srgb(v.clamp(0.0, 1.0)));
    }
}

/// L1 distance of two curves (lane-split so it vectorises).
#[inline(always)]
fn l1(a: &[f32], b: &[f32]) -> f32 {
    const LANES: usize = 8;
    let mut acc = [0.0f32; LANES];
    let (ca, ra) = a.split_at(a.len() / LANES * LANES);
    let (cb, rb) = b.split_at(ca.len());
    for (x, y) in ca.chunks_exact(LANES).zip(cb.chunks_exact(LANES)) {
        for k in 0..LANES {
            acc[k] += (x[k] - y[k]).abs();
        }
    }
    let tail: f32 = ra.iter().zip(rb).map(|(x, y)| (x - y).abs()).sum();
    acc.iter().sum::<f32>() + tail
}

crate::isa_dispatch! {
    /// The candidate cluster whose curve (`curves`, `nl` values each) is nearest to `y` in L1, if
    /// nearer than `own_err` (the error at the current cluster `own`); else (`own`, `own_err`).
    fn nearest_curve(
        y: &[f32],
        curves: &[f32],
        nl: usize,
        cand: &[u32],
        own: u32,
        own_err: f32,
    ) -> (u32, f32) = nearest_curve_impl;
}

#[inline(always)]
fn nearest_curve_impl(
    y: &[f32],
    curves: &[f32],
    nl: usize,
    cand: &[u32],
    own: u32,
    own_err: f32,
) -> (u32, f32) {
    let (mut best, mut best_e) = (own, own_err);
    for &b in cand.iter().filter(|&&b| b != own) {
        let e = l1(y, &curves[b as usize * nl..][..nl]);
        if e < best_e {
            (best, best_e) = (b, e);
        }
    }
    (best, best_e)
}

/// Refines `lobes` (one per cluster) and `assign` (cluster per texel) against the texels' light
/// curves `y` (`texels × lights`, the space lobes are fitted in). The error is measured on the
/// values themselves, or on their sRGB encoding with `srgb_metric` (lobes fitted to linear values
/// of 8-bit data); with `map` (one polynomial per light), on the lobe values mapped by it (the
/// per-image correction the model will apply). Lobes come out quantised as the file stores them.
pub fn refine(
    fitter: &LobeFitter,
    y: &[f32],
    srgb_metric: bool,
    map: Option<&[Poly]>,
    lobes: &mut [Lobe],
    assign: &mut [u32],
    opts: RefineOptions,
) -> RefineStats {
    let nl = fitter.lights();
    let k = lobes.len();
    let texels = assign.len();
    let mut stats = RefineStats::default();
    if k == 0
        || texels == 0
        || nl == 0
        || y.len() != texels * nl
        || map.is_some_and(|m| m.len() != nl)
    {
        return stats;
    }
    for l in lobes.iter_mut() {
        *l = quantised(l);
    }
    let ym: Vec<f32> = if srgb_metric {
        y.iter()
            .map(|&v| linear_to_srgb(v.clamp(0.0, 1.0)))
            .collect()
    } else {
        y.to_vec()
    };
    let row = |t: usize| &ym[t * nl..(t + 1) * nl];
    let mut curves = vec![0.0f32; k * nl];
    let fill_curves = |lobes: &[Lobe], curves: &mut [f32]| {
        curves
            .par_chunks_mut(nl)
            .zip(lobes.par_iter())
            .for_each(|(c, l)| curve(fitter, l, map, srgb_metric, c));
    };
    fill_curves(lobes, &mut curves);
    let mut err: Vec<f32> = (0..texels)
        .map(|t| l1(row(t), &curves[assign[t] as usize * nl..][..nl]))
        .collect();
    let total = |err: &[f32]| err.iter().map(|&e| e as f64).sum::<f64>();
    stats.errors.push(total(&err));
    let m = opts.candidates.clamp(1, k);
    for _ in 0..opts.iterations {
        // (a) Candidate lists: the m clusters nearest to each cluster by curve distance (itself
        // first, at distance 0).
        let cand: Vec<u32> = (0..k)
            .into_par_iter()
            .flat_map_iter(|a| {
                let ca = &curves[a * nl..(a + 1) * nl];
                let mut d: Vec<(f32, u32)> = (0..k)
                    .map(|b| {
                        let db = if a == b {
                            -1.0
                        } else {
                            l1(ca, &curves[b * nl..(b + 1) * nl])
                        };
                        (db, b as u32)
                    })
                    .collect();
                d.select_nth_unstable_by(m - 1, |x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
                d.truncate(m);
                d.into_iter().map(|p| p.1)
            })
            .collect();
        // Reassignment: move only on a strict improvement.
        let moves: Vec<(u32, f32)> = (0..texels)
            .into_par_iter()
            .with_min_len(64)
            .map(|t| {
                let a = assign[t] as usize;
                nearest_curve(
                    isa(),
                    row(t),
                    &curves,
                    nl,
                    &cand[a * m..(a + 1) * m],
                    a as u32,
                    err[t],
                )
            })
            .collect();
        let mut moved = 0;
        for (t, &(b, e)) in moves.iter().enumerate() {
            if b != assign[t] {
                moved += 1;
                assign[t] = b;
                err[t] = e;
            }
        }
        stats.moves += moved;
        // Re-seed empty clusters with the worst-fitted texels' own lobes (when that helps them).
        let mut count = vec![0usize; k];
        for &a in assign.iter() {
            count[a as usize] += 1;
        }
        let empty: Vec<usize> = (0..k).filter(|&a| count[a] == 0).collect();
        if !empty.is_empty() {
            let mut worst: Vec<usize> = (0..texels).collect();
            worst.sort_unstable_by(|&a, &b| err[b].total_cmp(&err[a]).then(a.cmp(&b)));
            let mut c = vec![0.0f32; nl];
            let mut next = worst.into_iter();
            for a in empty {
                for t in next.by_ref() {
                    if count[assign[t] as usize] <= 1 {
                        continue; // moving it would empty its own cluster
                    }
                    let own = quantised(&fitter.fit(&y[t * nl..(t + 1) * nl]).lobe);
                    curve(fitter, &own, map, srgb_metric, &mut c);
                    let e = l1(row(t), &c);
                    if e < err[t] {
                        count[assign[t] as usize] -= 1;
                        count[a] = 1;
                        assign[t] = a as u32;
                        err[t] = e;
                        lobes[a] = own;
                        curves[a * nl..(a + 1) * nl].copy_from_slice(&c);
                        stats.reseeds += 1;
                        break;
                    }
                }
            }
        }
        // (b) Refit every cluster on its members; keep the candidate with the lowest member L1.
        let mut members: Vec<Vec<usize>> = vec![Vec::new(); k];
        for (t, &a) in assign.iter().enumerate() {
            members[a as usize].push(t);
        }
        let refits: Vec<Option<(Lobe, Vec<f32>)>> = (0..k)
            .into_par_iter()
            .map(|a| {
                let mem = &members[a];
                if mem.is_empty() {
                    return None;
                }
                let mut mean = vec![0.0f32; nl];
                let mut median = vec![0.0f32; nl];
                // The members' curves transposed to one column per light, as order keys of the
                // values (`u32` comparisons select faster than `f32::total_cmp`): each member's
                // row is read whole (the rows are scattered over the texels; a column-wise gather
                // would miss the cache once per value). The column sums run in member order.
                let n = mem.len();
                let mut cols = vec![0u32; n * nl];
                let mut sum = vec![0.0f64; nl];
                for (i, &t) in mem.iter().enumerate() {
                    for (l, &v) in y[t * nl..(t + 1) * nl].iter().enumerate() {
                        cols[l * n + i] = order_key::key(v);
                        sum[l] += v as f64;
                    }
                }
                for (l, col) in cols.chunks_exact_mut(n).enumerate() {
                    mean[l] = (sum[l] / n as f64) as f32;
                    let mid = n / 2;
                    col.select_nth_unstable(mid);
                    median[l] = order_key::unkey(col[mid]);
                }
                let cur = lobes[a];
                let member_err = |c: &[f32]| mem.iter().map(|&t| l1(row(t), c) as f64).sum::<f64>();
                let base: f64 = mem.iter().map(|&t| err[t] as f64).sum();
                let mut best: Option<(Lobe, Vec<f32>, f64)> = None;
                let mut c = vec![0.0f32; nl];
                for target in [&mean, &median] {
                    for fit in [fitter.fit(target), fitter.fit_from(cur, target)] {
                        let l = quantised(&fit.lobe);
                        curve(fitter, &l, map, srgb_metric, &mut c);
                        let e = member_err(&c);
                        if e < best.as_ref().map_or(base, |b| b.2) {
                            best = Some((l, c.clone(), e));
                        }
                    }
                }
                best.map(|(l, c, _)| (l, c))
            })
            .collect();
        let mut refitted = 0;
        for (a, r) in refits.into_iter().enumerate() {
            if let Some((l, c)) = r {
                lobes[a] = l;
                curves[a * nl..(a + 1) * nl].copy_from_slice(&c);
                refitted += 1;
                for &t in &members[a] {
                    err[t] = l1(row(t), &c);
                }
            }
        }
        stats.refits += refitted;
        stats.errors.push(total(&err));
        if moved == 0 && refitted == 0 {
            break;
        }
    }
    stats
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::btf::DirectionSet;
    use crate::math::Pcg32;

    /// Texels drawn from `types` distinct lobes plus noise; returns (curves, true type per texel).
    fn texels(fitter: &LobeFitter, types: &[Lobe], per: usize, noise: f32) -> (Vec<f32>, Vec<u32>) {
        let nl = fitter.lights();
        let mut rng = Pcg32::new(9, 3);
        let mut y = Vec::new();
        let mut truth = Vec::new();
        let mut c = vec![0.0f32; nl];
        for i in 0..per * types.len() {
            let ty = i % types.len();
            lafortune::eval_all(&types[ty], fitter, &mut c);
            y.extend(
                c.iter()
                    .map(|&v| (v + noise * (rng.next_f32() - 0.5)).max(0.0)),
            );
            truth.push(ty as u32);
        }
        (y, truth)
    }

    fn types() -> Vec<Lobe> {
        vec![
            [0.8, 0.0, 0.0, 1.0, 2.0],
            [0.5, 0.5, 0.0, 0.75f32.sqrt(), 8.0],
            [0.3, -0.3, 0.4, (1.0f32 - 0.25).sqrt(), 1.0],
            [0.9, 0.0, -0.6, 0.8, 20.0],
        ]
    }

    #[test]
    fn fixes_planted_bad_assignments_and_never_raises_the_error() {
        let f = LobeFitter::new(&DirectionSet::ubo2003().dirs).unwrap();
        let types = types();
        let (y, truth) = texels(&f, &types, 10, 0.02);
        // Correct clusters, but three texels planted in the wrong cluster and rough lobes.
        let mut assign = truth.clone();
        assign[0] = 1;
        assign[5] = 3;
        assign[6] = 0;
        let mut lobes: Vec<Lobe> = types
            .iter()
            .map(|l| [l[0] * 1.3, l[1], l[2], l[3], l[4] * 0.7])
            .collect();
        let s = refine(
            &f,
            &y,
            false,
            None,
            &mut lobes,
            &mut assign,
            RefineOptions {
                iterations: 5,
                candidates: 4,
            },
        );
        assert_eq!(assign, truth, "{s:?}");
        assert!(s.moves >= 3 && s.refits > 0, "{s:?}");
        for w in s.errors.windows(2) {
            assert!(w[1] <= w[0], "error rose: {:?}", s.errors);
        }
        assert!(
            s.errors.last().unwrap() < &(0.5 * s.errors[0]),
            "{:?}",
            s.errors
        );
    }

    #[test]
    fn the_error_through_a_mapping_is_what_is_refined() {
        // The data are the squares of the type lobes' values; through the mapping y ↦ y² the
        // type lobes explain them exactly. Planted bad assignments must be fixed under the map,
        // and the refined lobes must stay near the type lobes (not fit the squared data raw).
        let f = LobeFitter::new(&DirectionSet::ubo2003().dirs).unwrap();
        let types = types();
        let (y, truth) = texels(&f, &types, 10, 0.0);
        let y: Vec<f32> = y.iter().map(|v| v * v).collect();
        let square: Vec<Poly> = vec![[0.0, 0.0, 1.0, 0.0, 0.0]; f.lights()];
        let mut assign = truth.clone();
        assign[1] = 2;
        assign[2] = 0;
        let mut lobes = types.clone();
        let s = refine(
            &f,
            &y,
            false,
            Some(&square),
            &mut lobes,
            &mut assign,
            RefineOptions {
                iterations: 4,
                candidates: 4,
            },
        );
        assert_eq!(assign, truth, "{s:?}");
        for w in s.errors.windows(2) {
            assert!(w[1] <= w[0], "error rose: {:?}", s.errors);
        }
        assert!(
            s.errors.last().unwrap() < &(1e-2 * s.errors[0]),
            "{:?}",
            s.errors
        );
        for (l, t) in lobes.iter().zip(&types) {
            assert!((l[0] - t[0]).abs() < 0.02 * t[0], "{l:?} vs {t:?}");
        }
        // A map of the wrong length is refused (nothing changes).
        let short = vec![[0.0, 1.0, 0.0, 0.0, 0.0]; 3];
        let mut a2 = assign.clone();
        a2[0] = 1;
        let s = refine(
            &f,
            &y,
            false,
            Some(&short),
            &mut lobes,
            &mut a2,
            RefineOptions {
                iterations: 2,
                candidates: 4,
            },
        );
        assert!(s.errors.is_empty() && a2[0] == 1);
    }

    #[test]
    fn empty_clusters_are_reseeded_and_the_error_never_rises() {
        let f = LobeFitter::new(&DirectionSet::ubo2003().dirs).unwrap();
        let types = types();
        let (y, truth) = texels(&f, &types, 8, 0.05);
        // Everything in cluster 0 of 4 (sRGB metric this time): the refinement must spread the
        // texels over the clusters.
        let mut assign = vec![0u32; truth.len()];
        let mut lobes = vec![types[0]; 4];
        let s = refine(
            &f,
            &y,
            true,
            None,
            &mut lobes,
            &mut assign,
            RefineOptions {
                iterations: 6,
                candidates: 4,
            },
        );
        assert!(s.reseeds > 0, "{s:?}");
        for w in s.errors.windows(2) {
            assert!(w[1] <= w[0], "error rose: {:?}", s.errors);
        }
        let mut used = assign.clone();
        used.sort();
        used.dedup();
        assert_eq!(used.len(), 4, "{assign:?}");
        assert!(
            s.errors.last().unwrap() < &(0.5 * s.errors[0]),
            "{:?}",
            s.errors
        );
        // Degenerate inputs do nothing.
        let mut none: Vec<Lobe> = Vec::new();
        assert!(
            refine(
                &f,
                &y,
                false,
                None,
                &mut none,
                &mut assign,
                RefineOptions {
                    iterations: 3,
                    candidates: 4
                }
            )
            .errors
            .is_empty()
        );
    }
}
