//! Stage 1: the template offset, cut paths and blend radii found on a few representative images
//! (and the patches of further tiles), giving a [`Stitch`].

use super::TileSpec;
use super::cut::{blend_radii, min_error_cut, ramp};
use super::stitch::{Mix, Stitch};
use crate::btf::{BtfSource, DirectionSet, StoredEncoding};
use crate::math::Vec3;
use crate::{Error, Result};

/// Feature images of the representative pictures: `[texel][feature]`, stored encoding.
struct Features {
    w: usize,
    d: usize,
    f: Vec<f32>,
}

impl Features {
    #[inline]
    fn at(&self, x: usize, y: usize) -> &[f32] {
        let i = (y * self.w + x) * self.d;
        &self.f[i..i + self.d]
    }
}

#[inline]
pub(super) fn dist(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

fn mix_into(out: &mut [f32], a: &[f32], wa: f32, b: &[f32]) {
    for ((o, &x), &y) in out.iter_mut().zip(a).zip(b) {
        *o = wa * x + (1.0 - wa) * y;
    }
}

/// A two-way blend of mixes, weights scaled; zero weights are dropped.
fn blend(a: &Mix, wa: f32, b: &Mix) -> Mix {
    let mut m: Mix = Vec::with_capacity(a.len() + b.len());
    if wa > 0.0 {
        m.extend(a.iter().map(|&(s, w)| (s, w * wa)));
    }
    if wa < 1.0 {
        for &(s, w) in b {
            let w = w * (1.0 - wa);
            match m.iter_mut().find(|e| e.0 == s) {
                Some(e) => e.1 += w,
                None => m.push((s, w)),
            }
        }
    }
    m
}

/// One cut: its path, blend radii and mean error per path cell.
struct Cut {
    path: Vec<usize>,
    radii: Vec<usize>,
    cost: f64,
}

fn cut(err: &[f32], len: usize, band: usize, cyclic: bool) -> Cut {
    let (path, c) = min_error_cut(err, len, band, cyclic);
    let radii = blend_radii(err, band, &path);
    Cut {
        path,
        radii,
        cost: c / len as f64,
    }
}

/// The template's two wrap cuts for source origin (x0, y0).
struct Template {
    horiz: Cut,
    vert: Cut,
    cost: f64,
}

fn template_cuts(f: &Features, x0: usize, y0: usize, w: usize, h: usize, o: usize) -> Template {
    let d = f.d;
    let wo = w + o;
    // Horizontal cut over the band rows 0..o, along all w + o columns: A = S(x, y) continues into
    // row o, B = S(x, h + y) continues from row h − 1.
    let mut err = vec![0.0f32; wo * o];
    for x in 0..wo {
        for j in 0..o {
            err[x * o + j] = dist(f.at(x0 + x, y0 + j), f.at(x0 + x, y0 + h + j));
        }
    }
    let horiz = cut(&err, wo, o, false);
    // Intermediate image I (w + o) × h, wrapping in y; only the band columns are needed.
    let mut fi_a = vec![0.0f32; h * o * d];
    let mut fi_b = vec![0.0f32; h * o * d];
    let fill = |x: usize, y: usize, out: &mut [f32]| {
        if y < o {
            let a = ramp(y as isize, horiz.path[x], horiz.radii[x]);
            mix_into(out, f.at(x0 + x, y0 + y), a, f.at(x0 + x, y0 + h + y));
        } else {
            out.copy_from_slice(f.at(x0 + x, y0 + y));
        }
    };
    for y in 0..h {
        for j in 0..o {
            let i = (y * o + j) * d;
            fill(j, y, &mut fi_a[i..i + d]);
            fill(w + j, y, &mut fi_b[i..i + d]);
        }
    }
    // Vertical cut over the band columns 0..o, along all h rows, cyclic (I wraps in y).
    let mut err = vec![0.0f32; h * o];
    for (e, (a, b)) in err
        .iter_mut()
        .zip(fi_a.chunks_exact(d).zip(fi_b.chunks_exact(d)))
    {
        *e = dist(a, b);
    }
    let vert = cut(&err, h, o, true);
    let cost = (horiz.cost * wo as f64 + vert.cost * h as f64) / (wo + h) as f64;
    Template { horiz, vert, cost }
}

fn template_mixes(
    sw: usize,
    x0: usize,
    y0: usize,
    w: usize,
    h: usize,
    o: usize,
    t: &Template,
) -> Vec<Mix> {
    let s = |x: usize, y: usize| -> Mix { vec![(((y0 + y) * sw + x0 + x) as u32, 1.0)] };
    let i_mix = |x: usize, y: usize| -> Mix {
        if y < o {
            let a = ramp(y as isize, t.horiz.path[x], t.horiz.radii[x]);
            blend(&s(x, y), a, &s(x, h + y))
        } else {
            s(x, y)
        }
    };
    let mut out = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            out.push(if x < o {
                let a = ramp(x as isize, t.vert.path[y], t.vert.radii[y]);
                blend(&i_mix(x, y), a, &i_mix(w + x, y))
            } else {
                i_mix(x, y)
            });
        }
    }
    out
}

