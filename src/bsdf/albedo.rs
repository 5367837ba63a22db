//! The diffuse reflectance of a BSDF at a hit (Mitsuba's `BSDF::eval_diffuse_reflectance`),
//! which the `aov` integrator writes as its `albedo` type.

use super::Bsdf;
use crate::geometry::SurfaceInteraction;
use crate::math::{Spectrum, Vec3};

impl Bsdf {
    /// The albedo at the hit `si`, as Mitsuba 3.9.1 defines it per plugin: a diffuse
    /// reflectance or base colour texture where the model has one, the nested model's for the
    /// wrappers, the blend of both for `blendbsdf`, the front or back model for `twosided` by
    /// the side `si.wi` is on; every other model π · eval(wi, normal) (0 for purely specular
    /// ones).
    pub fn diffuse_reflectance(&self, si: &SurfaceInteraction) -> Spectrum {
        match self {
            Bsdf::Diffuse(d) => d.reflectance.eval_at(si),
            Bsdf::Plastic(p) => p.diffuse_reflectance.eval(si.uv),
            Bsdf::RoughPlastic(p) => p.diffuse_reflectance.eval(si.uv),
            Bsdf::Principled(p) => p.base_color.eval(si.uv),
            Bsdf::PrincipledThin(p) => p.base_color.eval(si.uv),
            Bsdf::Mask(m) => m.nested.diffuse_reflectance(si),
            Bsdf::NormalMap(n) => n.nested.diffuse_reflectance(si),
            Bsdf::BumpMap(b) => b.nested.diffuse_reflectance(si),
            Bsdf::Blend(b) => {
                let w = b.weight_at(si);
                b.bsdfs[0].diffuse_reflectance(si) * (1.0 - w)
                    + b.bsdfs[1].diffuse_reflectance(si) * w
            }
            Bsdf::TwoSided(t) => {
                if si.wi.z < 0.0 {
                    let mut back = *si;
                    back.wi.z = -back.wi.z;
                    t.back.diffuse_reflectance(&back)
                } else {
                    t.front.diffuse_reflectance(si)
                }
            }
            _ => self.eval(si, Vec3::Z) * std::f32::consts::PI,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{BlendBsdf, Conductor, Diffuse, Texture, TwoSided};
    use crate::math::Vec2;

    fn diffuse(r: f32, g: f32, b: f32) -> Bsdf {
        Bsdf::Diffuse(Diffuse {
            reflectance: Texture::Constant(Spectrum::new(r, g, b)),
        })
    }

    #[test]
    fn wrappers_blend_and_sides_pick_their_nested_albedo() {
        let up = SurfaceInteraction::for_tests(Vec3::new(0.3, 0.0, 0.95).normalize(), Vec2::ZERO);
        let down =
            SurfaceInteraction::for_tests(Vec3::new(0.3, 0.0, -0.95).normalize(), Vec2::ZERO);
        let (a, b) = (diffuse(0.8, 0.4, 0.2), diffuse(0.1, 0.2, 0.3));
        assert_eq!(a.diffuse_reflectance(&up), Spectrum::new(0.8, 0.4, 0.2));
        let blend = Bsdf::Blend(BlendBsdf {
            weight: Texture::uniform(0.25),
            bsdfs: Box::new([a.clone(), b.clone()]),
        });
        let want = Spectrum::new(0.8, 0.4, 0.2) * 0.75 + Spectrum::new(0.1, 0.2, 0.3) * 0.25;
        assert!((blend.diffuse_reflectance(&up) - want).abs().max_element() < 1e-6);
        let two = Bsdf::TwoSided(TwoSided::new(a, b).unwrap());
        assert_eq!(two.diffuse_reflectance(&up), Spectrum::new(0.8, 0.4, 0.2));
        assert_eq!(two.diffuse_reflectance(&down), Spectrum::new(0.1, 0.2, 0.3));
        // A smooth conductor has no lobe at the normal: π·f(wi, n) is 0.
        let mirror = Bsdf::Conductor(Conductor {
            eta: Texture::Constant(Spectrum::ZERO),
            k: Texture::Constant(Spectrum::ONE),
            specular_reflectance: Texture::Constant(Spectrum::ONE),
        });
        assert_eq!(mirror.diffuse_reflectance(&up), Spectrum::ZERO);
    }
}
