//! Delaunay triangulation of small planar point sets (measured directions projected to the unit
//! disk), canonical even for the many cocircular quadruples of ring-shaped measurement sets.
//!
//! Construction: a lexicographic sweep builds some triangulation of the convex hull, then Lawson
//! edge flips make it Delaunay. Ties (four cocircular points, which UBO2003/UBO2014 have by the
//! dozen: two rings sharing two azimuths form an isosceles trapezoid) are broken by the rule
//! "the diagonal of a cocircular convex quad is the one through its lowest-index point". That rule
//! is the Delaunay triangulation of the points with lifts perturbed symbolically (point i lowered by
//! ε^(i+1)), so the result is unique, independent of construction order, and another implementation
//! (e.g. the Mitsuba reference plugin) can reproduce it exactly by flipping its own Delaunay
//! triangulation to the same rule. O(n²) at worst, which is nothing for n ≤ a few thousand.

use std::collections::HashMap;

/// Sine of the angle below which three points count as collinear (inputs are f32-rounded).
const COLLINEAR_SIN: f64 = 1e-6;
/// |α + β − π| (radians) below which a quad counts as cocircular.
const COCIRCULAR_RAD: f64 = 1e-6;
/// Points closer than this (disk units) are duplicates.
const DUPLICATE_DIST: f64 = 1e-7;

/// Twice the signed area of (a, b, c); > 0 when counter-clockwise.
#[inline]
pub(crate) fn orient(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
}