/// Candidate positions 0..=range with a step chosen so a 2-D search over `range × other` offsets
/// stays within ~`budget` candidates (every position when it does), always including both ends.
fn candidates(range: usize, other: usize, budget: usize) -> Vec<usize> {
    let n = ((range + 1) * (other + 1)) as f64 / budget as f64;
    let step = (n.sqrt().ceil() as usize).max(1);
    let mut v: Vec<usize> = (0..=range).step_by(step).collect();
    if v.last() != Some(&range) {
        v.push(range);
    }
    v
}

/// The four cuts that stitch a `pw × ph` patch from sample (px, py) into the template at (m, m).
struct PatchCuts {
    cuts: [Cut; 4],
    cost: f64,
}

#[allow(clippy::too_many_arguments)]
fn patch_cuts(
    f: &Features,
    ft: &[f32],
    w: usize,
    m: usize,
    px: usize,
    py: usize,
    pw: usize,
    ph: usize,
    op: usize,
) -> PatchCuts {
    let d = f.d;
    let t_at = |x: usize, y: usize| &ft[((m + y) * w + m + x) * d..((m + y) * w + m + x + 1) * d];
    let e = |x: usize, y: usize| dist(t_at(x, y), f.at(px + x, py + y));
    let mut maps: [Vec<f32>; 4] = Default::default();
    // left / right: along rows, across columns; top / bottom: along columns, across rows.
    maps[0] = (0..ph)
        .flat_map(|i| (0..op).map(move |j| (j, i)))
        .map(|(x, y)| e(x, y))
        .collect();
    maps[1] = (0..ph)
        .flat_map(|i| (0..op).map(move |j| (pw - op + j, i)))
        .map(|(x, y)| e(x, y))
        .collect();
    maps[2] = (0..pw)
        .flat_map(|i| (0..op).map(move |j| (i, j)))
        .map(|(x, y)| e(x, y))
        .collect();
    maps[3] = (0..pw)
        .flat_map(|i| (0..op).map(move |j| (i, ph - op + j)))
        .map(|(x, y)| e(x, y))
        .collect();
    let cuts = [
        cut(&maps[0], ph, op, false),
        cut(&maps[1], ph, op, false),
        cut(&maps[2], pw, op, false),
        cut(&maps[3], pw, op, false),
    ];
    let cost =
        (cuts[0].cost + cuts[1].cost) * ph as f64 + (cuts[2].cost + cuts[3].cost) * pw as f64;
    PatchCuts {
        cuts,
        cost: cost / (2 * (pw + ph)) as f64,
    }
}

/// Weight of the patch at patch texel (x, y).
fn patch_weight(c: &PatchCuts, x: usize, y: usize, pw: usize, ph: usize, op: usize) -> f32 {
    let [l, r, t, b] = &c.cuts;
    let (xi, yi) = (x as isize, y as isize);
    ramp(xi, l.path[y], l.radii[y])
        * (1.0 - ramp(xi - (pw - op) as isize, r.path[y], r.radii[y]))
        * ramp(yi, t.path[x], t.radii[x])
        * (1.0 - ramp(yi - (ph - op) as isize, b.path[x], b.radii[x]))
}

