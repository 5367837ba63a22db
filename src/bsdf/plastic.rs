//! Smooth plastic (Mitsuba `plastic`): a diffuse base under a smooth dielectric coating. Delta
//! specular reflection with Fresnel weight F(θ_i), plus the base seen through the interface,
//! (1 − F_i)(1 − F_o)/η² · ρ / (1 − F_dr) / π, where F_dr is the coating's internal diffuse
//! reflectance (`nonlinear` divides by 1 − ρ·F_dr instead). One-sided, as Mitsuba.

use super::fresnel::{
    fresnel_dielectric, fresnel_dielectric_t, fresnel_diffuse_reflectance, reflect,
};
use super::ior::ior;
use super::plugin::BsdfProperties;
use super::{BsdfFlags, BsdfSample, Bxdf, Texture};
use crate::Result;
use crate::geometry::SurfaceInteraction;
use crate::math::simd::f16::{F16, M16, V2x, V3x};
use crate::math::simd::real::{Real, V2, V3};
use crate::math::{Spectrum, Vec2, Vec3, warp};

/// A coated base's albedo `d` divided by what the coating's internal reflections (diffuse
/// reflectance `internal`) keep in: d / (1 − internal), or d / (1 − d · internal) when
/// `nonlinear` (Mitsuba's plastic and roughplastic), for one lane or sixteen.
#[inline(always)]
pub fn base_under_coating<T: Real>(d: V3<T>, internal: f32, nonlinear: bool) -> V3<T> {
    let one = T::splat(1.0);
    if nonlinear {
        let k = |d: T| d / (one - d * internal);
        V3::new(k(d.x), k(d.y), k(d.z))
    } else {
        let k = 1.0 - internal;
        V3::new(d.x / k, d.y / k, d.z / k)
    }
}

/// Smooth plastic, eta = int_ior / ext_ior (Mitsuba defaults 1.49 / 1.000277).
#[derive(Clone, Debug)]
pub struct Plastic {
    /// Albedo of the diffuse base (Mitsuba default 0.5).
    pub diffuse_reflectance: Texture,
    /// Multiplier on the specular reflection (Mitsuba default 1).
    pub specular_reflectance: Texture,
    /// Account for colour shifts from internal scattering (Mitsuba `nonlinear`, default false).
    pub nonlinear: bool,
    eta: f32,
    inv_eta_2: f32,
    fdr_int: f32,
    /// Share of samples steered to the specular lobe before the Fresnel term.
    specular_sampling_weight: f32,
}

impl Plastic {
    /// Mitsuba's `plastic`: `int_ior`, `ext_ior`, `diffuse_reflectance`,
    /// `specular_reflectance`, `nonlinear`.
    pub fn from_props(p: &mut dyn BsdfProperties) -> Result<Self> {
        let c = Coating::from_props(p, false)?;
        Ok(Plastic::new(
            c.eta,
            c.diffuse_reflectance,
            c.specular_reflectance,
            c.nonlinear,
        ))
    }
}

/// What `plastic` and `roughplastic` both read: a diffuse base under a dielectric coating.
pub(super) struct Coating {
    /// int_ior / ext_ior.
    pub eta: f32,
    pub diffuse_reflectance: Texture,
    pub specular_reflectance: Texture,
    pub nonlinear: bool,
}

impl Coating {
    /// The coating's parameters; a `rough` one also needs the two indices to differ.
    pub fn from_props(p: &mut dyn BsdfProperties, rough: bool) -> Result<Self> {
        let int_ior = ior(p, "int_ior", "polypropylene")?;
        let ext_ior = ior(p, "ext_ior", "air")?;
        if !(int_ior > 0.0 && ext_ior > 0.0) || (rough && int_ior == ext_ior) {
            return Err(p.err(
                "the interior and exterior indices of refraction must be positive and differ",
            ));
        }
        Ok(Coating {
            diffuse_reflectance: p.texture("diffuse_reflectance", Vec3::splat(0.5))?,
            specular_reflectance: p.texture("specular_reflectance", Vec3::ONE)?,
            nonlinear: p.bool("nonlinear", false)?,
            eta: int_ior / ext_ior,
        })
    }
}

impl Plastic {
    /// A plastic with relative IOR `eta` = int_ior / ext_ior (must be positive and finite).
    pub fn new(
        eta: f32,
        diffuse_reflectance: Texture,
        specular_reflectance: Texture,
        nonlinear: bool,
    ) -> Plastic {
        let d_mean = diffuse_reflectance.mean();
        let s_mean = specular_reflectance.mean();
        Plastic {
            eta,
            inv_eta_2: 1.0 / (eta * eta),
            fdr_int: fresnel_diffuse_reflectance(1.0 / eta),
            specular_sampling_weight: s_mean / (d_mean + s_mean),
            diffuse_reflectance,
            specular_reflectance,
            nonlinear,
        }
    }

    /// Relative IOR of the coating.
    pub fn eta(&self) -> f32 {
        self.eta
    }

