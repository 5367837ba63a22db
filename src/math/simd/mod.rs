//! The SIMD vocabulary of the crate, in one place:
//!
//! - [`Isa`]: the one feature token. The CPU's instruction set is detected once per process
//!   ([`isa`]) and every kernel that has builds for several instruction sets picks its build from
//!   this token (through [`crate::isa_dispatch`] or a `match` on [`Isa::level`]); nothing else
//!   asks the CPU for features.
//! - The lane types, side by side: [`f4::F4`] (4 f32, one SSE register: the PLM-C evaluation
//!   kernel), [`f8::F8`] (8 f32, one AVX register or two SSE ones: the BVH traversal) and
//!   [`f16::F16`] (16 f32 with its mask and vectors: the packet integrator's straight-line
//!   code), with [`real::Real`] for helpers written once over `f32` and `F16`.
//! - [`approx`]: every polynomial approximation of a transcendental function (sin/cos, exp2,
//!   log2, exp, ln, atan2), each written once, with its error bound and which kernels use it.
//! - [`transpose`]: the AVX-512 16 × 16 and the AVX 8 × 8 register transposes.
//!
//! No fused multiply-adds outside the PLM-C kernel's fused approximations: code built for any of
//! the levels returns the same bits (the image does not depend on the CPU it ran on).

pub mod approx;
pub mod f16;
pub mod f4;
pub mod f8;
pub mod real;
#[cfg(target_arch = "x86_64")]
pub mod transpose;

use std::sync::OnceLock;

/// Lanes of one call: an AVX-512 register of f32.
pub const WIDTH: usize = 16;

/// Sixteen f32 lanes.
pub type F32x16 = [f32; WIDTH];

/// An instruction-set level a kernel is built for (what dispatch matches on), lowest first:
/// each level includes the ones below it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// The baseline build (SSE2 on x86-64, or whatever the target has).
    Portable,
    /// AVX2 and FMA: two 8-lane halves per 16 lanes (FMA only where a kernel fuses on purpose).
    Avx2,
    /// AVX-512F (with AVX2 and FMA): one instruction per 16 lanes.
    Avx512,
}

/// An instruction set this CPU runs. Made only by [`isa`] and [`Isa::available`] (and the
/// always-safe [`Isa::PORTABLE`]), so the dispatchers may run a `#[target_feature]` build for
/// its level: safe code cannot name a level the CPU lacks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Isa(Level);

impl Isa {
    /// The baseline build, which every CPU runs.
    pub const PORTABLE: Isa = Isa(Level::Portable);

    /// The level the kernels run at.
    #[inline]
    pub fn level(self) -> Level {
        self.0
    }

    /// This level or `level`, whichever is lower (to compare builds: a lower level always runs).
    #[inline]
    pub fn at_most(self, level: Level) -> Isa {
        Isa(self.0.min(level))
    }

    /// Every instruction set this CPU runs, the portable one first (to compare the builds).
    pub fn available() -> Vec<Isa> {
        match isa().0 {
            Level::Avx512 => vec![Isa::PORTABLE, Isa(Level::Avx2), Isa(Level::Avx512)],
            Level::Avx2 => vec![Isa::PORTABLE, Isa(Level::Avx2)],
            Level::Portable => vec![Isa::PORTABLE],
        }
    }
}

/// The best instruction set of this CPU, detected once (the crate's only feature detection).
pub fn isa() -> Isa {
    static ISA: OnceLock<Isa> = OnceLock::new();
    *ISA.get_or_init(detect)
}

fn detect() -> Isa {
    #[cfg(target_arch = "x86_64")]
    {
        let avx2 = is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma");
        if avx2 && is_x86_feature_detected!("avx512f") {
            return Isa(Level::Avx512);
        }
        if avx2 {
            return Isa(Level::Avx2);
        }
    }
    Isa::PORTABLE
}

/// Defines `$name(isa, args…)`: the `#[inline(always)]` function `$body` run in a build for
/// `isa` (AVX-512, AVX2 or the baseline one). For kernels whose loops are written with fixed
/// lane-split sums and no fused multiply-adds, so every build returns the same bits; callers pass
/// [`isa()`] (tests may pass any of [`Isa::available`]).
#[macro_export]
macro_rules! isa_dispatch {
    ($(#[$doc:meta])* $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) -> $out:ty = $body:path;) => {
        $(#[$doc])*
        #[inline]
        $vis fn $name(isa: $crate::math::simd::Isa, $($arg: $ty),*) -> $out {
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx512f,avx2")]
            fn avx512($($arg: $ty),*) -> $out {
                $body($($arg),*)
            }
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx2")]
            fn avx2($($arg: $ty),*) -> $out {
                $body($($arg),*)
            }
            match isa.level() {
                // SAFETY: an `Isa` of these levels is made only by `simd::isa()` /
                // `Isa::available`, which checked the features on this CPU.
                #[cfg(target_arch = "x86_64")]
                $crate::math::simd::Level::Avx512 => unsafe { avx512($($arg),*) },
                #[cfg(target_arch = "x86_64")]
                $crate::math::simd::Level::Avx2 => unsafe { avx2($($arg),*) },
                _ => $body($($arg),*),
            }
        }
    };
}
