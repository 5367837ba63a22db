//! The packet integrator's shading kernel for lanes that hit a surface: one batch of up to
//! [`LANES`] paths that share a BSDF (on triangles or analytic spheres, whose surface point
//! comes from the scalar code), shaded in structure-of-arrays stage by stage (surface
//! interaction → emission with MIS → emitter sample → BSDF evaluation → MIS and the shadow
//! ray → BSDF sample → throughput and Russian roulette → continuation ray). The BSDF-independent
//! stages are straight-line code on 16-lane values ([`crate::math::simd::f16`]), one AVX-512
//! instruction (two AVX2 ones) per operation in the build [`crate::isa_dispatch`] picks. The
//! BSDF's own stages go through the batched BSDF interface ([`BsdfBatch`]), which runs each
//! kind's batched kernel or its scalar code lane by lane; this kernel names no BSDF model.
//!
//! Every lane runs the scalar integrator's arithmetic through the `_x` twins of its helpers
//! ([`triangle_surface_x`], [`FrameX`], [`sample_toward_x`], …), which round like them, on the
//! same random stream, so a lane's path is the same bits as
//! [`crate::render::path`]'s (`tests/rendering/packet_vs_scalar.rs` compares them).
//! What is not arithmetic stays scalar per lane: the gathers (mesh vertices, the pool's slots),
//! the random numbers, emitter selection and emission at emitter hits. Emitters other than
//! triangle-mesh area lights sample the lanes that chose them together
//! ([`crate::light::LightSet::sample_x`]: SoA for environment maps, constant, point, spot and
//! directional lights; an analytic sphere's lane by lane).

// `!(x > 0.0)` deliberately also rejects NaN, as in the scalar integrator.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::lane_stats::LANES;
use super::pool::{PathPool, Shadow};
use crate::bsdf::Bsdf;
use crate::bsdf::batch::BsdfBatch;
use crate::geometry::SurfaceInteraction;
use crate::geometry::accel::offset_origin_x;
use crate::geometry::shading::{placement, triangle_surface_x, triangle_vertices};
use crate::light::area::{sample_toward_x, tri_point_x};
use crate::light::{AreaLight, Light, LightSampleX};
use crate::math::frame::FrameX;
use crate::math::simd::f16::{F16, M16, V2x, V3x};
use crate::math::{Frame, Pcg32x, Spectrum, warp};
use crate::render::RenderScene;
use crate::render::integrator::{TraceStats, mis_weight, mis_weight_x, shadow_segment_from_x};

const L: usize = LANES;
// A BSDF batch is a packet's lanes.
const _: () = assert!(L == crate::bsdf::batch::L);

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

