//! The procedural material library: five virtual samples spanning the paper's range (knitted
//! wool, corduroy, leather, lacquered wood, brushed metal foil). Feature sizes are given in texels
//! for a 64-texel tile and rounded to a whole number of repeats per tile so every tile wraps.

use super::MicroSurface;
use super::brdf::BrdfParams;
use super::noise::{hash_unit, periodic_fbm, periodic_noise, periodic_worley};
use crate::math::{Vec2, Vec3};
use crate::{Error, Result};
use std::f32::consts::{PI, TAU};

/// The built-in materials.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MaterialKind {
    Wool,
    Corduroy,
    Leather,
    Wood,
    Foil,
}

impl MaterialKind {
    /// Every material, in `--list` order.
    pub const ALL: [MaterialKind; 5] = [
        MaterialKind::Wool,
        MaterialKind::Corduroy,
        MaterialKind::Leather,
        MaterialKind::Wood,
        MaterialKind::Foil,
    ];

    /// The CLI name.
    pub fn name(self) -> &'static str {
        match self {
            MaterialKind::Wool => "wool",
            MaterialKind::Corduroy => "corduroy",
            MaterialKind::Leather => "leather",
            MaterialKind::Wood => "wood",
            MaterialKind::Foil => "foil",
        }
    }

    /// One line for `btfpt synth --list`.
    pub fn description(self) -> &'static str {
        match self {
            MaterialKind::Wool => {
                "knitted wool: stockinette V loops of twisted yarn, fibre fuzz and sheen"
            }
            MaterialKind::Corduroy => {
                "corduroy: tall pile ridges along the rows (strongly anisotropic), velvet sheen"
            }
            MaterialKind::Leather => "leather: pebbled cellular grain with creases, low gloss",
            MaterialKind::Wood => {
                "lacquered wood: diffuse ring grain with pores under a smooth clear coat"
            }
            MaterialKind::Foil => {
                "brushed metal foil: crumpled aluminium, anisotropic GGX along the brushing"
            }
        }
    }

    /// Looks a material up by CLI name.
    pub fn from_name(name: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|m| m.name().eq_ignore_ascii_case(name))
            .ok_or_else(|| {
                let names: Vec<_> = Self::ALL.iter().map(|m| m.name()).collect();
                Error::Invalid(format!(
                    "unknown synth material '{name}' (known: {})",
                    names.join(", ")
                ))
            })
    }

    /// Builds the `width × height` texel tile with `subdiv × subdiv` geometry cells per texel;
    /// `seed` varies the noise (not the structure).
    pub fn build(
        self,
        width: usize,
        height: usize,
        subdiv: usize,
        seed: u64,
    ) -> Result<MicroSurface> {
        let t = Tile::new(width, height, seed);
        match self {
            MaterialKind::Wool => MicroSurface::from_fn(
                width,
                height,
                subdiv,
                true,
                |x, y| wool(&t, x, y).0,
                |x, y| wool(&t, x, y).1,
            ),
            MaterialKind::Corduroy => MicroSurface::from_fn(
                width,
                height,
                subdiv,
                true,
                |x, y| corduroy(&t, x, y).0,
                |x, y| corduroy(&t, x, y).1,
            ),
            MaterialKind::Leather => MicroSurface::from_fn(
                width,
                height,
                subdiv,
                true,
                |x, y| leather(&t, x, y).0,
                |x, y| leather(&t, x, y).1,
            ),
            MaterialKind::Wood => MicroSurface::from_fn(
                width,
                height,
                subdiv,
                true,
                |x, y| wood(&t, x, y).0,
                |x, y| wood(&t, x, y).1,
            ),
            MaterialKind::Foil => MicroSurface::from_fn(
                width,
                height,
                subdiv,
                true,
                |x, y| foil(&t, x, y).0,
                |x, y| foil(&t, x, y).1,
            ),
        }
    }
}

/// Tile geometry shared by the material functions.
struct Tile {
    w: f32,
    h: f32,
    seed: u64,
}

impl Tile {
    fn new(w: usize, h: usize, seed: u64) -> Self {
        Tile {
            w: w as f32,
            h: h as f32,
            seed,
        }
    }

    /// Whole repeats of a feature of `period` texels along x and y.
    fn reps(&self, period: f32) -> (u32, u32) {
        (
            ((self.w / period).round() as u32).max(1),
            ((self.h / period).round() as u32).max(1),
        )
    }

    /// Tile-relative coordinates in [0, 1).
    fn uv(&self, x: f32, y: f32) -> (f32, f32) {
        (x / self.w, y / self.h)
    }

    /// fBm whose base cell is about `period` texels.
    fn fbm(&self, x: f32, y: f32, period: f32, octaves: u32, salt: u64) -> f32 {
        let (px, py) = self.reps(period);
        let (u, v) = self.uv(x, y);
        periodic_fbm(u, v, px, py, octaves, self.seed ^ salt)
    }
}

fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

fn rgb(r: f32, g: f32, b: f32) -> Vec3 {
    Vec3::new(r, g, b)
}

/// Knitted wool (stockinette): every stitch is a V of two yarn legs; a leg is an oval loop
/// (≈ 0.62 × 0.27 stitch, tilted ±20° from the wale) of round cross-section with 3-ply twist
/// ridges, over a darker back layer; fibre fuzz as fine noise plus sheen; the fibre tangent
/// follows the ply twist.
fn wool(t: &Tile, x: f32, y: f32) -> (f32, BrdfParams) {
    let (nsx, nsy) = t.reps(8.0);
    let (sw, sh) = (t.w / nsx as f32, t.h / nsy as f32);
    let (u, v) = t.uv(x, y);
    let (gx, gy) = (u * nsx as f32, v * nsy as f32);
    let (ci, cj) = (gx.floor(), gy.floor());
    let p = Vec2::new((gx - ci) * sw, (gy - cj) * sh); // texels within the stitch
    let (ra, rb) = (0.62 * sh, 0.27 * sw); // leg half-length, half-width
    let depth = 0.3 * sw; // loop height
    let mut best = (-1.0f32, 0.0f32, 0u64); // (height, fibre angle, stitch hash)
    for dj in -1..=1 {
        for di in -1..=1 {
            let off = Vec2::new(di as f32 * sw, dj as f32 * sh);
            let sid = super::noise::hash2(
                (ci as i64 + di as i64).rem_euclid(nsx as i64),
                (cj as i64 + dj as i64).rem_euclid(nsy as i64),
                t.seed,
            );
            let jitter = Vec2::new(hash_unit(sid) - 0.5, hash_unit(sid >> 7) - 0.5) * (0.05 * sw);
            for leg in 0..2 {
                let sgn = if leg == 0 { -1.0 } else { 1.0 };
                let centre = off + jitter + Vec2::new((0.5 + sgn * 0.22) * sw, 0.5 * sh);
                // Leg axis: top-outer to bottom-centre (a V), ±20° from vertical.
                let ang = sgn * 20f32.to_radians();
                let axis = Vec2::new(-ang.sin(), ang.cos());
                let d = p - centre;
                let (along, across) = (d.dot(axis) / ra, d.perp_dot(axis) / rb);
                let rho2 = along * along + across * across;
                if rho2 < 1.0 {
                    let prof = (1.0 - rho2).sqrt();
                    // Three-ply twist ridges crossing the leg diagonally.
                    let twist = 0.1 * (TAU * (3.0 * along + 1.2 * across)).sin();
                    let hgt = depth * prof.sqrt() * (1.0 + twist);
                    if hgt > best.0 {
                        best = (hgt, axis.y.atan2(axis.x) + sgn * 0.6, sid);
                    }
                }
            }
        }
    }
    let fuzz = t.fbm(x, y, 1.0, 2, 11);
    let back = 0.1 * depth + 0.15 * t.fbm(x, y, 2.0, 2, 12);
    let on_yarn = best.0 > back;
    let height = best.0.max(back) + 0.05 * fuzz;
    let tint = 1.0 + 0.12 * (hash_unit(best.2) - 0.5) + 0.15 * t.fbm(x, y, 1.0, 2, 13);
    let base = rgb(0.50, 0.10, 0.08) * tint;
    let diffuse = if on_yarn { base } else { base * 0.45 };
    let params = BrdfParams {
        diffuse,
        specular: Vec3::splat(0.03),
        alpha: Vec2::new(0.25, 0.6),
        tangent_angle: if on_yarn { best.1 } else { 0.0 },
        sheen: rgb(0.35, 0.2, 0.18),
        sheen_roughness: 0.45,
        coat: 0.0,
        coat_alpha: 0.1,
    };
    (height, params)
}

/// Corduroy: cut-pile wales running along y (rows), a rounded ridge of ≈ 2 texels height per
/// ≈ 6 texels, narrow valleys between them; pile fibres give sheen and an anisotropic lobe.
fn corduroy(t: &Tile, x: f32, y: f32) -> (f32, BrdfParams) {
    let (n, _) = t.reps(6.0);
    let (u, _) = t.uv(x, y);
    let s = (u * n as f32).fract();
    let wale = t.w / n as f32;
    let c = (s - 0.5) / 0.42;
    let ridge = (1.0 - c * c).max(0.0).sqrt();
    let pile = 0.07 * t.fbm(x, y, 0.6, 2, 21);
    let height = 0.38 * wale * ridge * (1.0 + 0.08 * t.fbm(x, y, 12.0, 2, 22)) + pile;
    let depth = ridge.sqrt();
    let tint = 1.0 + 0.1 * t.fbm(x, y, 3.0, 3, 23);
    let params = BrdfParams {
        diffuse: rgb(0.30, 0.17, 0.08) * tint * (0.4 + 0.6 * depth),
        specular: Vec3::splat(0.03),
        alpha: Vec2::new(0.15, 0.6),
        tangent_angle: PI / 2.0,
        sheen: rgb(0.30, 0.24, 0.18) * depth,
        sheen_roughness: 0.3,
        coat: 0.0,
        coat_alpha: 0.1,
    };
    (height, params)
}

