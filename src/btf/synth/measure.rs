//! The virtual gonioreflectometer: per view an orthographic camera rectified to the reference
//! plane, per light a directional source of unit irradiance; self-shadowing, masking and one
//! BRDF-sampled bounce of inter-reflection. Output B = π · L_o (docs/conventions.md).
//!
//! Work per view: camera rays and bounce rays depend only on the view, so they are traced once per
//! sub-texel sample and cached; then, light by light, only the two shadow rays and two BRDF
//! evaluations per sample remain. Views run in parallel (rayon); each view's random streams are a
//! pure function of (seed, view, texel, sample), so output does not depend on the thread count.

use super::MicroSurface;
use super::brdf::BrdfParams;
use crate::btf::{DirectionSet, RawBtf, StoredEncoding};
use crate::math::{Frame, PI, Pcg32, Spectrum, Vec3};
use crate::{Error, Result};
use half::f16;
use rayon::prelude::*;

/// How to measure.
#[derive(Clone, Debug)]
pub struct SynthSettings {
    /// View (camera) directions, local to the reference plane (x = column, y = row, z = up).
    pub views: DirectionSet,
    /// Light directions.
    pub lights: DirectionSet,
    /// Stratified sub-texel samples per axis (samples per texel = strata²).
    pub strata: usize,
    /// Seed of every random stream.
    pub seed: u64,
    /// Trace one BRDF-sampled bounce of inter-reflection (off: direct light only).
    pub interreflection: bool,
    /// Upper bound on one sample's inter-reflected B per channel (∞ = unbiased). Rare glossy
    /// grazing bounce paths otherwise leave isolated bright texels at a few samples per texel;
    /// one Lambertian bounce never exceeds 1 (albedo ≤ 1), so the default 1 only trims those.
    pub indirect_clamp: f32,
    /// Show an indicatif progress bar on stderr.
    pub progress: bool,
}

impl SynthSettings {
    /// The UBO2003 set for views and lights, 2×2 samples per texel, one bounce, no progress bar.
    pub fn ubo2003(seed: u64) -> Self {
        SynthSettings {
            views: DirectionSet::ubo2003(),
            lights: DirectionSet::ubo2003(),
            strata: 2,
            seed,
            interreflection: true,
            indirect_clamp: 1.0,
            progress: false,
        }
    }
}

/// A shading point cached for all lights of a view.
#[derive(Clone, Copy)]
struct Vertex {
    /// Shadow-ray origin (surface point nudged along the facet normal).
    origin: Vec3,
    /// Facet normal (light below it is blocked by the facet itself).
    ng: Vec3,
    /// Shading frame (tangent from the cell's fibre/brush direction).
    frame: Frame,
    /// Outgoing direction (toward the camera or the previous vertex), local.
    wo: Vec3,
    cell: u32,
    /// Path weight multiplying this vertex's direct light.
    weight: Spectrum,
    /// Clamp of this vertex's contribution to B (per channel; ∞ for camera vertices).
    clamp: f32,
}

/// Measures `surface` into a linear RawBtf `[view][light][row][column][rgb]` using the current
/// rayon pool (wrap the call in `ThreadPool::install` to choose the thread count).
pub fn measure(surface: &MicroSurface, s: &SynthSettings) -> Result<RawBtf> {
    if s.views.is_empty() || s.lights.is_empty() {
        return Err(Error::Invalid(
            "synth: empty view or light direction set".into(),
        ));
    }
    for (name, set) in [("view", &s.views), ("light", &s.lights)] {
        if let Some(k) = set
            .dirs
            .iter()
            .position(|d| d.z.is_nan() || d.z <= 1e-3 || !d.is_finite())
        {
            return Err(Error::Invalid(format!(
                "synth: {name} direction {k} {:?} is not above the reference plane",
                set.angles_deg.get(k)
            )));
        }
    }
    if s.indirect_clamp.is_nan() || s.indirect_clamp <= 0.0 {
        return Err(Error::Invalid(format!(
            "synth: indirect clamp must be positive (got {})",
            s.indirect_clamp
        )));
    }
    if s.strata == 0 || s.strata > 64 {
        return Err(Error::Invalid(format!(
            "synth: strata per axis must be in 1..=64 (got {})",
            s.strata
        )));
    }
    let (w, h) = (surface.width(), surface.height());
    let per_view = s.lights.len() * w * h * 3;
    let total = per_view
        .checked_mul(s.views.len())
        .filter(|&n| n < (1usize << 36))
        .ok_or_else(|| Error::Invalid("synth: output too large".into()))?;
    let mut data = vec![f16::ZERO; total];
    let bar = if s.progress {
        let b = indicatif::ProgressBar::new(s.views.len() as u64);
        if let Ok(style) = indicatif::ProgressStyle::with_template(
            "synth {bar:40} {pos}/{len} views  {elapsed_precise} (eta {eta})",
        ) {
            b.set_style(style);
        }
        b
    } else {
        indicatif::ProgressBar::hidden()
    };
    data.par_chunks_mut(per_view)
        .enumerate()
        .for_each(|(view, out)| {
            measure_view(surface, s, view, out);
            bar.inc(1);
        });
    bar.finish_and_clear();
    RawBtf::from_f16(
        s.views.clone(),
        s.lights.clone(),
        w,
        h,
        StoredEncoding::Linear,
        data,
    )
}

