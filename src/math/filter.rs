//! Reconstruction filters of the film (Mitsuba 3's `rfilter` plugins): each sample is splatted
//! with weight f(dx)·f(dy) into every pixel whose centre lies within the filter radius, and a
//! pixel's value is Σ w·L / Σ w, as Mitsuba's `hdrfilm` does (without per-sample weight
//! normalisation). `box` of radius ½ is the special case where each sample lands in exactly one
//! pixel with weight 1; the film keeps its exact per-pixel path for it.

use crate::math::simd;
use crate::math::simd::approx::{exp2, floor_small};
use crate::math::simd::f16::{F16, lanes};
use crate::{Error, Result};

/// Largest filter radius accepted, in pixels (keeps the per-sample weight tables on the stack).
pub const MAX_RADIUS: f32 = 15.0;

/// Which 1-D filter kernel, with its precomputed constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FilterKind {
    /// 1 for |x| < radius.
    Box,
    /// Linear falloff 1 − |x|/radius.
    Tent,
    /// exp(α x²) − exp(α r²), clamped at 0; α = −1/(2σ²) · log₂ e (stored for `exp2`), r = 4σ.
    Gaussian { alpha: f32, bias: f32 },
    /// Mitchell–Netravali cubic with parameters B and C (Catmull–Rom is B = 0, C = ½).
    Mitchell { b: f32, c: f32 },
    /// Windowed sinc with `radius` lobes.
    Lanczos,
}

/// A separable reconstruction filter: kernel and radius in pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Filter {
    pub kind: FilterKind,
    /// Support half-width in pixels.
    pub radius: f32,
}

impl Default for Filter {
    /// Mitsuba's `hdrfilm` default: a Gaussian of standard deviation 0.5 pixels.
    fn default() -> Self {
        Filter::gaussian(0.5).expect("the default Gaussian is valid")
    }
}

fn check_radius(name: &str, r: f32) -> Result<f32> {
    if r.is_finite() && r > 0.0 && r <= MAX_RADIUS {
        Ok(r)
    } else {
        Err(Error::Invalid(format!(
            "rfilter '{name}': radius {r} must be in (0, {MAX_RADIUS}] pixels"
        )))
    }
}

impl Filter {
    /// The box filter of radius ½: one pixel per sample, weight 1.
    pub const BOX: Filter = Filter {
        kind: FilterKind::Box,
        radius: 0.5,
    };

    /// `box` with the given radius in pixels (Mitsuba default 0.5).
    pub fn boxed(radius: f32) -> Result<Filter> {
        Ok(Filter {
            kind: FilterKind::Box,
            radius: check_radius("box", radius)?,
        })
    }

    /// `tent` with the given radius in pixels (Mitsuba default 1).
    pub fn tent(radius: f32) -> Result<Filter> {
        Ok(Filter {
            kind: FilterKind::Tent,
            radius: check_radius("tent", radius)?,
        })
    }

    /// `gaussian` with standard deviation `stddev` pixels (Mitsuba default 0.5), cut at 4σ.
    pub fn gaussian(stddev: f32) -> Result<Filter> {
        let radius = check_radius("gaussian", 4.0 * stddev)?;
        let alpha = -1.0 / (2.0 * stddev * stddev) * std::f32::consts::LOG2_E;
        Ok(Filter {
            kind: FilterKind::Gaussian {
                alpha,
                bias: exp2(alpha * radius * radius),
            },
            radius,
        })
    }

    /// `mitchell` (Mitsuba defaults B = C = ⅓, radius 2) and `catmullrom` (B = 0, C = ½).
    pub fn mitchell(b: f32, c: f32, radius: f32) -> Result<Filter> {
        if !(b.is_finite() && c.is_finite()) {
            return Err(Error::Invalid(format!(
                "rfilter 'mitchell': B = {b}, C = {c} must be finite"
            )));
        }
        Ok(Filter {
            kind: FilterKind::Mitchell { b, c },
            radius: check_radius("mitchell", radius)?,
        })
    }

    /// `lanczos` with `lobes` lobes (Mitsuba default 3); the radius is the lobe count.
    pub fn lanczos(lobes: i64) -> Result<Filter> {
        if lobes < 1 || lobes as f32 > MAX_RADIUS {
            return Err(Error::Invalid(format!(
                "rfilter 'lanczos': lobes = {lobes} must be in 1..={MAX_RADIUS}"
            )));
        }
        Ok(Filter {
            kind: FilterKind::Lanczos,
            radius: lobes as f32,
        })
    }

    /// True for the radius-½ box: the film then uses its one-pixel-per-sample path.
    pub fn is_box(&self) -> bool {
        self.kind == FilterKind::Box && self.radius == 0.5
    }

