//! N queries on flat arrays, split into [`BATCH`]-sized groups and spread over rayon: a fitted
//! model's groups run the packet integrator's batched path ([`PlmcBsdf::prepare16`] for the view
//! lookups and texels, [`PlmcBsdf::eval_b_pdf_batch`] / [`PlmcBsdf::sample_batch`] for the
//! 16-lane model kernel); raw data runs the raw BTF's scalar BSDF query by query, as both
//! integrators do. No Python here: the bindings (`btf.rs`) validate the arrays, release the GIL
//! and call these.

use btfpt::bsdf::plmc::{BATCH, PREPARE_LANES};
use btfpt::bsdf::{BtfBsdf, Bxdf, PlmcBsdf};
use btfpt::geometry::SurfaceInteraction;
use btfpt::math::{Vec2, Vec3};
use rayon::prelude::*;
use std::mem::MaybeUninit;

// One prepare16 call serves one batch.
const _: () = assert!(BATCH <= PREPARE_LANES);

/// Queries per rayon task (a multiple of [`BATCH`]): large enough that scheduling is noise.
const TASK: usize = 64 * BATCH;

/// A measured material as the renderer evaluates it.
pub enum Model {
    /// Raw measured data (nearest texel, 3 × 3 measured values blended).
    Raw(BtfBsdf),
    /// A fitted LM / PLM / PLM-C model.
    Fitted(PlmcBsdf),
}