    /// The base's albedo divided by what the coating's internal reflections keep in.
    #[inline]
    pub fn base(&self, uv: Vec2) -> Spectrum {
        self.base_t(uv.into()).into()
    }

    /// [`Self::base`] for one lane or sixteen.
    #[inline(always)]
    pub fn base_t<T: Real>(&self, uv: V2<T>) -> V3<T> {
        let d = self.diffuse_reflectance.eval_t(uv);
        base_under_coating(d, self.fdr_int, self.nonlinear)
    }

    /// Probability of sampling the diffuse lobe given F(θ_i).
    #[inline]
    fn prob_diffuse(&self, f_i: f32) -> f32 {
        let ps = f_i * self.specular_sampling_weight;
        let pd = (1.0 - f_i) * (1.0 - self.specular_sampling_weight);
        pd / (ps + pd)
    }

    /// [`Self::prob_diffuse`] per lane.
    #[inline(always)]
    fn prob_diffuse_x(&self, f_i: F16) -> F16 {
        let ps = f_i * self.specular_sampling_weight;
        let pd = (1.0 - f_i) * (1.0 - self.specular_sampling_weight);
        pd / (ps + pd)
    }

    /// [`Self::eval`] and [`Self::pdf`] per lane, with each lane's [`Self::base`] in `base`.
    #[inline(always)]
    pub fn eval_pdf_x(&self, base: V3x, wi: V3x, wo: V3x) -> (V3x, F16) {
        let zero = F16::splat(0.0);
        let below = wi.z.le(zero).or(wo.z.le(zero));
        let f_i = fresnel_dielectric_t(wi.z, self.eta).r;
        let f_o = fresnel_dielectric_t(wo.z, self.eta).r;
        let cos_pdf = warp::square_to_cosine_hemisphere_pdf_x(wo);
        let f = base.scale(cos_pdf * self.inv_eta_2 * (1.0 - f_i) * (1.0 - f_o));
        let pdf = cos_pdf * self.prob_diffuse_x(f_i);
        (
            V3x::select(below, V3x::ZERO, f),
            F16::select(below, zero, pdf),
        )
    }

    /// [`Self::sample`] per lane, with each lane's [`Self::base`] and specular reflectance:
    /// (wo, pdf, weight, delta lobe, valid), valid false where that returns None.
    #[inline(always)]
    pub fn sample_x(
        &self,
        base: V3x,
        specular: V3x,
        wi: V3x,
        sample1: F16,
        sample2: V2x,
    ) -> (V3x, F16, V3x, M16, M16) {
        let zero = F16::splat(0.0);
        let f_i = fresnel_dielectric_t(wi.z, self.eta).r;
        let prob_diffuse = self.prob_diffuse_x(f_i);
        let prob_specular = 1.0 - prob_diffuse;
        let specular_lobe = sample1.lt(prob_specular);
        // The specular lobe: the mirror direction.
        let ws = V3x::new(-wi.x, -wi.y, wi.z);
        let w_spec = specular.scale(f_i / prob_specular);
        // The diffuse lobe.
        let wd = warp::square_to_cosine_hemisphere_x(sample2);
        let pdf_d = prob_diffuse * warp::square_to_cosine_hemisphere_pdf_x(wd);
        let f_o = fresnel_dielectric_t(wd.z, self.eta).r;
        let w_diff = base.scale(self.inv_eta_2 * (1.0 - f_i) * (1.0 - f_o) / prob_diffuse);
        let above = wi.z.le(zero).not();
        let ok = above.and(specular_lobe.or(pdf_d.le(zero).not()));
        (
            V3x::select(specular_lobe, ws, wd),
            F16::select(specular_lobe, prob_specular, pdf_d),
            V3x::select(specular_lobe, w_spec, w_diff),
            specular_lobe,
            ok,
        )
    }
}

impl Bxdf for Plastic {
    /// Delta and diffuse reflection.
    fn flags(&self) -> BsdfFlags {
        let f = BsdfFlags::DELTA_REFLECTION | BsdfFlags::DIFFUSE_REFLECTION;
        f.varying_if(
            self.diffuse_reflectance.is_spatially_varying()
                || self.specular_reflectance.is_spatially_varying(),
        )
    }

    /// The diffuse lobe only (the specular one is a delta).
    fn eval(&self, si: &SurfaceInteraction, wo: Vec3) -> Spectrum {
        if si.wi.z <= 0.0 || wo.z <= 0.0 {
            return Spectrum::ZERO;
        }
        let f_i = fresnel_dielectric(si.wi.z, self.eta).r;
        let f_o = fresnel_dielectric(wo.z, self.eta).r;
        self.base(si.uv)
            * (warp::square_to_cosine_hemisphere_pdf(wo)
                * self.inv_eta_2
                * (1.0 - f_i)
                * (1.0 - f_o))
    }