    /// Mitsuba's plugin name with the radius, for the render summary.
    pub fn name(&self) -> String {
        let kind = match self.kind {
            FilterKind::Box => "box",
            FilterKind::Tent => "tent",
            FilterKind::Gaussian { .. } => "gaussian",
            FilterKind::Mitchell { b, c } if b == 0.0 && c == 0.5 => "catmullrom",
            FilterKind::Mitchell { .. } => "mitchell",
            FilterKind::Lanczos => "lanczos",
        };
        format!("{kind} (radius {})", self.radius)
    }

    /// Pixels a sample can reach beyond its own pixel, on each side (Mitsuba's border size).
    pub fn border(&self) -> u32 {
        if self.is_box() {
            0
        } else {
            (self.radius - 0.5).ceil().max(0.0) as u32
        }
    }

    /// Filter weight at offset `x` pixels from a pixel centre, as Mitsuba 3.9 evaluates it.
    #[inline]
    pub fn eval(&self, x: f32) -> f32 {
        let r = self.radius;
        match self.kind {
            FilterKind::Box => {
                if x.abs() < r {
                    1.0
                } else {
                    0.0
                }
            }
            FilterKind::Tent => (1.0 - x.abs() / r).max(0.0),
            // The crate's own exp2 (no libm: the same bits on every CPU, and it vectorises over
            // a footprint's weights).
            FilterKind::Gaussian { alpha, bias } => gaussian(alpha, bias, x),
            FilterKind::Mitchell { b, c } => {
                let x = (2.0 * x / r).abs();
                let (x2, x3) = (x * x, x * x * x);
                let v = if x < 1.0 {
                    (12.0 - 9.0 * b - 6.0 * c) * x3
                        + (-18.0 + 12.0 * b + 6.0 * c) * x2
                        + (6.0 - 2.0 * b)
                } else {
                    (-b - 6.0 * c) * x3
                        + (6.0 * b + 30.0 * c) * x2
                        + (-12.0 * b - 48.0 * c) * x
                        + (8.0 * b + 24.0 * c)
                };
                if x < 2.0 { v * (1.0 / 6.0) } else { 0.0 }
            }
            FilterKind::Lanczos => {
                let x = x.abs();
                if x < f32::EPSILON {
                    1.0
                } else if x < r {
                    let x1 = std::f32::consts::PI * x;
                    let x2 = x1 / r;
                    (x1.sin() * x2.sin()) / (x1 * x2)
                } else {
                    0.0
                }
            }
        }
    }

    /// The pixels a sample at film coordinate `pos` reaches along one axis: the first, how
    /// many, and the first one's offset from the sample (the kernel's argument there).
    /// Positions are film coordinates, far below 2³¹, so the truncating floor is exact (and
    /// no libm call on the baseline target).
    #[inline(always)]
    fn footprint(&self, pos: f32) -> (f32, usize, f32) {
        let p = pos - 0.5;
        let lo = -floor_small(-(p - self.radius));
        let hi = floor_small(p + self.radius);
        let n = ((hi - lo) as i64 + 1).clamp(0, FOOTPRINT as i64) as usize;
        (lo, n, lo - p)
    }

    /// [`Filter::weights_1d`] along both axes of a sample at film position (`fx`, `fy`): the
    /// (first, count) of x and y. A Gaussian that reaches at most eight pixels per axis (every
    /// standard deviation up to 0.875 pixels, Mitsuba's default 0.5 among them) evaluates both
    /// axes in one 16-lane pass, the same bits as two `weights_1d` calls.
    #[inline]
    pub fn weights_2d(
        &self,
        fx: f32,
        fy: f32,
        wx: &mut [f32; FOOTPRINT],
        wy: &mut [f32; FOOTPRINT],
    ) -> ((i64, usize), (i64, usize)) {
        if let FilterKind::Gaussian { alpha, bias } = self.kind
            && self.radius < 3.5
        {
            let (lx, nx, bx) = self.footprint(fx);
            let (ly, ny, by) = self.footprint(fy);
            let w = gaussian_xy(simd::isa(), alpha, bias, bx, by);
            wx[..8].copy_from_slice(&w.0[..8]);
            wy[..8].copy_from_slice(&w.0[8..]);
            return ((lx as i64, nx), (ly as i64, ny));
        }
        (self.weights_1d(fx, wx), self.weights_1d(fy, wy))
    }

    /// Weights of a sample at film coordinate `pos` (pixel i covers [i, i+1)) for the pixels
    /// `first..first + n` along one axis: returns `first` and fills `w[..n]`.
    #[inline]
    pub fn weights_1d(&self, pos: f32, w: &mut [f32; FOOTPRINT]) -> (i64, usize) {
        let (lo, n, base) = self.footprint(pos);
        if let FilterKind::Gaussian { alpha, bias } = self.kind {
            // Whole groups of 8 with no branch inside, so the exp2 polynomial vectorises (the
            // weights past n are computed and never read).
            for (g, ws) in w.chunks_exact_mut(8).enumerate().take(n.div_ceil(8)) {
                for (i, wi) in ws.iter_mut().enumerate() {
                    *wi = gaussian(alpha, bias, base + (8 * g + i) as f32);
                }
            }
        } else {
            for (i, wi) in w.iter_mut().enumerate().take(n) {
                *wi = self.eval(base + i as f32);
            }
        }
        (lo as i64, n)
    }
}