#[inline(always)]
fn shade(
    rs: &RenderScene,
    bsdf: &Bsdf,
    pool: &mut PathPool,
    slots: &[u32],
    stats: &mut TraceStats,
) {
    let n = slots.len();
    if n == 0 {
        return;
    }
    debug_assert!(n <= L);
    let pt = &rs.integrator;
    let meshes = &rs.scene.meshes;
    let lights = &rs.lights;
    let zero = F16::splat(0.0);

    // ------------------------------ gather (scalar) ------------------------------
    // Lanes past n keep zeros: the SoA stages compute them too, and nothing reads the results.
    let mut slot = [0usize; L];
    let mut tp = [V3x::ZERO; 3];
    let mut tn = [V3x::ZERO; 3];
    let mut tuv = [V2x::ZERO; 3];
    let mut has_n = M16::splat(false);
    let mut has_uv = M16::splat(false);
    let mut bary = V2x::ZERO;
    let mut hit_t = [0f32; L];
    let mut mesh_id = [0u32; L];
    let mut prim = [0u32; L];
    let mut ray_d = V3x::ZERO;
    let mut throughput = V3x::ZERO;
    let mut eta = F16::splat(1.0);
    let mut is_sphere = M16::splat(false);
    let mut mirror = M16::splat(false);
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
        if let Some(pl) = placement(meshes, &h) {
            // An instance's triangle: its corners and normals moved to world space first, as
            // the scalar `surface_interaction` does.
            let (p3, n3, uv3) = triangle_vertices(m, h.prim);
            let (p3, n3) = pl.triangle_to_world(p3, n3);
            mirror.0[l] = pl.mirrors;
            for k in 0..3 {
                tp[k].set(l, p3[k]);
            }
            if let Some(n3) = n3 {
                has_n.0[l] = true;
                for k in 0..3 {
                    tn[k].set(l, n3[k]);
                }
            }
            if let Some(uv3) = uv3 {
                has_uv.0[l] = true;
                for k in 0..3 {
                    tuv[k].set(l, uv3[k]);
                }
            }
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
    // A mirroring instance's normals as `Placement::orient` turns them.
    let ng = V3x::select(mirror, ng.neg(), ng);
    let ns = V3x::select(mirror.and(has_n.not()), ns.neg(), ns);
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
        bary: if is_sphere.0[l] {
            crate::math::Vec2::ZERO
        } else {
            bary.get(l)
        },
    };

    // ------- emission with MIS, depth limit, random numbers, emitter choice (scalar) -------
    let mut live = [false; L];
    // The lanes' BSDF stages, batched where the BSDF has a batched kernel.
    let mut batch = BsdfBatch::new(bsdf);
    // Lanes that sample an emitter (drawing u_sel and u first).
    let mut nee = [false; L];
    // Lanes whose emitter sample is an area light's triangle, placed in the SoA stage below,
    // and lanes with the finished sample of any other emitter (in `other`).
    let mut is_area = M16::splat(false);
    let mut is_other = M16::splat(false);
    let mut other = LightSampleX {
        wi: V3x::splat(crate::math::Vec3::Z),
        dist: F16::splat(1.0),
        n_geo: V3x::ZERO,
        weight: V3x::ZERO,
        pdf: F16::splat(1.0),
        delta: M16::splat(false),
    };
    let (mut lp0, mut le1, mut le2, mut lng) = (V3x::ZERO, V3x::ZERO, V3x::ZERO, V3x::ZERO);
    let mut ln = [V3x::ZERO; 3];
    let mut l_has_n = M16::splat(false);
    let mut l_rad = V3x::ZERO;
    let mut l_inv_area = zero;
    // The area light each lane's emitter sample picked, if it picked one.
    let mut area: [Option<&AreaLight>; L] = [None; L];
    for l in 0..n {
        let i = slot[l];
        if lights.is_emissive(mesh_id[l]) {
            let si = si_at(l);
            let le = lights.area_radiance(&si);
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
        let own = &rs.scene.bsdfs[meshes[mesh_id[l] as usize].bsdf as usize];
        let smooth = batch.start_lane(l, own, wi.get(l), uv.get(l), || si_at(l));
        nee[l] = pt.nee && smooth;
    }
    let going = (0..n).filter(|&l| live[l]).fold(0u16, |m, l| m | 1 << l);
    batch.prepare(going, &wi, &uv);

    // ------------- random numbers (SoA, each lane on its own stream, in scalar order) -------------
    // Per live lane: u_sel and u if it samples an emitter, then u_lobe and u_bsdf (evaluating
    // the emitter sample draws none), then the Russian roulette number at write-back.
    let mut rng = Pcg32x::gather(&pool.rng, &slot, n);
    let u_sel = rng.next_f32(&nee);
    let mut u_light = V2x {
        x: F16(rng.next_f32(&nee)),
        y: F16(rng.next_f32(&nee)),
    };
    let u_lobe = F16(rng.next_f32(&live));
    let u_bsdf = V2x {
        x: F16(rng.next_f32(&live)),
        y: F16(rng.next_f32(&live)),
    };

    // -------------- emitter choice (scalar); other emitters' samples (SoA) --------------
    // Each emitter other than a triangle-mesh area light samples the lanes that chose it
    // together (`LightSet::sample_x`); area lights follow below.
    let mut chosen = [0u32; L];
    let mut want_other = M16::splat(false);
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
    let b = warp::square_to_uniform_triangle_x(u_light);
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
        l_rad.set(l, a.radiance_at(tri_of[l], b.get(l)));
        l_inv_area.0[l] = a.inv_area();
    }

    // ------------------------- area-light samples (SoA) -------------------------
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
    let (f, bsdf_pdf) = batch.eval_for_light(has_light, wi, wo, delta, si_at);

    // ---------------------- MIS and the shadow ray (SoA) ----------------------
    let mis = F16::select(delta, F16::splat(1.0), mis_weight_x(ls.pdf, bsdf_pdf));
    let shadow_on = has_light.and(f.is_zero().or(ls.weight.is_zero()).not());
    let contribution = throughput.mul(f).mul(ls.weight).scale(mis);
    let (sh_o, sh_d, sh_t, sh_test) = shadow_segment_from_x(p, ng, &ls);

    // ------------------------------ BSDF sample ------------------------------
    let bs = batch.sample(wi, u_lobe, u_bsdf, si_at);
    let (wo_s, s_pdf, weight, s_eta, s_delta, sampled) =
        (bs.wo, bs.pdf, bs.weight, bs.eta, bs.delta, bs.ok);

    // ------------------------ throughput, continuation (SoA) ------------------------
    let wo_world = frame.to_world(wo_s);
    let new_tp = throughput.mul(weight);
    let eta = eta * s_eta;
    let t_max = new_tp.max_element();
    let q = (t_max * eta * eta).min(F16::splat(0.95));
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

#[cfg(test)]
mod tests;