/// Stage 1 on given representative images (linear `[texel][rgb]`, sample `sw × sh`): finds the
/// template (and patches) and returns the stitch.
pub fn find_stitch_in(
    images: &[&[f32]],
    sw: usize,
    sh: usize,
    enc: StoredEncoding,
    spec: &TileSpec,
) -> Result<Stitch> {
    let (w, h) = (spec.width, spec.height);
    if w > sw || h > sh {
        return Err(Error::Invalid(format!(
            "the {w}×{h} tile is larger than the {sw}×{sh} sample"
        )));
    }
    if w < 4 || h < 4 {
        return Err(Error::Invalid(format!(
            "the {w}×{h} tile is too small (at least 4×4)"
        )));
    }
    let room = (sw - w).min(sh - h);
    let o = spec
        .overlap
        .unwrap_or_else(|| (w.min(h) / 4).clamp(2, 16).min(room));
    if o < 2 || o > room || o > w.min(h) / 2 {
        return Err(Error::Invalid(format!(
            "the {w}×{h} tile needs an overlap band of 2..={} texels inside the {sw}×{sh} sample \
             (overlap {o}): use a smaller tile",
            (w.min(h) / 2).min(room).max(2)
        )));
    }
    if spec.count == 0 {
        return Err(Error::Invalid("--tiles must be at least 1".into()));
    }
    if images.is_empty() || images.iter().any(|i| i.len() != sw * sh * 3) {
        return Err(Error::Invalid(format!(
            "stitching needs representative images of {sw}×{sh} texels"
        )));
    }
    let d = 3 * images.len();
    let mut feat = vec![0.0f32; sw * sh * d];
    for (r, img) in images.iter().enumerate() {
        for t in 0..sw * sh {
            for c in 0..3 {
                feat[t * d + 3 * r + c] = enc.encode(img[3 * t + c]);
            }
        }
    }
    let f = Features { w: sw, d, f: feat };
    // Stage 1a: the template origin with the cheapest wrap cuts.
    let mut best: Option<((usize, usize), Template)> = None;
    // Every offset while ≲ 50k candidates and 4·10⁸ feature differences, a grid beyond (each
    // candidate costs O((w + h) · overlap · features)).
    let budget = (400_000_000 / ((w + h) * o * d).max(1)).clamp(1_000, 50_000);
    for &y0 in &candidates(sh - h - o, sw - w - o, budget) {
        for &x0 in &candidates(sw - w - o, sh - h - o, budget) {
            let t = template_cuts(&f, x0, y0, w, h, o);
            if best.as_ref().is_none_or(|b| t.cost < b.1.cost) {
                best = Some(((x0, y0), t));
            }
        }
    }
    let ((x0, y0), tpl) = best.ok_or_else(|| Error::Invalid("no template position".into()))?;
    let mut mixes = template_mixes(sw, x0, y0, w, h, o, &tpl);
    let cut_error = (tpl.cost / d as f64).sqrt();
    let mut patches = Vec::new();
    if spec.count > 1 {
        let m = o;
        let (pw, ph) = (w - 2 * m, h - 2 * m);
        let op = o.min(pw / 4).min(ph / 4);
        if op < 2 {
            return Err(Error::Invalid(format!(
                "{} tiles need inner patches: the {w}×{h} tile is too small for a {o}-texel \
                 overlap (needs at least {}×{})",
                spec.count,
                2 * m + 8,
                2 * m + 8
            )));
        }
        // Template features, for the patch cut error maps.
        let mut ft = vec![0.0f32; w * h * d];
        for (t, mix) in mixes.iter().enumerate() {
            for &(s, wt) in mix {
                let src = &f.f[s as usize * d..(s as usize + 1) * d];
                for (o, &v) in ft[t * d..(t + 1) * d].iter_mut().zip(src) {
                    *o += wt * v;
                }
            }
        }
        let template_mixes = mixes.clone();
        // Positions already used: the template's own inner area, then each patch.
        let mut used = vec![(x0 + m, y0 + m)];
        let min_sep = pw.max(ph) / 2;
        for _ in 1..spec.count {
            let mut bestp: Option<((usize, usize), PatchCuts)> = None;
            for &py in &candidates(sh - ph, sw - pw, budget) {
                for &px in &candidates(sw - pw, sh - ph, budget) {
                    if used
                        .iter()
                        .any(|&(ux, uy)| ux.abs_diff(px).max(uy.abs_diff(py)) < min_sep)
                    {
                        continue;
                    }
                    let c = patch_cuts(&f, &ft, w, m, px, py, pw, ph, op);
                    if bestp.as_ref().is_none_or(|b| c.cost < b.1.cost) {
                        bestp = Some(((px, py), c));
                    }
                }
            }
            let ((px, py), pc) = bestp.ok_or_else(|| {
                Error::Invalid(format!(
                    "the {sw}×{sh} sample is too small for {} different {w}×{h} tiles",
                    spec.count
                ))
            })?;
            used.push((px, py));
            patches.push((px, py));
            for y in 0..h {
                for x in 0..w {
                    let t = y * w + x;
                    let inside = (m..m + pw).contains(&x) && (m..m + ph).contains(&y);
                    mixes.push(if inside {
                        let (u, v) = (x - m, y - m);
                        let a = patch_weight(&pc, u, v, pw, ph, op);
                        let p: Mix = vec![(((py + v) * sw + px + u) as u32, 1.0)];
                        blend(&p, a, &template_mixes[t])
                    } else {
                        template_mixes[t].clone()
                    });
                }
            }
        }
    }
    Ok(Stitch::from_mixes(
        sw,
        sh,
        w,
        h,
        spec.count,
        o,
        (x0, y0),
        patches,
        cut_error,
        &mixes,
    ))
}

