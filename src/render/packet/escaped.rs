//! The packet integrator's kernel for escaped rays: the lights at infinity seen along them
//! (hidden from the camera with `hide_emitters`), with MIS against the emitter sampling of the
//! previous vertex, 16 lanes at a time in SoA ([`crate::light::LightSet::eval_infinite_x`]: an
//! environment map's lat-long mapping, texel lookups and pdfs per lane in registers); the
//! paths end. Each lane computes the scalar integrator's bits.

use super::lane_stats::LANES;
use super::pool::PathPool;
use crate::math::simd::f16::{F16, M16, V3x};
use crate::render::RenderScene;
use crate::render::integrator::mis_weight_x;

crate::isa_dispatch! {
    /// Adds the radiance from infinity along each escaped ray of `slots` to its path, and ends
    /// the paths: what the scalar integrator does when a ray misses the scene.
    pub fn shade_escaped(rs: &RenderScene, pool: &mut PathPool, slots: &[u32]) -> () = escaped;
}

#[inline(always)]
fn escaped(rs: &RenderScene, pool: &mut PathPool, slots: &[u32]) {
    let pt = &rs.integrator;
    let lights = &rs.lights;
    let zero = F16::splat(0.0);
    for batch in slots.chunks(LANES) {
        // Lanes past the batch keep zeros: computed, never written back.
        let mut show = M16::splat(false);
        let (mut d, mut tp, mut result) = (V3x::ZERO, V3x::ZERO, V3x::ZERO);
        let (mut prev_pdf, mut prev_delta) = (zero, M16::splat(false));
        for (l, &i) in batch.iter().enumerate() {
            let i = i as usize;
            show.0[l] = !(pool.depth[i] == 0 && pt.hide_emitters);
            d.set(l, pool.ray_d.get(i));
            tp.set(l, pool.throughput.get(i));
            result.set(l, pool.result.get(i));
            prev_pdf.0[l] = pool.prev_pdf[i];
            prev_delta.0[l] = pool.prev_delta[i];
        }
        if show.0.contains(&true) {
            let no_mis = prev_delta.or(M16::splat(!pt.nee));
            for k in 0..lights.infinite_count() {
                let (le, pdf_e) = lights.eval_infinite_x(k, d);
                let em_pdf = F16::select(no_mis, zero, pdf_e);
                let seen = result.add(tp.mul(le).scale(mis_weight_x(prev_pdf, em_pdf)));
                result = V3x::select(show, seen, result);
            }
        }
        for (l, &i) in batch.iter().enumerate() {
            let i = i as usize;
            pool.result.set(i, result.get(l));
            pool.ending[i] = true;
        }
    }
}