/// One query's inputs: uv, ω_i (view, toward the camera), ω_l (light) in the local frame.
fn v3(a: &[f32; 3]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

/// B = π · f · cos θ_l and, when `pdf` is given, the sampling pdf of ω_l, for every query.
pub fn eval_b_pdf(
    model: &Model,
    uv: &[[f32; 2]],
    wi: &[[f32; 3]],
    wo: &[[f32; 3]],
    b: &mut [[f32; 3]],
    pdf: Option<&mut [f32]>,
) {
    let n = uv.len();
    assert!(wi.len() == n && wo.len() == n && b.len() == n);
    let task = |t: usize, b: &mut [[f32; 3]], mut pdf: Option<&mut [f32]>| {
        let s = t * TASK;
        for (g, b) in b.chunks_mut(BATCH).enumerate() {
            let o = s + g * BATCH;
            let r = o..o + b.len();
            let pdf = pdf
                .as_deref_mut()
                .map(|p| &mut p[g * BATCH..g * BATCH + b.len()]);
            match model {
                Model::Fitted(m) => fitted_group(m, &uv[r.clone()], &wi[r.clone()], &wo[r], b, pdf),
                Model::Raw(m) => raw_group(m, &uv[r.clone()], &wi[r.clone()], &wo[r], b, pdf),
            }
        }
    };
    match pdf {
        Some(pdf) => {
            assert_eq!(pdf.len(), n);
            b.par_chunks_mut(TASK)
                .zip(pdf.par_chunks_mut(TASK))
                .enumerate()
                .for_each(|(t, (b, pdf))| task(t, b, Some(pdf)));
        }
        None => b
            .par_chunks_mut(TASK)
            .enumerate()
            .for_each(|(t, b)| task(t, b, None)),
    }
}

/// Raw data, query by query through the raw BTF's scalar BSDF (as both integrators).
fn raw_group(
    m: &BtfBsdf,
    uv: &[[f32; 2]],
    wi: &[[f32; 3]],
    wo: &[[f32; 3]],
    b: &mut [[f32; 3]],
    mut pdf: Option<&mut [f32]>,
) {
    for q in 0..b.len() {
        let si = SurfaceInteraction::for_tests(v3(&wi[q]), Vec2::from(uv[q]));
        let w = v3(&wo[q]);
        b[q] = if si.wi.z <= 0.0 || w.z <= 0.0 {
            [0.0; 3]
        } else {
            let (x, y) = m.texel(si.uv);
            m.material().eval_b(si.wi, w, x, y).to_array()
        };
        if let Some(p) = pdf.as_deref_mut() {
            p[q] = m.pdf(&si, w);
        }
    }
}

/// The per-hit states of up to [`BATCH`] queries by one [`PlmcBsdf::prepare16`]: the hits of
/// the queries above the horizon packed to the front (the first one repeated past them), with
/// their query indices and their count; None if no query is above the horizon.
fn prepare_group(
    m: &PlmcBsdf,
    uv: &[[f32; 2]],
    wi: &[[f32; 3]],
) -> Option<([btfpt::bsdf::PlmcHit; BATCH], [usize; BATCH], usize)> {
    let n = uv.len();
    let mut lane = [[0f32; PREPARE_LANES]; 5];
    for q in 0..n {
        [lane[0][q], lane[1][q], lane[2][q]] = wi[q];
        [lane[3][q], lane[4][q]] = uv[q];
    }
    let mask = if n == 16 { u16::MAX } else { (1u16 << n) - 1 };
    let mut hits = [const { MaybeUninit::uninit() }; PREPARE_LANES];
    let mut query = [0u8; PREPARE_LANES];
    let k = m.prepare16(
        [&lane[0], &lane[1], &lane[2]],
        [&lane[3], &lane[4]],
        mask,
        &mut hits,
        &mut query,
    );
    if k == 0 {
        return None;
    }
    // SAFETY: prepare16 wrote entries 0..k (k ≥ 1).
    let mut packed = [unsafe { hits[0].assume_init() }; BATCH];
    let mut slot = [0usize; BATCH];
    for j in 0..k {
        // SAFETY: as above.
        packed[j] = unsafe { hits[j].assume_init() };
        slot[j] = query[j] as usize;
    }
    Some((packed, slot, k))
}

fn fitted_group(
    m: &PlmcBsdf,
    uv: &[[f32; 2]],
    wi: &[[f32; 3]],
    wo: &[[f32; 3]],
    b: &mut [[f32; 3]],
    mut pdf: Option<&mut [f32]>,
) {
    b.fill([0.0; 3]);
    if let Some(p) = pdf.as_deref_mut() {
        p.fill(0.0);
    }
    // The hits above the horizon, packed (the filler past k is never read).
    let Some((packed, slot, k)) = prepare_group(m, uv, wi) else {
        return;
    };
    let mut w = [Vec3::Z; BATCH];
    for j in 0..k {
        w[j] = v3(&wo[slot[j]]);
    }
    let want = [pdf.is_some(); BATCH];
    let mut out = [([0f32; 3], 0f32); BATCH];
    m.eval_b_pdf_batch(&packed[..k], &w[..k], &want[..k], &mut out[..k]);
    for j in 0..k {
        b[slot[j]] = out[j].0;
        if let Some(p) = pdf.as_deref_mut() {
            p[slot[j]] = out[j].1;
        }
    }
}

/// One sampled light direction per query: ω_l, the weight f · cos θ_l / pdf (per channel) and
/// the pdf; pdf 0 (and ω_l, weight 0) where the sample fails (below the horizon).
pub fn sample(
    model: &Model,
    uv: &[[f32; 2]],
    wi: &[[f32; 3]],
    u1: &[f32],
    u2: &[[f32; 2]],
    wo: &mut [[f32; 3]],
    weight: &mut [[f32; 3]],
    pdf: &mut [f32],
) {
    let n = uv.len();
    assert!(wi.len() == n && u1.len() == n && u2.len() == n);
    assert!(wo.len() == n && weight.len() == n && pdf.len() == n);
    wo.par_chunks_mut(TASK)
        .zip(weight.par_chunks_mut(TASK))
        .zip(pdf.par_chunks_mut(TASK))
        .enumerate()
        .for_each(|(t, ((wo, weight), pdf))| {
            let s = t * TASK;
            for (g, ((wo, weight), pdf)) in wo
                .chunks_mut(BATCH)
                .zip(weight.chunks_mut(BATCH))
                .zip(pdf.chunks_mut(BATCH))
                .enumerate()
            {
                let o = s + g * BATCH;
                let r = o..o + wo.len();
                wo.fill([0.0; 3]);
                weight.fill([0.0; 3]);
                pdf.fill(0.0);
                let mut put =
                    |q: usize, r: Option<(btfpt::bsdf::BsdfSample, btfpt::math::Spectrum)>| {
                        if let Some((s, f)) = r {
                            (wo[q], weight[q], pdf[q]) = (s.wo.to_array(), f.to_array(), s.pdf);
                        }
                    };
                match model {
                    Model::Fitted(m) => {
                        let Some((packed, slot, k)) =
                            prepare_group(m, &uv[r.clone()], &wi[r.clone()])
                        else {
                            continue;
                        };
                        let (mut s1, mut s2) = ([0f32; BATCH], [Vec2::ZERO; BATCH]);
                        for j in 0..k {
                            s1[j] = u1[o + slot[j]];
                            s2[j] = Vec2::from(u2[o + slot[j]]);
                        }
                        let mut out = [None; BATCH];
                        m.sample_batch(&packed[..k], &s1[..k], &s2[..k], &mut out[..k]);
                        for j in 0..k {
                            put(slot[j], out[j]);
                        }
                    }
                    Model::Raw(m) => {
                        for q in 0..r.len() {
                            let si = SurfaceInteraction::for_tests(
                                v3(&wi[o + q]),
                                Vec2::from(uv[o + q]),
                            );
                            put(q, m.sample(&si, u1[o + q], Vec2::from(u2[o + q])));
                        }
                    }
                }
            }
        });
}

/// The scalar path of every query, one by one (the scalar integrator's calls): B, f · cos θ_l,
/// the pdf, and a sample from `(u1, u2)` as (ω_l, weight, pdf). The test oracle of the batched
/// path above.
#[allow(clippy::type_complexity)]
pub fn reference(
    model: &Model,
    uv: [f32; 2],
    wi: [f32; 3],
    wo: [f32; 3],
    u1: f32,
    u2: [f32; 2],
) -> ([f32; 3], [f32; 3], f32, ([f32; 3], [f32; 3], f32)) {
    let si = SurfaceInteraction::for_tests(v3(&wi), Vec2::from(uv));
    let w = v3(&wo);
    let above = si.wi.z > 0.0 && w.z > 0.0;
    let (b, f, pdf, s) = match model {
        Model::Fitted(m) => {
            let b = if above {
                let (x, y) = m.texel(si.uv);
                m.material().eval_b(si.wi, w, x, y)
            } else {
                [0.0; 3]
            };
            let (f, pdf) = m.eval_pdf(&si, w);
            (b, f, pdf, m.sample(&si, u1, Vec2::from(u2)))
        }
        Model::Raw(m) => {
            let b = if above {
                let (x, y) = m.texel(si.uv);
                m.material().eval_b(si.wi, w, x, y).to_array()
            } else {
                [0.0; 3]
            };
            let (f, pdf) = m.eval_pdf(&si, w);
            (b, f, pdf, m.sample(&si, u1, Vec2::from(u2)))
        }
    };
    let s = s.map_or(([0.0; 3], [0.0; 3], 0.0), |(s, wt)| {
        (s.wo.to_array(), wt.to_array(), s.pdf)
    });
    (b, f.to_array(), pdf, s)
}
