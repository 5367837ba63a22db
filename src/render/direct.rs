//! Mitsuba 3's `direct` integrator (`src/integrators/direct.cpp`): at the first surface a
//! camera ray hits, `emitter_samples` emitter samples (smooth BSDFs only) and `bsdf_samples`
//! BSDF samples, combined with the power heuristic on the sample-count-weighted pdfs; emitters
//! the camera sees are added unless `hide_emitters`. Mitsuba's quirk is kept: a delta emitter's
//! sample has weight 1, not 1 / emitter_samples, so its light counts emitter_samples times.

use super::RenderScene;
use super::integrator::{TraceStats, camera_hit, mis_weight, occluded};
use crate::bsdf::BsdfFlags;
use crate::geometry::accel::offset_origin;
use crate::geometry::shading::surface_interaction;
use crate::math::{Pcg32, Spectrum, Vec3};
use crate::scene::DirectSettings;

/// Radiance arriving at `o` from direction `d` (unit) within `tmax`, as Mitsuba's `direct`.
#[allow(clippy::too_many_arguments)]
pub fn li(
    ds: &DirectSettings,
    hide_emitters: bool,
    rs: &RenderScene,
    o: Vec3,
    d: Vec3,
    tmax: f32,
    rng: &mut Pcg32,
    stats: &mut TraceStats,
) -> Spectrum {
    let meshes = &rs.scene.meshes;
    let lights = &rs.lights;
    let mut result = Spectrum::ZERO;
    let (hit, ray_o) = camera_hit(rs, o, d, tmax, hide_emitters, stats);
    // ----------------------- visible emitters -----------------------
    let Some(h) = hit else {
        if !hide_emitters {
            for k in 0..lights.infinite_count() {
                result += lights.eval_infinite(k, d).0;
            }
        }
        return result;
    };
    let si = surface_interaction(meshes, ray_o, d, &h);
    if !hide_emitters && lights.is_emissive(h.mesh) {
        result += lights.area_radiance(&si);
    }
    let Some(bsdf) = rs.scene.bsdfs.get(meshes[h.mesh as usize].bsdf as usize) else {
        return result;
    };
    let bsdf = bsdf.at(&si);
    let (ne, nb) = (ds.emitter_samples, ds.bsdf_samples);
    let sum = (ne + nb) as f32;
    let (frac_lum, frac_bsdf) = (ne as f32 / sum, nb as f32 / sum);
    // ----------------------- emitter sampling -----------------------
    if ne > 0 && bsdf.flags().has(BsdfFlags::SMOOTH) {
        let weight_lum = 1.0 / ne as f32;
        for _ in 0..ne {
            let u_sel = rng.next_f32();
            let u = rng.next_2d();
            let Some(ls) = lights.sample(si.p, u_sel, u) else {
                continue;
            };
            let wo = si.to_local(ls.wi);
            let (f, bsdf_pdf) = bsdf.eval_for_light(&si, wo, ls.delta);
            if f == Spectrum::ZERO || ls.weight == Spectrum::ZERO || occluded(rs, &si, &ls, stats) {
                continue;
            }
            let mis = if ls.delta {
                1.0
            } else {
                mis_weight(ls.pdf * frac_lum, bsdf_pdf * frac_bsdf) * weight_lum
            };
            result += f * ls.weight * mis;
        }
    }
    // ------------------------ BSDF sampling -------------------------
    if nb > 0 {
        let weight_bsdf = 1.0 / nb as f32;
        for _ in 0..nb {
            let u1 = rng.next_f32();
            let u2 = rng.next_2d();
            let Some((bs, weight)) = bsdf.sample(&si, u1, u2) else {
                continue;
            };
            if weight == Spectrum::ZERO {
                continue;
            }
            let wo = si.to_world(bs.wo);
            let delta = bs.sampled.has(BsdfFlags::DELTA);
            let ro = offset_origin(si.p, si.n, wo);
            stats.rays += 1;
            match rs.accel.intersect(ro, wo, f32::INFINITY) {
                None => {
                    for k in 0..lights.infinite_count() {
                        let (le, pdf_e) = lights.eval_infinite(k, wo);
                        let em_pdf = if delta { 0.0 } else { pdf_e };
                        result += weight
                            * le
                            * mis_weight(bs.pdf * frac_bsdf, em_pdf * frac_lum)
                            * weight_bsdf;
                    }
                }
                Some(h2) if lights.is_emissive(h2.mesh) => {
                    let si2 = surface_interaction(meshes, ro, wo, &h2);
                    let le = lights.area_radiance(&si2);
                    if le != Spectrum::ZERO {
                        let em_pdf = if delta {
                            0.0
                        } else {
                            lights.pdf_area_hit(si.p, &si2)
                        };
                        result += weight
                            * le
                            * mis_weight(bs.pdf * frac_bsdf, em_pdf * frac_lum)
                            * weight_bsdf;
                    }
                }
                Some(_) => {}
            }
        }
    }
    result
}