/// Leather: Worley-cell pebbles (≈ 3.5 texels) separated by creases, slow wrinkles, fine pores;
/// low gloss, darker creases.
fn leather(t: &Tile, x: f32, y: f32) -> (f32, BrdfParams) {
    let (px, py) = t.reps(3.5);
    let (u, v) = t.uv(x, y);
    let (f1, f2, id) = periodic_worley(u, v, px, py, t.seed ^ 31);
    let crease = smoothstep(0.0, 0.22, f2 - f1);
    let dome = 1.0 - 0.5 * f1 * f1;
    let height = 0.55 * crease.sqrt() * dome
        + 0.35 * t.fbm(x, y, 16.0, 3, 32)
        + 0.04 * t.fbm(x, y, 0.5, 1, 33);
    let tint = 0.85 + 0.3 * hash_unit(id);
    let params = BrdfParams {
        diffuse: rgb(0.30, 0.15, 0.07) * tint * (0.45 + 0.55 * crease),
        specular: Vec3::splat(0.04),
        alpha: Vec2::splat(0.55 - 0.2 * crease),
        tangent_angle: 0.0,
        sheen: Vec3::ZERO,
        sheen_roughness: 0.5,
        coat: 0.0,
        coat_alpha: 0.1,
    };
    (height, params)
}

/// Lacquered wood: growth rings as distorted bands along x (≈ 5 texels apart), dark latewood,
/// elongated pores sunk into the latewood, all under a smooth clear coat.
fn wood(t: &Tile, x: f32, y: f32) -> (f32, BrdfParams) {
    let (_, nr) = t.reps(5.0);
    let (u, v) = t.uv(x, y);
    let g = (v * nr as f32 + 0.6 * t.fbm(x, y, 16.0, 3, 41) + 8.0).fract();
    let late = smoothstep(0.55, 0.8, g) * (1.0 - smoothstep(0.9, 1.0, g));
    let (qx, qy) = t.reps(2.0);
    let (pf1, _, _) = periodic_worley(u, v, (qx / 2).max(1), qy * 2, t.seed ^ 42);
    let pore = (1.0 - smoothstep(0.08, 0.22, pf1)) * late;
    let height = -0.18 * pore - 0.06 * late + 0.02 * periodic_noise(u * 64.0, v * 64.0, 64, 64, 43);
    let fibre = 1.0 + 0.08 * t.fbm(x, y, 0.8, 2, 44);
    let light = rgb(0.60, 0.36, 0.17);
    let dark = rgb(0.30, 0.14, 0.05);
    let params = BrdfParams {
        diffuse: (light + (dark - light) * late) * fibre * (1.0 - 0.5 * pore),
        specular: Vec3::ZERO,
        alpha: Vec2::splat(0.3),
        tangent_angle: 0.0,
        sheen: Vec3::ZERO,
        sheen_roughness: 0.5,
        coat: 1.0,
        coat_alpha: 0.07,
    };
    (height, params)
}

/// Brushed metal foil: crumpled foil (wrinkles ≈ 10 texels, ≈ 1.5 texels deep) with fine
/// brushing scratches along x; aluminium-coloured anisotropic GGX, smooth along the brushing.
fn foil(t: &Tile, x: f32, y: f32) -> (f32, BrdfParams) {
    let (u, v) = t.uv(x, y);
    let crumple = 1.5 * t.fbm(x, y, 10.0, 4, 51);
    let (sx, _) = t.reps(32.0);
    let (_, sy) = t.reps(0.5);
    let scratch = 0.05 * periodic_noise(u * sx as f32, v * sy as f32, sx, sy, t.seed ^ 52);
    let height = crumple + scratch;
    let var = 1.0 + 0.25 * t.fbm(x, y, 8.0, 2, 53);
    let params = BrdfParams {
        diffuse: Vec3::ZERO,
        specular: rgb(0.91, 0.92, 0.93),
        alpha: Vec2::new(0.07, 0.3) * var,
        tangent_angle: 0.05 * t.fbm(x, y, 8.0, 2, 54),
        sheen: Vec3::ZERO,
        sheen_roughness: 0.5,
        coat: 0.0,
        coat_alpha: 0.1,
    };
    (height, params)
}