/// Offset of ray origins along the facet normal, in texel units.
const RAY_EPS: f32 = 2e-4;

fn make_vertex(
    surface: &MicroSurface,
    hit: &super::heightfield::HfHit,
    toward: Vec3,
    weight: Spectrum,
    clamp: f32,
) -> Option<Vertex> {
    let p: &BrdfParams = surface.params(hit.cell);
    let (sa, ca) = p.tangent_angle.sin_cos();
    let frame = Frame::from_normal_tangent(hit.ns, Vec3::new(ca, sa, 0.0));
    let wo = frame.to_local(toward);
    if wo.z <= 0.0 || toward.dot(hit.ng) <= 0.0 {
        return None;
    }
    Some(Vertex {
        origin: hit.p + hit.ng * RAY_EPS,
        ng: hit.ng,
        frame,
        wo,
        cell: hit.cell as u32,
        weight,
        clamp,
    })
}

fn measure_view(surface: &MicroSurface, s: &SynthSettings, view: usize, out: &mut [f16]) {
    let hf = surface.heightfield();
    let (w, h) = (surface.width(), surface.height());
    let spp = s.strata * s.strata;
    let wv = s.views.dirs[view];
    // Start camera rays just above the highest point: the plane point (x, y, 0) shifted along ω_v.
    let lift = (hf.zmax().max(0.0) + 1e-3) / wv.z;
    // Per texel: primary vertices then bounce vertices (None = black).
    let mut verts: Vec<Vertex> = Vec::with_capacity(w * h * spp * 2);
    let mut offsets: Vec<u32> = Vec::with_capacity(w * h + 1);
    for y in 0..h {
        for x in 0..w {
            offsets.push(verts.len() as u32);
            let pixel = ((view * h + y) * w + x) as u64;
            for k in 0..spp {
                let mut rng = Pcg32::for_sample(s.seed, pixel, k as u64);
                let (a, b) = (k % s.strata, k / s.strata);
                let u = rng.next_2d();
                let px = x as f32 + (a as f32 + u.x) / s.strata as f32;
                let py = y as f32 + (b as f32 + u.y) / s.strata as f32;
                let o = Vec3::new(px, py, 0.0) + wv * lift;
                let Some(hit) = hf.intersect(o, -wv) else {
                    continue;
                };
                let Some(v1) = make_vertex(surface, &hit, wv, Spectrum::ONE, f32::INFINITY) else {
                    continue;
                };
                verts.push(v1);
                if !s.interreflection {
                    continue;
                }
                let p1 = surface.params(v1.cell as usize);
                let Some((wi, weight)) = p1.sample(v1.wo, rng.next_f32(), rng.next_2d()) else {
                    continue;
                };
                let wb = v1.frame.to_world(wi);
                if wb.dot(v1.ng) <= 0.0 {
                    continue;
                }
                if let Some(hit2) = hf.intersect(v1.origin, wb)
                    && let Some(v2) =
                        make_vertex(surface, &hit2, -wb, weight, s.indirect_clamp / PI)
                {
                    verts.push(v2);
                }
            }
        }
    }
    offsets.push(verts.len() as u32);
    let norm = PI / spp as f32;
    for (l, &wl) in s.lights.dirs.iter().enumerate() {
        let img = &mut out[l * w * h * 3..(l + 1) * w * h * 3];
        for t in 0..w * h {
            let mut acc = Spectrum::ZERO;
            for v in &verts[offsets[t] as usize..offsets[t + 1] as usize] {
                if wl.dot(v.ng) <= 0.0 {
                    continue;
                }
                let wi = v.frame.to_local(wl);
                if wi.z <= 0.0 {
                    continue;
                }
                let f = surface.params(v.cell as usize).eval(wi, v.wo) * (wi.z * v.weight);
                if f.max_element() <= 0.0 || hf.occluded(v.origin, wl) {
                    continue;
                }
                acc += f.min(Vec3::splat(v.clamp));
            }
            let b = acc * norm;
            img[3 * t] = f16::from_f32(b.x);
            img[3 * t + 1] = f16::from_f32(b.y);
            img[3 * t + 2] = f16::from_f32(b.z);
        }
    }
}