    /// Cosine-hemisphere pdf times the diffuse lobe's selection probability.
    fn pdf(&self, si: &SurfaceInteraction, wo: Vec3) -> f32 {
        if si.wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let f_i = fresnel_dielectric(si.wi.z, self.eta).r;
        warp::square_to_cosine_hemisphere_pdf(wo) * self.prob_diffuse(f_i)
    }

    /// Chooses the specular lobe with probability ∝ F_i · w_s, else the diffuse one.
    fn sample(
        &self,
        si: &SurfaceInteraction,
        sample1: f32,
        sample2: Vec2,
    ) -> Option<(BsdfSample, Spectrum)> {
        if si.wi.z <= 0.0 {
            return None;
        }
        let f_i = fresnel_dielectric(si.wi.z, self.eta).r;
        let prob_diffuse = self.prob_diffuse(f_i);
        let prob_specular = 1.0 - prob_diffuse;
        if sample1 < prob_specular {
            let bs = BsdfSample {
                wo: reflect(si.wi),
                pdf: prob_specular,
                eta: 1.0,
                sampled: BsdfFlags::DELTA_REFLECTION,
            };
            let w = self.specular_reflectance.eval(si.uv) * (f_i / prob_specular);
            return Some((bs, w));
        }
        let wo = warp::square_to_cosine_hemisphere(sample2);
        let pdf = prob_diffuse * warp::square_to_cosine_hemisphere_pdf(wo);
        if pdf <= 0.0 {
            return None;
        }
        let f_o = fresnel_dielectric(wo.z, self.eta).r;
        let w = self.base(si.uv) * (self.inv_eta_2 * (1.0 - f_i) * (1.0 - f_o) / prob_diffuse);
        let bs = BsdfSample {
            wo,
            pdf,
            eta: 1.0,
            sampled: BsdfFlags::DIFFUSE_REFLECTION,
        };
        Some((bs, w))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Pcg32;

    fn bits(v: Vec3) -> [u32; 3] {
        v.to_array().map(f32::to_bits)
    }

    #[test]
    fn soa_twins_match_the_scalar_plastic() {
        // Lane by lane and bit for bit, with the degenerate inputs the branches exist for:
        // directions below and on the horizon, an index-matched coating, sample numbers at 0.
        let mut rng = Pcg32::new(7, 9);
        let colour = |r: &mut Pcg32| Spectrum::new(r.next_f32(), r.next_f32(), r.next_f32());
        for (k, eta) in [1.49f32, 1.0, 1.9, 0.7].into_iter().enumerate() {
            let p = Plastic::new(
                eta,
                Texture::Constant(colour(&mut rng)),
                Texture::Constant(colour(&mut rng)),
                k == 2,
            );
            for round in 0..200 {
                let (mut wi, mut wo) = (V3x::ZERO, V3x::ZERO);
                let (mut u1, mut u2) = (F16::splat(0.0), V2x::ZERO);
                let (mut base, mut spec) = (V3x::ZERO, V3x::ZERO);
                let mut si = Vec::new();
                for l in 0..16 {
                    let mut a = warp::square_to_uniform_sphere(rng.next_2d());
                    let mut b = warp::square_to_uniform_sphere(rng.next_2d());
                    match (round + l) % 7 {
                        0 => a.z = 0.0,
                        1 => b.z = 0.0,
                        2 => a = Vec3::Z,
                        _ => {}
                    }
                    if (round + l) % 3 == 0 {
                        b.z = b.z.abs();
                    }
                    let uv = rng.next_2d();
                    let s = SurfaceInteraction::for_tests(a, uv);
                    wi.set(l, a);
                    wo.set(l, b);
                    u1.0[l] = if l == 5 { 0.0 } else { rng.next_f32() };
                    u2.set(l, rng.next_2d());
                    base.set(l, p.base(uv));
                    spec.set(l, p.specular_reflectance.eval(uv));
                    si.push(s);
                }
                let (f, pdf) = p.eval_pdf_x(base, wi, wo);
                let (swo, spdf, sw, sdelta, sok) = p.sample_x(base, spec, wi, u1, u2);
                for (l, s) in si.iter().enumerate() {
                    let b = wo.get(l);
                    assert_eq!(
                        bits(f.get(l)),
                        bits(p.eval(s, b)),
                        "eval, eta {eta} lane {l}"
                    );
                    assert_eq!(pdf.0[l].to_bits(), p.pdf(s, b).to_bits(), "pdf, eta {eta}");
                    match p.sample(s, u1.0[l], u2.get(l)) {
                        None => assert!(!sok.0[l], "sample, eta {eta} lane {l}"),
                        Some((bs, w)) => {
                            assert!(sok.0[l], "sample, eta {eta} lane {l}");
                            assert_eq!(bits(swo.get(l)), bits(bs.wo));
                            assert_eq!(spdf.0[l].to_bits(), bs.pdf.to_bits());
                            assert_eq!(bits(sw.get(l)), bits(w));
                            assert_eq!(sdelta.0[l], bs.sampled.has(BsdfFlags::DELTA));
                        }
                    }
                }
            }
        }
    }
}
