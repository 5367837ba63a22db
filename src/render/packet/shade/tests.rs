//! Every `_x` twin the SoA kernel calls against its scalar original, lane by lane and bit for
//! bit, on random inputs mixed with the degenerate ones the branches exist for (zero vectors,
//! tangents parallel to the normal, degenerate uv maps, points behind a light, lights at
//! infinity, zero pdfs). `tests/rendering/packet_vs_scalar.rs` checks the whole kernel; this names the twin
//! that drifted.

use crate::bsdf::diffuse::{
    eval_local, eval_local_x, pdf_local, pdf_local_x, sample_local, sample_local_x,
};
use crate::geometry::accel::{offset_origin, offset_origin_x};
use crate::geometry::shading::{triangle_surface, triangle_surface_x};
use crate::light::area::{sample_toward, sample_toward_x, tri_point, tri_point_x};
use crate::light::{LightSample, LightSampleX};
use crate::math::frame::FrameX;
use crate::math::simd::f16::{F16, M16, V2x, V3x};
use crate::math::{Frame, Pcg32, Vec2, Vec3, warp};
use crate::render::integrator::{
    mis_weight, mis_weight_x, shadow_segment_from, shadow_segment_from_x,
};

const L: usize = 16;

fn bits3(v: Vec3) -> [u32; 3] {
    v.to_array().map(f32::to_bits)
}

fn bits2(v: Vec2) -> [u32; 2] {
    v.to_array().map(f32::to_bits)
}

/// Random vectors in [-2, 2]³ with every fifth one degenerate (zero, an axis, or a copy).
fn v3(rng: &mut Pcg32, k: usize) -> Vec3 {
    match k % 5 {
        0 => Vec3::ZERO,
        1 => Vec3::Z,
        _ => Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0 - 2.0,
    }
}