/// Representative (view, light) pairs spread over the hemisphere: up to `n` (3..=5 sensible) of
/// (θv, φv, θl, φl) = (0,0,45,0), (30,90,30,270), (60,0,15,180), (45,200,60,20), (75,120,45,300),
/// each snapped to the nearest measured direction, duplicates dropped.
pub fn representative_pairs(
    views: &DirectionSet,
    lights: &DirectionSet,
    n: usize,
) -> Vec<(usize, usize)> {
    const TARGETS: [(f32, f32, f32, f32); 5] = [
        (0.0, 0.0, 45.0, 0.0),
        (30.0, 90.0, 30.0, 270.0),
        (60.0, 0.0, 15.0, 180.0),
        (45.0, 200.0, 60.0, 20.0),
        (75.0, 120.0, 45.0, 300.0),
    ];
    let dir = |t: f32, p: f32| {
        let (t, p) = (t.to_radians(), p.to_radians());
        Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
    };
    let nearest = |set: &DirectionSet, d: Vec3| {
        (0..set.len())
            .max_by(|&a, &b| set.dirs[a].dot(d).total_cmp(&set.dirs[b].dot(d)))
            .unwrap_or(0)
    };
    let mut out: Vec<(usize, usize)> = Vec::new();
    for &(tv, pv, tl, pl) in TARGETS.iter().take(n.max(1)) {
        let p = (nearest(views, dir(tv, pv)), nearest(lights, dir(tl, pl)));
        if !out.contains(&p) {
            out.push(p);
        }
    }
    out
}

/// Stage 1 on a BTF: loads the representative images and finds the stitch.
pub fn find_stitch(source: &dyn BtfSource, spec: &TileSpec) -> Result<Stitch> {
    let (sw, sh) = (source.width(), source.height());
    if spec.width > sw || spec.height > sh {
        return Err(Error::Invalid(format!(
            "the {}×{} tile is larger than the {sw}×{sh} sample",
            spec.width, spec.height
        )));
    }
    let pairs = representative_pairs(source.views(), source.lights(), 5);
    let n = sw * sh * 3;
    let mut images: Vec<Vec<f32>> = Vec::with_capacity(pairs.len());
    let mut views: Vec<usize> = pairs.iter().map(|p| p.0).collect();
    views.dedup();
    for v in views {
        let data = source.load_view(v)?;
        for &(pv, l) in &pairs {
            if pv == v {
                images.push(data[l * n..(l + 1) * n].to_vec());
            }
        }
    }
    let refs: Vec<&[f32]> = images.iter().map(|i| i.as_slice()).collect();
    find_stitch_in(&refs, sw, sh, source.encoding(), spec)
}
