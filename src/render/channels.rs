//! What one camera sample adds to the extra image channels (Mitsuba's `aov` and `moment`):
//! values of the surface its camera ray hits first and functions of its radiance. Both
//! integrators call [`sample_values`] with the sample's pixel, index and radiance; it redraws
//! the camera ray as the scalar integrator does, so the values are the same bits whoever
//! traced the path.

use super::RenderScene;
use super::film::RenderSettings;
use super::integrator::film_sample_start;
use crate::geometry::SurfaceInteraction;
use crate::geometry::shading::surface_interaction;
use crate::io::RgbImage;
use crate::math::cie1931::srgb_to_xyz;
use crate::math::{Spectrum, Vec2, Vec3};
use crate::scene::channels::{ChannelValue, ImageChannels, SampleValue};

/// Writes the scene's per-sample channel values (`rs.scene.channels.per_sample`) of sample
/// `sample` of film pixel (`px`, `py`), whose path brought radiance `l`, into `out`. A ray that
/// escapes gives 0 for every surface value, as Mitsuba's `aov`.
pub fn sample_values(
    rs: &RenderScene,
    s: &RenderSettings,
    px: u32,
    py: u32,
    sample: u64,
    l: Spectrum,
    out: &mut [f32],
) {
    let values = &rs.scene.channels.per_sample;
    let (mut rng, fx, fy) = film_sample_start(s.seed, s.width, px, py, sample);
    let u = rs.camera.aperture_sample(&mut rng);
    let (o, d, tmax) = rs.camera.sample_ray(fx, fy, u);
    let needs_hit = values
        .iter()
        .any(|v| v.needs_hit() || *v == SampleValue::Alpha);
    let hit = if needs_hit {
        rs.accel.intersect(o, d, tmax)
    } else {
        None
    };
    let si = hit
        .as_ref()
        .map(|h| surface_interaction(&rs.scene.meshes, o, d, h));
    let xyz = srgb_to_xyz([l[0], l[1], l[2]]);
    let albedo = match &si {
        Some(si) if values.iter().any(|v| matches!(v, SampleValue::Albedo(_))) => {
            let mesh = &rs.scene.meshes[si.mesh as usize];
            rs.scene
                .bsdfs
                .get(mesh.bsdf as usize)
                .map_or(Spectrum::ZERO, |b| b.diffuse_reflectance(si))
        }
        _ => Spectrum::ZERO,
    };
    let duv = match &si {
        Some(si)
            if values
                .iter()
                .any(|v| matches!(v, SampleValue::DuvDx(_) | SampleValue::DuvDy(_))) =>
        {
            let scale = 1.0 / (rs.scene.spp.max(1) as f32).sqrt();
            let [x, y] = rs.camera.differentials(fx, fy, u).map(|(ox, dx)| {
                // Mitsuba's scale_differential: the offset rays moved towards the main one.
                ((ox - o) * scale + o, (dx - d) * scale + d)
            });
            uv_partials(si, x, y)
        }
        _ => [Vec2::ZERO; 2],
    };
    for (slot, v) in out.iter_mut().zip(values) {
        let a = |v: crate::math::Vec3, axis: usize| v[axis];
        *slot = match (*v, &si) {
            (SampleValue::Xyz(i), _) => xyz[i],
            (SampleValue::XyzSquared(i), _) => xyz[i] * xyz[i],
            (SampleValue::Alpha, _) => {
                let env = rs.integrator.direct.is_none()
                    && !rs.integrator.hide_emitters
                    && rs.lights.infinite_count() > 0;
                if hit.is_some() || env { 1.0 } else { 0.0 }
            }
            (_, None) => 0.0,
            (SampleValue::Albedo(i), Some(_)) => albedo[i],
            (SampleValue::DuvDx(i), Some(_)) => duv[0][i],
            (SampleValue::DuvDy(i), Some(_)) => duv[1][i],
            (SampleValue::Depth, Some(si)) => si.t,
            (SampleValue::Position(i), Some(si)) => a(si.p, i),
            (SampleValue::Uv(i), Some(si)) => si.uv[i],
            (SampleValue::GeoNormal(i), Some(si)) => a(si.n, i),
            (SampleValue::ShNormal(i), Some(si)) => a(si.sh_frame.n, i),
            (SampleValue::DpDu(i), Some(si)) => a(si.dpdu, i),
            (SampleValue::DpDv(i), Some(si)) => a(si.dpdv, i),
            (SampleValue::PrimIndex, Some(si)) => si.prim as f32,
            (SampleValue::ShapeIndex, Some(si)) => (si.mesh + 1) as f32,
        };
    }
}

/// ∂uv/∂x and ∂uv/∂y at `si` from the offset rays `x` and `y` (origin, direction), as Mitsuba's
/// `SurfaceInteraction::compute_uv_partials`: each offset ray meets the hit's tangent plane, and
/// the two position offsets are solved for uv in the least-squares sense through ∂p/∂u, ∂p/∂v
/// (0 where those are degenerate).
fn uv_partials(si: &SurfaceInteraction, x: (Vec3, Vec3), y: (Vec3, Vec3)) -> [Vec2; 2] {
    let plane = si.n.dot(si.p);
    let (du, dv) = (si.dpdu, si.dpdv);
    let a00 = du.dot(du);
    let a01 = du.dot(dv);
    let a11 = dv.dot(dv);
    let inv_det = 1.0 / (a00 * a11 - a01 * a01);
    let inv_det = if inv_det.is_finite() { inv_det } else { 0.0 };
    [x, y].map(|(o, d)| {
        let t = (plane - si.n.dot(o)) / si.n.dot(d);
        let dp = d * t + o - si.p;
        let (b0, b1) = (du.dot(dp), dv.dot(dp));
        Vec2::new(a11 * b0 - a01 * b1, a00 * b1 - a01 * b0) * inv_det
    })
}

/// The extra output channels of a finished render, named as Mitsuba names them: the image's
/// own R, G, B where a nested integrator's colour is asked for, else the filtered means
/// `means` ([`super::RenderState::extra_means`]).
pub fn output_channels(
    channels: &ImageChannels,
    img: &RgbImage,
    means: &[f32],
) -> super::partial::ExtraChannels {
    let npix = img.width * img.height;
    let n = channels.per_sample.len();
    channels
        .outputs
        .iter()
        .map(|(name, v)| {
            let values = match *v {
                ChannelValue::Image(c) => (0..npix).map(|i| img.data[i * 3 + c]).collect(),
                ChannelValue::Sample(k) => (0..npix).map(|i| means[i * n + k]).collect(),
            };
            (name.clone(), values)
        })
        .collect()
}