/// The Gaussian kernel exp(α x²) − exp(α r²) clamped at 0, with α and the bias as
/// [`FilterKind::Gaussian`] stores them.
#[inline(always)]
fn gaussian(alpha: f32, bias: f32, x: f32) -> f32 {
    (exp2(alpha * x * x) - bias).max(0.0)
}

crate::isa_dispatch! {
    /// The Gaussian at `bx + i` (lanes i < 8) and `by + i − 8` (lanes 8..16): one sample's
    /// weights along both axes, one AVX-512 instruction per step.
    fn gaussian_xy(alpha: f32, bias: f32, bx: f32, by: f32) -> F16 = gaussian_lanes;
}

#[inline(always)]
fn gaussian_lanes(alpha: f32, bias: f32, bx: f32, by: f32) -> F16 {
    F16(lanes(|l| {
        let x = if l < 8 {
            bx + l as f32
        } else {
            by + (l - 8) as f32
        };
        gaussian(alpha, bias, x)
    }))
}

/// Most pixels one sample reaches along an axis (2·MAX_RADIUS + 1, rounded up).
pub const FOOTPRINT: usize = 32;

#[cfg(test)]
mod tests {
    use super::*;

    const XS: [f32; 10] = [0.0, 0.1, 0.37, 0.5, 0.8, 1.0, 1.3, 1.9, 2.5, 2.99];

    /// Golden values from Mitsuba 3.9.1 (llvm_ad_rgb): `mi.load_dict({...}).eval(XS)`
    /// (reference-images/filter_golden.py), with its radius and border size.
    #[test]
    #[allow(clippy::excessive_precision)] // Mitsuba's values as printed, digit for digit
    fn matches_mitsuba_eval() {
        let cases: [(Filter, f32, u32, [f32; 10]); 8] = [
            (
                Filter::tent(1.0).unwrap(),
                1.0,
                1,
                [1.0, 0.9, 0.63, 0.5, 0.2, 0.0, 0.0, 0.0, 0.0, 0.0],
            ),
            (
                Filter::default(),
                2.0,
                2,
                [
                    0.999247133731842,
                    0.979533314704895,
                    0.760367214679718,
                    0.606423020362854,
                    0.2776011824607849,
                    0.13496048748493195,
                    0.033704567700624466,
                    0.0003878818533848971,
                    0.0,
                    0.0,
                ],
            ),
            (
                Filter::gaussian(0.3).unwrap(),
                1.2,
                1,
                [
                    0.9992640614509583,
                    0.9454464912414551,
                    0.46717220544815063,
                    0.24892790615558624,
                    0.028234237805008888,
                    0.0035380125045776367,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                ],
            ),
            (
                Filter::mitchell(1.0 / 3.0, 1.0 / 3.0, 2.0).unwrap(),
                2.0,
                2,
                [
                    0.888888955116272,
                    0.870055615901947,
                    0.6741840839385986,
                    0.5347222685813904,
                    0.20622217655181885,
                    0.05555558204650879,
                    -0.02994457259774208,
                    -0.0029445188120007515,
                    0.0,
                    0.0,
                ],
            ),
            (
                Filter::mitchell(0.0, 0.5, 2.0).unwrap(),
                2.0,
                2,
                [
                    1.0,
                    0.9765000343322754,
                    0.7337295413017273,
                    0.5625,
                    0.1679999828338623,
                    0.0,
                    -0.07350032031536102,
                    -0.00450007151812315,
                    0.0,
                    0.0,
                ],
            ),
            (
                Filter::lanczos(3).unwrap(),
                3.0,
                3,
                [
                    1.0,
                    0.9818348288536072,
                    0.7699339985847473,
                    0.6079270839691162,
                    0.20745967328548431,
                    -2.3013184247133722e-08,
                    -0.1423301249742508,
                    -0.023769866675138474,
                    0.024317074567079544,
                    1.1183505193912424e-05,
                ],
            ),
            (
                Filter::tent(1.5).unwrap(),
                1.5,
                1,
                [
                    1.0,
                    0.9333333373069763,
                    0.753333330154419,
                    0.6666666269302368,
                    0.46666663885116577,
                    0.3333333134651184,
                    0.13333332538604736,
                    0.0,
                    0.0,
                    0.0,
                ],
            ),
            (
                Filter::mitchell(0.5, 0.25, 2.0).unwrap(),
                2.0,
                2,
                [
                    0.8333333730697632,
                    0.8168333768844604,
                    0.6444113254547119,
                    0.5208333730697632,
                    0.22533327341079712,
                    0.0833333358168602,
                    -0.008166870102286339,
                    -0.002166589256376028,
                    0.0,
                    0.0,
                ],
            ),
        ];
        for (f, radius, border, want) in cases {
            assert!((f.radius - radius).abs() < 1e-6, "{f:?}");
            assert_eq!(f.border(), border, "{f:?}");
            for (x, w) in XS.iter().zip(want) {
                let got = f.eval(*x);
                // Mitsuba's LLVM Gaussian differs from exp(αx²) − exp(αr²) by an oscillating
                // ≤ 4.2e-4 (an approximate exp: filter_golden.py prints both); we keep the
                // exact kernel, a weight change far below any test's noise.
                let tol = match f.kind {
                    FilterKind::Gaussian { .. } => 5e-4,
                    _ => 2e-6,
                };
                assert!((got - w).abs() <= tol, "{f:?} at {x}: {got} vs Mitsuba {w}");
            }
        }
        // Mitsuba's box is 1 strictly inside its radius.
        let b = Filter::BOX;
        assert!(b.is_box() && b.border() == 0);
        assert_eq!(XS.map(|x| b.eval(x))[..4], [1.0, 1.0, 1.0, 0.0]);
    }