/// Sign of [`orient`] with a relative tolerance: 0 when the angle at `a` is within
/// [`COLLINEAR_SIN`] of 0 or π.
fn orient_sign(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> i32 {
    let o = orient(a, b, c);
    let lab = (b[0] - a[0]).hypot(b[1] - a[1]);
    let lac = (c[0] - a[0]).hypot(c[1] - a[1]);
    let lbc = (c[0] - b[0]).hypot(c[1] - b[1]);
    // |o| = product of two sides × sine of their angle; use the two longest sides so the test
    // measures the smallest angle of the triangle.
    let (l1, l2) = {
        let mut s = [lab, lac, lbc];
        s.sort_by(f64::total_cmp);
        (s[1], s[2])
    };
    if o.abs() <= COLLINEAR_SIN * l1 * l2 {
        0
    } else if o > 0.0 {
        1
    } else {
        -1
    }
}

/// Interior angle at `p` of the triangle (p, q, r), in (0, π).
fn angle_at(p: [f64; 2], q: [f64; 2], r: [f64; 2]) -> f64 {
    let u = [q[0] - p[0], q[1] - p[1]];
    let v = [r[0] - p[0], r[1] - p[1]];
    let cross = u[0] * v[1] - u[1] * v[0];
    let dot = u[0] * v[0] + u[1] * v[1];
    cross.abs().atan2(dot)
}

/// Delaunay triangles (counter-clockwise index triples into `points`) with the canonical tie rule
/// of the module docs. Errors on fewer than 3 points, duplicates, non-finite or all-collinear input.
pub fn triangulate(points: &[[f64; 2]]) -> Result<Vec<[u32; 3]>, String> {
    let n = points.len();
    if n < 3 {
        return Err(format!("needs at least 3 directions, got {n}"));
    }
    if n > u32::MAX as usize / 4 {
        return Err(format!("too many directions ({n})"));
    }
    if let Some(i) = points
        .iter()
        .position(|p| !p[0].is_finite() || !p[1].is_finite())
    {
        return Err(format!("direction {i} is not finite"));
    }
    let mut order: Vec<u32> = (0..n as u32).collect();
    order.sort_by(|&i, &j| {
        let (p, q) = (points[i as usize], points[j as usize]);
        p[0].total_cmp(&q[0]).then(p[1].total_cmp(&q[1]))
    });
    // Duplicates are within DUPLICATE_DIST in x, so a short window after each point suffices.
    for (k, &i) in order.iter().enumerate() {
        let p = points[i as usize];
        for &j in &order[k + 1..] {
            let q = points[j as usize];
            if q[0] - p[0] > DUPLICATE_DIST {
                break;
            }
            if (q[1] - p[1]).abs() <= DUPLICATE_DIST {
                let (a, b) = (i.min(j), i.max(j));
                return Err(format!("directions {a} and {b} coincide"));
            }
        }
    }
    let pt = |i: u32| points[i as usize];

    // Initial collinear run s[0..k], then the first point off their line.
    let (s0, s1) = (order[0], order[1]);
    let k = (2..n)
        .find(|&k| orient_sign(pt(s0), pt(s1), pt(order[k])) != 0)
        .ok_or_else(|| "all directions lie on one great circle through the normal".to_string())?;
    let apex = order[k];
    let left = orient(pt(s0), pt(s1), pt(apex)) > 0.0;
    let mut tris: Vec<[u32; 3]> = Vec::with_capacity(2 * n);
    for w in order[..k].windows(2) {
        tris.push(if left {
            [w[0], w[1], apex]
        } else {
            [w[1], w[0], apex]
        });
    }
    // Convex hull, counter-clockwise.
    let mut hull: Vec<u32> = if left {
        order[..=k].to_vec()
    } else {
        std::iter::once(s0)
            .chain(std::iter::once(apex))
            .chain(order[1..k].iter().rev().copied())
            .collect()
    };

    // Sweep: each new point is lexicographically largest, hence outside the current hull.
    for &p in &order[k + 1..] {
        let h = hull.len();
        let visible: Vec<bool> = (0..h)
            .map(|i| orient_sign(pt(hull[i]), pt(hull[(i + 1) % h]), pt(p)) < 0)
            .collect();
        let Some(first_vis) = (0..h).find(|&i| visible[i]) else {
            // Rounding put p on a hull edge (e.g. equal x in exact arithmetic): split that edge.
            split_hull_edge(points, &mut hull, &mut tris, p)?;
            continue;
        };
        // Start of the (cyclic) visible chain: a visible edge whose predecessor is not visible.
        let start = (0..h)
            .map(|d| (first_vis + h - d) % h)
            .find(|&i| !visible[(i + h - 1) % h])
            .ok_or_else(|| format!("direction {p} sees the whole hull (degenerate geometry)"))?;
        let mut count = 0;
        while visible[(start + count) % h] {
            let (a, b) = (hull[(start + count) % h], hull[(start + count + 1) % h]);
            tris.push([b, a, p]);
            count += 1;
            if count == h {
                break;
            }
        }
        // Replace the hull vertices strictly inside the visible chain by p.
        let mut new_hull = Vec::with_capacity(h + 1);
        let end = (start + count) % h; // last vertex of the chain (stays)
        let mut i = end;
        loop {
            new_hull.push(hull[i]);
            if i == start {
                break;
            }
            i = (i + 1) % h;
        }
        new_hull.push(p);
        hull = new_hull;
    }

    lawson_flips(points, &mut tris)?;
    Ok(tris)
}

/// Inserts `p`, which lies on a hull edge (within the collinearity tolerance), by splitting the
/// edge and the triangle on it.
fn split_hull_edge(
    points: &[[f64; 2]],
    hull: &mut Vec<u32>,
    tris: &mut Vec<[u32; 3]>,
    p: u32,
) -> Result<(), String> {
    let pt = |i: u32| points[i as usize];
    let h = hull.len();
    let on_edge = (0..h).find(|&i| {
        let (a, b) = (pt(hull[i]), pt(hull[(i + 1) % h]));
        let q = pt(p);
        let d = [b[0] - a[0], b[1] - a[1]];
        let s = ((q[0] - a[0]) * d[0] + (q[1] - a[1]) * d[1]) / (d[0] * d[0] + d[1] * d[1]);
        orient_sign(a, b, q) == 0 && s > 0.0 && s < 1.0
    });
    let Some(i) = on_edge else {
        return Err(format!(
            "direction {p} could not be inserted (degenerate geometry)"
        ));
    };
    let (a, b) = (hull[i], hull[(i + 1) % h]);
    let t = tris
        .iter()
        .position(|tri| (0..3).any(|e| tri[e] == a && tri[(e + 1) % 3] == b))
        .ok_or_else(|| format!("direction {p}: hull edge without triangle"))?;
    let c = third(tris[t], a, b);
    tris[t] = [a, p, c];
    tris.push([p, b, c]);
    hull.insert(i + 1, p);
    Ok(())
}

/// Edge flips until every interior edge satisfies the (tie-broken) Delaunay criterion.
fn lawson_flips(points: &[[f64; 2]], tris: &mut [[u32; 3]]) -> Result<(), String> {
    let pt = |i: u32| points[i as usize];
    // Directed edge (a, b) → triangle that has it counter-clockwise.
    let mut owner: HashMap<(u32, u32), usize> = HashMap::with_capacity(3 * tris.len());
    for (t, tri) in tris.iter().enumerate() {
        for e in 0..3 {
            owner.insert((tri[e], tri[(e + 1) % 3]), t);
        }
    }
    let mut stack: Vec<(u32, u32)> = owner.keys().copied().filter(|&(a, b)| a < b).collect();
    stack.sort_unstable(); // deterministic processing order
    let n = points.len();
    let max_flips = 20 * n * n + 1000;
    let mut flips = 0usize;
    while let Some((a, b)) = stack.pop() {
        let (Some(&t1), Some(&t2)) = (owner.get(&(a, b)), owner.get(&(b, a))) else {
            continue; // hull edge or no longer present
        };
        let c = third(tris[t1], a, b);
        let d = third(tris[t2], b, a);
        if !should_flip(pt(a), pt(b), pt(c), pt(d), [a, b, c, d]) {
            continue;
        }
        flips += 1;
        if flips > max_flips {
            return Err("Delaunay edge flipping did not converge (degenerate geometry)".into());
        }
        for (t, tri) in [(t1, tris[t1]), (t2, tris[t2])] {
            for e in 0..3 {
                let key = (tri[e], tri[(e + 1) % 3]);
                if owner.get(&key) == Some(&t) {
                    owner.remove(&key);
                }
            }
        }
        // Quad a, d, b, c is counter-clockwise; the new diagonal is c–d.
        tris[t1] = [a, d, c];
        tris[t2] = [d, b, c];
        for t in [t1, t2] {
            let tri = tris[t];
            for e in 0..3 {
                owner.insert((tri[e], tri[(e + 1) % 3]), t);
            }
        }
        for (u, v) in [(a, d), (d, b), (b, c), (c, a)] {
            stack.push((u.min(v), u.max(v)));
        }
    }
    Ok(())
}

/// The vertex of `tri` that is neither `a` nor `b`.
fn third(tri: [u32; 3], a: u32, b: u32) -> u32 {
    tri.into_iter()
        .find(|&v| v != a && v != b)
        .unwrap_or(tri[0])
}

/// Whether edge a–b, shared by the counter-clockwise triangles (a, b, c) and (b, a, d), must be
/// replaced by c–d. `ids` = [a, b, c, d] as point indices for the tie rule.
pub(crate) fn should_flip(
    a: [f64; 2],
    b: [f64; 2],
    c: [f64; 2],
    d: [f64; 2],
    ids: [u32; 4],
) -> bool {
    // Only a strictly convex quad can be flipped.
    if orient_sign(c, d, a) * orient_sign(c, d, b) >= 0 {
        return false;
    }
    let excess = angle_at(c, a, b) + angle_at(d, a, b) - std::f64::consts::PI;
    if excess > COCIRCULAR_RAD {
        true
    } else if excess < -COCIRCULAR_RAD {
        false
    } else {
        let m = *ids.iter().min().unwrap_or(&ids[0]);
        m == ids[2] || m == ids[3]
    }
}

#[cfg(test)]
pub(crate) mod tests_support {
    pub(crate) use super::tests::check;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(points: &[[f64; 2]], t: [u32; 3]) -> f64 {
        0.5 * orient(
            points[t[0] as usize],
            points[t[1] as usize],
            points[t[2] as usize],
        )
    }

    /// Checks a triangulation: CCW non-degenerate triangles, every point used, edges shared by at
    /// most two triangles with opposite orientation, total area = hull area, and every interior
    /// edge locally Delaunay with the tie rule (which makes the triangulation the canonical one).
    pub(crate) fn check(points: &[[f64; 2]], tris: &[[u32; 3]]) {
        let mut edges: HashMap<(u32, u32), usize> = HashMap::new();
        let mut used = vec![false; points.len()];
        let mut total = 0.0;
        for (t, &tri) in tris.iter().enumerate() {
            assert!(area(points, tri) > 0.0, "triangle {tri:?} not CCW");
            total += area(points, tri);
            for e in 0..3 {
                used[tri[e] as usize] = true;
                assert!(
                    edges.insert((tri[e], tri[(e + 1) % 3]), t).is_none(),
                    "edge used twice in one direction"
                );
            }
        }
        assert!(used.iter().all(|&u| u), "a point is not a vertex");
        let hull = convex_hull_area(points);
        assert!(
            (total - hull).abs() < 1e-9 * hull.max(1e-3),
            "area {total} vs hull {hull}"
        );
        for (&(a, b), &t1) in &edges {
            if let Some(&t2) = edges.get(&(b, a)) {
                let c = third(tris[t1], a, b);
                let d = third(tris[t2], b, a);
                let p = |i: u32| points[i as usize];
                assert!(
                    !should_flip(p(a), p(b), p(c), p(d), [a, b, c, d]),
                    "edge {a}-{b} is not canonical Delaunay"
                );
            }
        }
    }

    fn convex_hull_area(points: &[[f64; 2]]) -> f64 {
        let mut p = points.to_vec();
        p.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
        let mut lower: Vec<[f64; 2]> = Vec::new();
        for &q in &p {
            while lower.len() >= 2
                && orient(lower[lower.len() - 2], lower[lower.len() - 1], q) <= 0.0
            {
                lower.pop();
            }
            lower.push(q);
        }
        let mut upper: Vec<[f64; 2]> = Vec::new();
        for &q in p.iter().rev() {
            while upper.len() >= 2
                && orient(upper[upper.len() - 2], upper[upper.len() - 1], q) <= 0.0
            {
                upper.pop();
            }
            upper.push(q);
        }
        lower.pop();
        upper.pop();
        lower.extend(upper);
        let m = lower.len();
        (0..m)
            .map(|i| {
                let (a, b) = (lower[i], lower[(i + 1) % m]);
                0.5 * (a[0] * b[1] - a[1] * b[0])
            })
            .sum()
    }

    #[test]
    fn lattice_with_collinear_and_cocircular_points() {
        let mut pts = Vec::new();
        for i in -3..=3 {
            for j in -3..=3 {
                pts.push([0.2 * i as f64, 0.2 * j as f64]);
            }
        }
        let tris = triangulate(&pts).unwrap();
        check(&pts, &tris);
        assert_eq!(tris.len(), 2 * 36);
        // Canonical tie rule on a unit square of the lattice: the diagonal through its lowest index.
        // Indices: (x, y) = 0.2·(i − 3, j − 3) at 7·i + j; square 0, 1, 7, 8 is the corner one.
        let has = |a: u32, b: u32| tris.iter().any(|t| t.contains(&a) && t.contains(&b));
        assert!(has(0, 8) && !has(1, 7));
    }

    #[test]
    fn rejects_degenerate_input() {
        assert!(triangulate(&[[0.0, 0.0], [1.0, 0.0]]).is_err());
        assert!(triangulate(&[[0.0, 0.0], [0.5, 0.0], [1.0, 0.0]]).is_err());
        let e = triangulate(&[[0.0, 0.0], [0.5, 0.3], [0.0, 0.0]]).unwrap_err();
        assert!(e.contains("0 and 2"), "{e}");
        assert!(triangulate(&[[0.0, 0.0], [f64::NAN, 0.3], [0.1, 0.0]]).is_err());
    }

    #[test]
    fn collinear_start_then_apex_on_either_side() {
        for apex_y in [0.5, -0.5] {
            let pts = [
                [0.0, 0.0],
                [0.1, 0.0],
                [0.2, 0.0],
                [0.3, 0.0],
                [0.35, apex_y],
                [0.5, 0.1],
            ];
            let tris = triangulate(&pts).unwrap();
            check(&pts, &tris);
        }
    }
}