#[test]
fn twins_match_their_scalar_helpers() {
    let mut rng = Pcg32::new(3, 14);
    for round in 0..300 {
        let mut tp = [V3x::ZERO; 3];
        let mut tn = [V3x::ZERO; 3];
        let mut tuv = [V2x::ZERO; 3];
        let (mut has_n, mut has_uv) = (M16::splat(false), M16::splat(false));
        let (mut b, mut u) = (V2x::ZERO, V2x::ZERO);
        let (mut d, mut extra) = (V3x::ZERO, V3x::ZERO);
        let mut scalar_in = Vec::new();
        for l in 0..L {
            let k = round + l;
            let p = [
                v3(&mut rng, 2 + k),
                v3(&mut rng, 3 + k),
                v3(&mut rng, 4 + k),
            ];
            let n = [v3(&mut rng, k), v3(&mut rng, k + 2), v3(&mut rng, k + 3)]
                .map(|v| v.normalize_or_zero());
            // Degenerate uv maps (det 0) on every seventh lane.
            let mut t = [0; 3].map(|_| Vec2::new(rng.next_f32(), rng.next_f32()));
            if k % 7 == 0 {
                t[2] = t[1];
            }
            let bb = Vec2::new(rng.next_f32(), rng.next_f32()) * 0.5;
            let uu = Vec2::new(rng.next_f32(), rng.next_f32());
            let uu = if k % 11 == 0 { Vec2::splat(0.5) } else { uu };
            let dd = v3(&mut rng, k + 4).normalize_or_zero();
            let ee = v3(&mut rng, k + 1);
            for j in 0..3 {
                tp[j].set(l, p[j]);
                tn[j].set(l, n[j]);
                tuv[j].set(l, t[j]);
            }
            has_n.0[l] = k % 3 == 0;
            has_uv.0[l] = k % 2 == 0;
            b.set(l, bb);
            u.set(l, uu);
            d.set(l, dd);
            extra.set(l, ee);
            scalar_in.push((p, n, t, bb, uu, dd, ee));
        }
        // Surface interaction, frame, local directions.
        let (p, ng, ns, uv, du, dv) = triangle_surface_x(tp, has_n, tn, has_uv, tuv, b);
        let fr = FrameX::from_normal_tangent(ns, du);
        let fr_n = FrameX::from_normal(ns);
        let wi = fr.to_local(d);
        let ww = fr.to_world(d);
        // Area-light point and sample, offsets, shadow segments.
        let tb = warp::square_to_uniform_triangle_x(u);
        let at = tri_point_x(p, du, dv, ng, has_n, tn, tb);
        let rad = V3x::splat(Vec3::new(1.0, 2.0, 3.0));
        let (ls, ok) = sample_toward_x(rad, F16::splat(0.25), extra, at);
        let off = offset_origin_x(p, ng, d);
        let mut lsx = ls;
        for l in 0..L {
            // Lights at infinity and point lights (no normal) on some lanes.
            if l % 4 == 1 {
                lsx.dist.0[l] = f32::INFINITY;
            }
            if l % 4 == 2 {
                lsx.n_geo.set(l, Vec3::ZERO);
            }
        }
        let (so, sd, st, sok) = shadow_segment_from_x(p, ng, &lsx);
        // Diffuse BSDF, MIS.
        let f = eval_local_x(rad, wi, d);
        let pdf = pdf_local_x(wi, d);
        let (swo, spdf, sok2) = sample_local_x(wi, u);
        let mis = mis_weight_x(pdf, ls.pdf);
        for l in 0..L {
            let (tpl, n, t, bb, uu, dd, ee) = scalar_in[l];
            let normals = has_n.0[l].then_some(n);
            let uvs = has_uv.0[l].then_some(t);
            let (sp, sng, sns, suv, sdu, sdv) = triangle_surface(tpl, normals, uvs, bb);
            assert_eq!(bits3(p.get(l)), bits3(sp), "p, lane {l} round {round}");
            assert_eq!(bits3(ng.get(l)), bits3(sng));
            assert_eq!(bits3(ns.get(l)), bits3(sns));
            assert_eq!(bits2(uv.get(l)), bits2(suv));
            assert_eq!(bits3(du.get(l)), bits3(sdu));
            assert_eq!(bits3(dv.get(l)), bits3(sdv));
            let sf = Frame::from_normal_tangent(sns, sdu);
            assert_eq!(
                bits3(fr.s.get(l)),
                bits3(sf.s),
                "frame s, lane {l} round {round}"
            );
            assert_eq!(bits3(fr.t.get(l)), bits3(sf.t));
            let sfn = Frame::from_normal(sns);
            assert_eq!(bits3(fr_n.s.get(l)), bits3(sfn.s));
            assert_eq!(bits3(fr_n.t.get(l)), bits3(sfn.t));
            let swi = sf.to_local(dd);
            assert_eq!(bits3(wi.get(l)), bits3(swi));
            assert_eq!(bits3(ww.get(l)), bits3(sf.to_world(dd)));
            let stb = warp::square_to_uniform_triangle(uu);
            assert_eq!(bits2(tb.get(l)), bits2(stb));
            let sat = tri_point(sp, sdu, sdv, sng, normals, stb);
            assert_eq!(bits3(at.0.get(l)), bits3(sat.0));
            assert_eq!(bits3(at.2.get(l)), bits3(sat.2));
            let sls = sample_toward(Vec3::new(1.0, 2.0, 3.0), 0.25, ee, sat);
            assert_eq!(ok.0[l], sls.is_some(), "light sample validity, lane {l}");
            if let Some(s) = sls {
                assert_eq!(bits3(ls.wi.get(l)), bits3(s.wi));
                assert_eq!(ls.dist.0[l].to_bits(), s.dist.to_bits());
                assert_eq!(bits3(ls.weight.get(l)), bits3(s.weight));
                assert_eq!(ls.pdf.0[l].to_bits(), s.pdf.to_bits());
            }
            assert_eq!(bits3(off.get(l)), bits3(offset_origin(sp, sng, dd)));
            let one = LightSample {
                wi: lsx.wi.get(l),
                dist: lsx.dist.0[l],
                n_geo: lsx.n_geo.get(l),
                weight: lsx.weight.get(l),
                pdf: lsx.pdf.0[l],
                delta: false,
            };
            let seg = shadow_segment_from(sp, sng, &one);
            assert_eq!(sok.0[l], seg.is_some(), "shadow segment validity, lane {l}");
            if let Some((o, dir, t)) = seg {
                assert_eq!(bits3(so.get(l)), bits3(o));
                assert_eq!(bits3(sd.get(l)), bits3(dir));
                assert_eq!(st.0[l].to_bits(), t.to_bits());
            }
            let r = Vec3::new(1.0, 2.0, 3.0);
            assert_eq!(bits3(f.get(l)), bits3(eval_local(r, swi, dd)));
            assert_eq!(pdf.0[l].to_bits(), pdf_local(swi, dd).to_bits());
            let s = sample_local(swi, uu);
            assert_eq!(sok2.0[l], s.is_some());
            if let Some((wo, pd)) = s {
                assert_eq!(bits3(swo.get(l)), bits3(wo));
                assert_eq!(spdf.0[l].to_bits(), pd.to_bits());
            }
            let m = mis_weight(pdf_local(swi, dd), ls.pdf.0[l]);
            assert_eq!(mis.0[l].to_bits(), m.to_bits());
        }
    }
    // The light sample's edges: a point at the reference point, a light seen edge-on (cos 0),
    // from behind, and a regular one.
    let cases = [
        (Vec3::ZERO, Vec3::ZERO, Vec3::Z),
        (Vec3::X, Vec3::ZERO, Vec3::Z),
        (Vec3::X, Vec3::ZERO, Vec3::X),
        (Vec3::X, Vec3::ZERO, -Vec3::X),
    ];
    let (mut pl, mut pr, mut nl) = (V3x::ZERO, V3x::ZERO, V3x::ZERO);
    for l in 0..L {
        let (a, b, c) = cases[l % cases.len()];
        pl.set(l, a);
        pr.set(l, b);
        nl.set(l, c);
    }
    let r = Vec3::ONE;
    let (_, ok) = sample_toward_x(V3x::splat(r), F16::splat(1.0), pr, (pl, nl, nl));
    for l in 0..L {
        let s = sample_toward(r, 1.0, pr.get(l), (pl.get(l), nl.get(l), nl.get(l)));
        assert_eq!(ok.0[l], s.is_some(), "edge case {}", l % cases.len());
    }
    // LightSampleX::select keeps each side's delta flag.
    let a = LightSampleX {
        wi: V3x::ZERO,
        dist: F16::splat(1.0),
        n_geo: V3x::ZERO,
        weight: V3x::ZERO,
        pdf: F16::splat(1.0),
        delta: M16::splat(true),
    };
    let b = LightSampleX {
        delta: M16::splat(false),
        ..a
    };
    let mut m = M16::splat(false);
    m.0[3] = true;
    let s = LightSampleX::select(m, &a, &b);
    assert!((0..L).all(|l| s.delta.0[l] == (l == 3)));
}