    #[test]
    fn weights_cover_the_footprint() {
        let f = Filter::default();
        let mut w = [0.0; FOOTPRINT];
        // A sample at the centre of pixel 10 reaches pixels 8..=12 (the ends with weight 0).
        let (lo, n) = f.weights_1d(10.5, &mut w);
        assert_eq!((lo, n), (8, 5));
        assert_eq!(w[0], 0.0);
        assert!((w[2] - f.eval(0.0)).abs() < 1e-7);
        let (lo, n) = f.weights_1d(10.75, &mut w);
        assert_eq!((lo, n), (9, 4));
        assert!((w[1] - f.eval(-0.25)).abs() < 1e-7);
    }

    #[test]
    fn both_axes_at_once_match_each_axis_alone() {
        let filters = [
            Filter::default(),
            Filter::gaussian(0.3).unwrap(),
            Filter::gaussian(0.87).unwrap(),
            Filter::gaussian(1.5).unwrap(),
            Filter::tent(1.5).unwrap(),
            Filter::mitchell(1.0 / 3.0, 1.0 / 3.0, 2.0).unwrap(),
        ];
        let mut rng = crate::math::Pcg32::new(5, 1);
        for f in filters {
            for k in 0..2000 {
                // Pixel centres and edges, then random positions, some near the film's origin.
                let (fx, fy) = match k {
                    0 => (0.5, 0.5),
                    1 => (0.0, 3.0),
                    2 => (1e-4, 2.999),
                    _ => (300.0 * rng.next_f32(), 4.0 * rng.next_f32()),
                };
                let (mut ax, mut ay, mut bx, mut by) = (
                    [0.0; FOOTPRINT],
                    [0.0; FOOTPRINT],
                    [0.0; FOOTPRINT],
                    [0.0; FOOTPRINT],
                );
                let ((lx, nx), (ly, ny)) = f.weights_2d(fx, fy, &mut ax, &mut ay);
                assert_eq!((lx, nx), f.weights_1d(fx, &mut bx), "{f:?} {fx}");
                assert_eq!((ly, ny), f.weights_1d(fy, &mut by), "{f:?} {fy}");
                assert_eq!(ax[..nx], bx[..nx], "{f:?} {fx}");
                assert_eq!(ay[..ny], by[..ny], "{f:?} {fy}");
                // Against the ceil/floor definition of the footprint.
                let p = fx - 0.5;
                assert_eq!(lx, (p - f.radius).ceil() as i64, "{f:?} {fx}");
                assert_eq!(
                    nx as i64,
                    ((p + f.radius).floor() - (p - f.radius).ceil()) as i64 + 1
                );
            }
        }
        // Every instruction-set build of the 16-lane pass gives the same bits.
        if let FilterKind::Gaussian { alpha, bias } = Filter::default().kind {
            let want = gaussian_lanes(alpha, bias, -1.75, -2.0);
            for isa in crate::math::simd::Isa::available() {
                assert_eq!(gaussian_xy(isa, alpha, bias, -1.75, -2.0), want, "{isa:?}");
            }
        }
    }

    #[test]
    fn bad_parameters_are_errors() {
        assert!(Filter::gaussian(-1.0).is_err());
        assert!(Filter::tent(f32::NAN).is_err());
        assert!(Filter::lanczos(0).is_err());
        assert!(Filter::boxed(100.0).is_err());
    }
}
