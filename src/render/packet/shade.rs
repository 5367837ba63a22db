//! The packet integrator's shading kernel for lanes that hit a surface: one batch of up to
//! [`LANES`] paths that share a BSDF (on triangles or analytic spheres, whose surface point
//! comes from the scalar code), shaded in structure-of-arrays stage by stage (surface
//! interaction → emission with MIS → emitter sample → BSDF evaluation → MIS and the shadow
//! ray → BSDF sample → throughput and Russian roulette → continuation ray). The BSDF-independent
//! stages are straight-line code on 16-lane values ([`crate::math::simd::wide`]), one AVX-512
//! instruction (two AVX2 ones) per operation in the build [`crate::isa_dispatch`] picks. The
//! BSDF's own stages run as its batched kernel where it has one — SoA for `diffuse`
//! ([`eval_local_x`], [`sample_local_x`]), 16 evaluations per pass for a fitted BTF
//! ([`PlmcBsdf::eval_pdf_batch`]) — and lane by lane through [`BsdfAt`] for the others.
//!
//! Every lane runs the scalar integrator's arithmetic through the `_x` twins of its helpers
//! ([`triangle_surface_x`], [`FrameX`], [`sample_toward_x`], …), which round like them, on the
//! same random stream, so a lane's path is the same bits as
//! [`crate::render::integrator::PathTracer::li`]'s (`tests/render_packet.rs` compares them).
//! What is not arithmetic stays scalar per lane: the gathers (mesh vertices, the pool's slots),
//! the random numbers, emitter selection and emission at emitter hits. Emitters other than
//! triangle-mesh area lights sample the lanes that chose them together
//! ([`crate::light::LightSet::sample_x`]: SoA for environment maps, constant, point, spot and
//! directional lights; an analytic sphere's lane by lane).

// `!(x > 0.0)` deliberately also rejects NaN, as in the scalar integrator.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::lanes::LANES;
use super::pool::{PathPool, Shadow};
use crate::bsdf::diffuse::{eval_local_x, pdf_local_x, sample_local_x};
use crate::bsdf::{Bsdf, BsdfAt, BsdfFlags, PlmcBsdf, Texture};
use crate::geometry::SurfaceInteraction;
use crate::geometry::accel::offset_origin_x;
use crate::geometry::shading::triangle_surface_x;
use crate::light::area::{sample_toward_x, tri_point_x};
use crate::light::{AreaLight, Light, LightSampleX};
use crate::math::frame::FrameX;
use crate::math::simd::wide::{Fx, Mx, V2x, V3x};
use crate::math::{Frame, Pcg32x, Spectrum, warp};
use crate::render::RenderScene;
use crate::render::integrator::{TraceStats, mis_weight, mis_weight_x, shadow_segment_from_x};

const L: usize = LANES;
// One batched view lookup serves a packet batch.
const _: () = assert!(L == crate::bsdf::plmc::PREPARE_LANES);

crate::isa_dispatch! {
    /// Shades the lanes `slots` of the pool (at most [`LANES`], all hit a surface whose BSDF
    /// is `bsdf`, or any `diffuse` one if `bsdf` is diffuse) one path segment on: what the
    /// scalar integrator's loop body does for each, in SoA.
    pub fn shade_hits(
        rs: &RenderScene,
        bsdf: &Bsdf,
        pool: &mut PathPool,
        slots: &[u32],
        stats: &mut TraceStats,
    ) -> () = shade;
}

/// The batched form a BSDF's own stages take.
#[derive(Clone, Copy)]
enum Kind<'a> {
    /// SoA twins of the scalar diffuse code, with the batch BSDF's albedo texture (each lane
    /// reads its own mesh's, see [`diffuse_sides`]); a `twosided` diffuse lane seen from below
    /// runs them on z-mirrored directions with its back albedo, as [`crate::bsdf::TwoSided`].
    Diffuse(&'a Texture),
    /// A fitted BTF: emitter evaluations 16 per pass of its batched kernel.
    Plmc(&'a PlmcBsdf),
    /// Lane by lane through the scalar code.
    Scalar,
}

#[inline(always)]
fn shade(
    rs: &RenderScene,
    bsdf: &Bsdf,
    pool: &mut PathPool,
    slots: &[u32],
    stats: &mut TraceStats,
) {
    let kind = match (diffuse_sides(bsdf), bsdf) {
        (Some((front, _)), _) => Kind::Diffuse(front),
        (None, Bsdf::Plmc(b)) => Kind::Plmc(b),
        (None, _) => Kind::Scalar,
    };
    let n = slots.len();
    if n == 0 {
        return;
    }
    debug_assert!(n <= L);
    let pt = &rs.integrator;
    let meshes = &rs.scene.meshes;
    let lights = &rs.lights;
    let zero = Fx::splat(0.0);

    // ------------------------------ gather (scalar) ------------------------------
    // Lanes past n keep zeros: the SoA stages compute them too, and nothing reads the results.
    let mut slot = [0usize; L];
    let mut tp = [V3x::ZERO; 3];
    let mut tn = [V3x::ZERO; 3];
    let mut tuv = [V2x::ZERO; 3];
    let mut has_n = Mx::splat(false);
    let mut has_uv = Mx::splat(false);
    let mut bary = V2x::ZERO;
    let mut hit_t = [0f32; L];
    let mut mesh_id = [0u32; L];
    let mut prim = [0u32; L];
    let mut ray_d = V3x::ZERO;
    let mut throughput = V3x::ZERO;
    let mut eta = Fx::splat(1.0);
    let mut is_sphere = Mx::splat(false);
    let (mut sph_p, mut sph_n, mut sph_du, mut sph_dv) =
        (V3x::ZERO, V3x::ZERO, V3x::ZERO, V3x::ZERO);
    let mut sph_uv = V2x::ZERO;
    for (l, &i) in slots.iter().enumerate() {
        let i = i as usize;
        slot[l] = i;
        let Some(h) = pool.hit[i] else { continue };
        let m = &meshes[h.mesh as usize];
        bary.set(l, h.b);
        hit_t[l] = h.t;
        mesh_id[l] = h.mesh;
        prim[l] = h.prim;
        ray_d.set(l, pool.ray_d.get(i));
        throughput.set(l, pool.throughput.get(i));
        eta.0[l] = pool.eta[i];
        if let Some(sphere) = &m.sphere {
            // An analytic sphere's surface comes from the scalar code; the frame and the rest
            // are the same SoA stages.
            let (sp, sn, suv, sdu, sdv) = sphere.surface(pool.ray_o.get(i), ray_d.get(l), h.t);
            is_sphere.0[l] = true;
            sph_p.set(l, sp);
            sph_n.set(l, sn);
            sph_uv.set(l, suv);
            sph_du.set(l, sdu);
            sph_dv.set(l, sdv);
            continue;
        }
        let v = m.indices[h.prim as usize].map(|k| k as usize);
        for k in 0..3 {
            tp[k].set(l, m.positions[v[k]]);
        }
        if !m.normals.is_empty() {
            has_n.0[l] = true;
            for k in 0..3 {
                tn[k].set(l, m.normals[v[k]]);
            }
        }
        if !m.uvs.is_empty() {
            has_uv.0[l] = true;
            for k in 0..3 {
                tuv[k].set(l, m.uvs[v[k]]);
            }
        }
    }

    // ------------------------- surface interaction (SoA) -------------------------
    let (p, ng, ns, uv, dpdu, dpdv) = triangle_surface_x(tp, has_n, tn, has_uv, tuv, bary);
    // (A sphere's shading normal is its geometric one.)
    let p = V3x::select(is_sphere, sph_p, p);
    let ng = V3x::select(is_sphere, sph_n, ng);
    let ns = V3x::select(is_sphere, sph_n, ns);
    let uv = V2x::select(is_sphere, sph_uv, uv);
    let dpdu = V3x::select(is_sphere, sph_du, dpdu);
    let dpdv = V3x::select(is_sphere, sph_dv, dpdv);
    let frame = FrameX::from_normal_tangent(ns, dpdu);
    let wi = frame.to_local(ray_d.neg());
    let si_at = |l: usize| SurfaceInteraction {
        p: p.get(l),
        t: hit_t[l],
        n: ng.get(l),
        sh_frame: Frame {
            s: frame.s.get(l),
            t: frame.t.get(l),
            n: frame.n.get(l),
        },
        uv: uv.get(l),
        dpdu: dpdu.get(l),
        dpdv: dpdv.get(l),
        wi: wi.get(l),
        mesh: mesh_id[l],
        prim: prim[l],
    };

    // ------- emission with MIS, depth limit, random numbers, emitter choice (scalar) -------
    let mut live = [false; L];
    // Each live lane's BSDF at its hit, with its per-hit state.
    let mut at_l: [Option<BsdfAt>; L] = [None; L];
    // Lanes that sample an emitter (drawing u_sel and u first).
    let mut nee = [false; L];
    let mut albedo = V3x::ZERO;
    // Diffuse lanes of a `twosided` seen from below (directions z-mirrored), and those seen
    // edge-on (wi.z neither > 0 nor < 0: black, no sample).
    let mut flip = Mx::splat(false);
    let mut edge_on = Mx::splat(false);
    // Lanes whose emitter sample is an area light's triangle, placed in the SoA stage below,
    // and lanes with the finished sample of any other emitter (in `other`).
    let mut is_area = Mx::splat(false);
    let mut is_other = Mx::splat(false);
    let mut other = LightSampleX {
        wi: V3x::splat(crate::math::Vec3::Z),
        dist: Fx::splat(1.0),
        n_geo: V3x::ZERO,
        weight: V3x::ZERO,
        pdf: Fx::splat(1.0),
        delta: Mx::splat(false),
    };
    let (mut lp0, mut le1, mut le2, mut lng) = (V3x::ZERO, V3x::ZERO, V3x::ZERO, V3x::ZERO);
    let mut ln = [V3x::ZERO; 3];
    let mut l_has_n = Mx::splat(false);
    let mut l_rad = V3x::ZERO;
    let mut l_inv_area = zero;
    // The area light each lane's emitter sample picked, if it picked one.
    let mut area: [Option<&AreaLight>; L] = [None; L];
    for l in 0..n {
        let i = slot[l];
        if lights.is_emissive(mesh_id[l]) {
            let si = si_at(l);
            let le = lights.area_radiance(meshes, &si);
            if le != Spectrum::ZERO {
                let em_pdf = if pool.prev_delta[i] || !pt.nee {
                    0.0
                } else {
                    lights.pdf_area_hit(pool.prev_p.get(i), &si)
                };
                let r = pool.result.get(i)
                    + pool.throughput.get(i) * le * mis_weight(pool.prev_pdf[i], em_pdf);
                pool.result.set(i, r);
            }
        }
        if pool.depth[i].saturating_add(1) >= pt.max_depth {
            pool.ending[i] = true;
            continue;
        }
        live[l] = true;
        let smooth = match kind {
            // Diffuse is smooth, and its SoA stages need only the albedo.
            Kind::Diffuse(batch) => {
                let mesh_bsdf = &rs.scene.bsdfs[meshes[mesh_id[l] as usize].bsdf as usize];
                // (The sort puts only diffuse meshes in a diffuse batch.)
                let tex = match diffuse_sides(mesh_bsdf).unwrap_or((batch, None)) {
                    (front, None) => front,
                    (front, Some(back)) => {
                        let z = wi.z.0[l];
                        flip.0[l] = z < 0.0;
                        edge_on.0[l] = !(z > 0.0) && !(z < 0.0);
                        if z < 0.0 { back } else { front }
                    }
                };
                albedo.set(l, tex.eval(uv.get(l)));
                true
            }
            // (Its per-hit states follow, for all live lanes at once.)
            Kind::Plmc(b) => b.flags().has(BsdfFlags::SMOOTH),
            Kind::Scalar => {
                let at = bsdf.at(&si_at(l));
                let smooth = at.flags().has(BsdfFlags::SMOOTH);
                at_l[l] = Some(at);
                smooth
            }
        };
        nee[l] = pt.nee && smooth;
    }
    if let Kind::Plmc(b) = kind {
        // A fitted BTF's per-hit states of the live lanes, 16 view lookups at once: what
        // `Bsdf::at` finds lane by lane.
        let going = (0..n).filter(|&l| live[l]).fold(0u16, |m, l| m | 1 << l);
        let hits = b.prepare16([&wi.x.0, &wi.y.0, &wi.z.0], [&uv.x.0, &uv.y.0], going);
        for l in (0..n).filter(|&l| live[l]) {
            at_l[l] = Some(match hits[l] {
                Some(h) => BsdfAt::Plmc(b, h),
                None => BsdfAt::Stateless(bsdf),
            });
        }
    }

    // ------------- random numbers (SoA, each lane on its own stream, in scalar order) -------------
    // Per live lane: u_sel and u if it samples an emitter, then u_lobe and u_bsdf (evaluating
    // the emitter sample draws none), then the Russian roulette number at write-back.
    let mut rng = Pcg32x::gather(&pool.rng, &slot, n);
    let u_sel = rng.next_f32(&nee);
    let mut u_light = V2x {
        x: Fx(rng.next_f32(&nee)),
        y: Fx(rng.next_f32(&nee)),
    };
    let u_lobe = Fx(rng.next_f32(&live));
    let u_bsdf = V2x {
        x: Fx(rng.next_f32(&live)),
        y: Fx(rng.next_f32(&live)),
    };

    // -------------- emitter choice (scalar); other emitters' samples (SoA) --------------
    // Each emitter other than a triangle-mesh area light samples the lanes that chose it
    // together (`LightSet::sample_x`); area lights follow below.
    let mut chosen = [0u32; L];
    let mut want_other = Mx::splat(false);
    for l in 0..n {
        if !nee[l] {
            continue;
        }
        let k = lights.select(u_sel[l]);
        match lights.lights.get(k) {
            None => {}
            Some(Light::Area(a)) => {
                area[l] = Some(a);
                is_area.0[l] = true;
            }
            Some(_) => {
                chosen[l] = k as u32;
                want_other.0[l] = true;
            }
        }
    }
    if want_other.0.contains(&true) {
        (other, is_other) = lights.sample_x(p, &chosen, want_other, u_light);
    }

    // ----------- area lights: triangle by area (SoA if the lanes share a light) -----------
    let mut tri_of = [0u32; L];
    match area.iter().flatten().next() {
        None => {}
        Some(&first) if area.iter().flatten().all(|&a| std::ptr::eq(a, first)) => {
            (tri_of, u_light.x) = first.pick_x(u_light.x);
        }
        Some(_) => {
            for l in 0..n {
                if let Some(a) = area[l] {
                    (tri_of[l], u_light.x.0[l]) = a.pick(u_light.x.0[l]);
                }
            }
        }
    }
    for l in 0..n {
        let Some(a) = area[l] else {
            continue;
        };
        let tri = a.triangle(tri_of[l]);
        lp0.set(l, tri.p0);
        le1.set(l, tri.e1);
        le2.set(l, tri.e2);
        lng.set(l, tri.ng);
        if let Some(nv) = tri.normals {
            l_has_n.0[l] = true;
            for (k, v) in nv.into_iter().enumerate() {
                ln[k].set(l, v);
            }
        }
        l_rad.set(l, a.radiance);
        l_inv_area.0[l] = a.inv_area();
    }

    // ------------------------- area-light samples (SoA) -------------------------
    let b = warp::square_to_uniform_triangle_x(u_light);
    let at = tri_point_x(lp0, le1, le2, lng, l_has_n, ln, b);
    let (area, area_ok) = sample_toward_x(l_rad, l_inv_area, p, at);
    let sel = if lights.is_empty() {
        1.0
    } else {
        lights.select_pdf()
    };
    let ls = LightSampleX::select(is_area, &area.with_selection(sel), &other);
    let has_light = is_area.and(area_ok).or(is_other);

    // --------------------------- BSDF evaluation ---------------------------
    let wo = frame.to_local(ls.wi);
    let delta = ls.delta;
    let (f, bsdf_pdf) = match kind {
        Kind::Diffuse(_) => {
            let (wi, wo) = (mirror_z(flip, wi), mirror_z(flip, wo));
            (
                V3x::select(edge_on, V3x::ZERO, eval_local_x(albedo, wi, wo)),
                Fx::select(delta.or(edge_on), zero, pdf_local_x(wi, wo)),
            )
        }
        Kind::Plmc(_) | Kind::Scalar => {
            let (mut f, mut pdf) = match kind {
                Kind::Plmc(b) => eval_plmc(b, &at_l, has_light, wo, delta),
                _ => (V3x::ZERO, zero),
            };
            for l in 0..n {
                // (A fitted BTF's lanes with per-hit state were evaluated in the batch.)
                if let (true, Some(at @ BsdfAt::Stateless(_))) = (has_light.0[l], &at_l[l]) {
                    let (fl, pl) = at.eval_for_light(&si_at(l), wo.get(l), delta.0[l]);
                    f.set(l, fl);
                    pdf.0[l] = pl;
                }
            }
            (f, pdf)
        }
    };

    // ---------------------- MIS and the shadow ray (SoA) ----------------------
    let mis = Fx::select(delta, Fx::splat(1.0), mis_weight_x(ls.pdf, bsdf_pdf));
    let shadow_on = has_light.and(f.is_zero().or(ls.weight.is_zero()).not());
    let contribution = throughput.mul(f).mul(ls.weight).scale(mis);
    let (sh_o, sh_d, sh_t, sh_test) = shadow_segment_from_x(p, ng, &ls);

    // ------------------------------ BSDF sample ------------------------------
    // (local direction, pdf, weight, η, delta lobe) per lane; `sampled` false where it failed.
    let (wo_s, s_pdf, weight, s_eta, s_delta, sampled) = match kind {
        Kind::Diffuse(_) => {
            let (wo, pdf, ok) = sample_local_x(mirror_z(flip, wi), u_bsdf);
            let (wo, ok) = (mirror_z(flip, wo), ok.and(edge_on.not()));
            // The albedo is the weight; a diffuse sample keeps η (× 1) and is not a delta lobe.
            (wo, pdf, albedo, Fx::splat(1.0), Mx::splat(false), ok)
        }
        Kind::Plmc(_) | Kind::Scalar => {
            let (mut wo, mut pdf, mut w) =
                (V3x::splat(crate::math::Vec3::Z), Fx::splat(1.0), V3x::ZERO);
            let (mut e, mut dl, mut ok) = (Fx::splat(1.0), Mx::splat(false), Mx::splat(false));
            let mut batched = [None; L];
            if let Kind::Plmc(b) = kind {
                batched = sample_plmc(b, &at_l, u_lobe, u_bsdf);
            }
            for l in 0..n {
                let Some(at) = &at_l[l] else { continue };
                let s = match at {
                    // (Sampled in the batch.)
                    BsdfAt::Plmc(..) if matches!(kind, Kind::Plmc(_)) => batched[l],
                    _ => at.sample(&si_at(l), u_lobe.0[l], u_bsdf.get(l)),
                };
                if let Some((bs, wl)) = s {
                    wo.set(l, bs.wo);
                    pdf.0[l] = bs.pdf;
                    w.set(l, wl);
                    e.0[l] = bs.eta;
                    dl.0[l] = bs.sampled.has(BsdfFlags::DELTA);
                    ok.0[l] = true;
                }
            }
            (wo, pdf, w, e, dl, ok)
        }
    };

    // ------------------------ throughput, continuation (SoA) ------------------------
    let wo_world = frame.to_world(wo_s);
    let new_tp = throughput.mul(weight);
    let eta = eta * s_eta;
    let t_max = new_tp.max_element();
    let q = (t_max * eta * eta).min(Fx::splat(0.95));
    let rr_tp = new_tp.div(q);
    let new_o = offset_origin_x(p, ng, wo_world);

    // Russian roulette's number, for the lanes that continue at a depth that plays it.
    let mut rr = [false; L];
    for l in 0..n {
        rr[l] = live[l] && sampled.0[l] && pool.depth[slot[l]] + 1 >= pt.rr_depth;
    }
    let u_rr = rng.next_f32(&rr);

    // --------------- Russian roulette and write-back ---------------
    for l in 0..n {
        let i = slot[l];
        if live[l] {
            if shadow_on.0[l] {
                stats.rays += 1;
                pool.shadow_c.set(i, contribution.get(l));
                pool.shadow[i] = if sh_test.0[l] {
                    pool.shadow_o.set(i, sh_o.get(l));
                    pool.shadow_d.set(i, sh_d.get(l));
                    pool.shadow_t[i] = sh_t.0[l];
                    Shadow::Test
                } else {
                    Shadow::Unoccluded
                };
            }
            if !sampled.0[l] {
                pool.ending[i] = true;
            } else {
                let depth = pool.depth[i] + 1;
                pool.depth[i] = depth;
                pool.prev_p.set(i, p.get(l));
                pool.prev_pdf[i] = s_pdf.0[l];
                pool.prev_delta[i] = s_delta.0[l];
                pool.eta[i] = eta.0[l];
                let mut alive = true;
                let mut tpl = new_tp.get(l);
                if rr[l] {
                    if !(u_rr[l] < q.0[l]) {
                        alive = false;
                    } else {
                        tpl = rr_tp.get(l);
                    }
                }
                pool.throughput.set(i, tpl);
                if !alive || !(t_max.0[l] > 0.0) {
                    pool.ending[i] = true;
                } else {
                    pool.ray_o.set(i, new_o.get(l));
                    pool.ray_d.set(i, wo_world.get(l));
                    pool.ray_t[i] = f32::INFINITY;
                    pool.passthrough[i] = false;
                    stats.rays += 1;
                }
            }
        }
    }
    rng.scatter(&mut pool.rng, &slot, n);
}

/// The albedo textures of a BSDF the diffuse SoA stages run: (front, back) of a `twosided`
/// over two `diffuse` models, (albedo, None) of a `diffuse` one, None for any other model.
/// Every such BSDF shares one sort key, since each lane reads its own mesh's textures.
pub fn diffuse_sides(b: &Bsdf) -> Option<(&Texture, Option<&Texture>)> {
    match b {
        Bsdf::Diffuse(d) => Some((&d.reflectance, None)),
        Bsdf::TwoSided(t) => match (&*t.front, &*t.back) {
            (Bsdf::Diffuse(f), Bsdf::Diffuse(k)) => Some((&f.reflectance, Some(&k.reflectance))),
            _ => None,
        },
        _ => None,
    }
}

/// `v` with z negated in the lanes of `m` (`twosided`'s mirror through the surface).
#[inline(always)]
fn mirror_z(m: Mx, v: V3x) -> V3x {
    V3x::new(v.x, v.y, Fx::select(m, -v.z, v.z))
}

/// The emitter evaluations of a fitted-BTF batch: (f, pdf) per lane for the lanes in `want`
/// whose BSDF kept its per-hit state (the rest through the scalar code), 16 per pass of the
/// batched kernel; the pdf is 0 for delta lights.
#[inline(always)]
fn eval_plmc(b: &PlmcBsdf, at_l: &[Option<BsdfAt>; L], want: Mx, wo: V3x, delta: Mx) -> (V3x, Fx) {
    let (mut f, mut pdf) = (V3x::ZERO, Fx::splat(0.0));
    let mut hits = [None; L];
    let mut at = [0usize; L];
    let mut wq = [crate::math::Vec3::ZERO; L];
    let mut want_pdf = [false; L];
    let mut m = 0;
    for l in 0..L {
        if let (true, Some(BsdfAt::Plmc(_, h))) = (want.0[l], &at_l[l]) {
            hits[m] = Some(*h);
            at[m] = l;
            wq[m] = wo.get(l);
            want_pdf[m] = !delta.0[l];
            m += 1;
        }
    }
    if let Some(first) = hits[0] {
        let hits = hits.map(|h| h.unwrap_or(first));
        let mut out = [(Spectrum::ZERO, 0.0); L];
        b.eval_pdf_batch(&hits[..m], &wq[..m], &want_pdf[..m], &mut out[..m]);
        for j in 0..m {
            f.set(at[j], out[j].0);
            pdf.0[at[j]] = out[j].1;
        }
    }
    (f, pdf)
}

/// The BSDF samples of a fitted-BTF batch's lanes that kept their per-hit state (`None`
/// elsewhere and where sampling fails), their model evaluations 16 per pass of the batched
/// kernel: [`PlmcBsdf::sample_batch`], the same samples as the scalar `sample_hit`.
#[inline(always)]
fn sample_plmc(
    b: &PlmcBsdf,
    at_l: &[Option<BsdfAt>; L],
    u_lobe: Fx,
    u_bsdf: V2x,
) -> [Option<(crate::bsdf::BsdfSample, Spectrum)>; L] {
    let mut out = [None; L];
    let mut hits = [None; L];
    let mut at = [0usize; L];
    let (mut u1, mut u2) = ([0f32; L], [crate::math::Vec2::ZERO; L]);
    let mut m = 0;
    for l in 0..L {
        if let Some(BsdfAt::Plmc(_, h)) = &at_l[l] {
            hits[m] = Some(*h);
            at[m] = l;
            (u1[m], u2[m]) = (u_lobe.0[l], u_bsdf.get(l));
            m += 1;
        }
    }
    if let Some(first) = hits[0] {
        let hits = hits.map(|h| h.unwrap_or(first));
        let mut got = [None; L];
        b.sample_batch(&hits[..m], &u1[..m], &u2[..m], &mut got[..m]);
        for j in 0..m {
            out[at[j]] = got[j];
        }
    }
    out
}

#[cfg(test)]
mod tests;
