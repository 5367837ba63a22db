//! 16-lane f32 transcendental functions for the packet kernels (sin/cos, exp2, log2) instead of
//! libm on the hot path. Each is a branch-free polynomial written once for one lane
//! ([`lane`]) and run over a `[f32; 16]` in a loop that LLVM vectorises inside a
//! `#[target_feature]` function: AVX-512 (one zmm per array), AVX2 (two ymm), or the baseline
//! SSE2 build, chosen once per process at runtime ([`isa`]). No fused multiply-adds are used, so
//! the three paths return the same bits (the image does not depend on the CPU it ran on).
//! `cargo bench --bench simd_math` compares them with libm.

pub mod lane;
pub mod real;
#[cfg(target_arch = "x86_64")]
pub mod transpose;
pub mod wide;

use std::sync::OnceLock;

/// Lanes of one call: an AVX-512 register of f32.
pub const WIDTH: usize = 16;

/// Sixteen f32 lanes.
pub type F32x16 = [f32; WIDTH];

/// An instruction-set level a kernel is built for (what dispatch matches on).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Level {
    /// AVX-512F (+ AVX2, FMA available but unused): one instruction per 16 lanes.
    Avx512,
    /// AVX2: two 8-lane halves.
    Avx2,
    /// The baseline build (SSE2 on x86-64, or whatever the target has).
    Portable,
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

    /// Every instruction set this CPU runs, the portable one first (to compare the builds).
    pub fn available() -> Vec<Isa> {
        match isa().0 {
            Level::Avx512 => vec![Isa::PORTABLE, Isa(Level::Avx2), Isa(Level::Avx512)],
            Level::Avx2 => vec![Isa::PORTABLE, Isa(Level::Avx2)],
            Level::Portable => vec![Isa::PORTABLE],
        }
    }
}

/// The best instruction set of this CPU, detected once.
pub fn isa() -> Isa {
    static ISA: OnceLock<Isa> = OnceLock::new();
    *ISA.get_or_init(detect)
}

fn detect() -> Isa {
    #[cfg(target_arch = "x86_64")]
    {
        if is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx2") {
            return Isa(Level::Avx512);
        }
        if is_x86_feature_detected!("avx2") {
            return Isa(Level::Avx2);
        }
    }
    Isa::PORTABLE
}

/// Defines a public 16-lane function `$name(isa, x) -> ($out)` from a one-lane body, with an
/// AVX-512, an AVX2 and a portable instantiation of the same loop.
macro_rules! lanes16 {
    ($kind:ident, $(#[$doc:meta])* $name:ident, $lane:path, $out:ty, $zero:expr) => {
        $(#[$doc])*
        #[inline]
        pub fn $name(isa: Isa, x: &F32x16) -> $out {
            #[inline(always)]
            fn body(x: &F32x16) -> $out {
                let mut out: $out = $zero;
                run(x, &mut out);
                out
            }
            #[inline(always)]
            fn run(x: &F32x16, out: &mut $out) {
                lanes16!(@$kind x, out, $lane);
            }
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx512f,avx2")]
            fn avx512(x: &F32x16) -> $out {
                body(x)
            }
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx2")]
            fn avx2(x: &F32x16) -> $out {
                body(x)
            }
            match isa.level() {
                // SAFETY: an `Isa` of these levels is made only by `detect` / `Isa::available`,
                // which checked the features on this CPU.
                #[cfg(target_arch = "x86_64")]
                Level::Avx512 => unsafe { avx512(x) },
                #[cfg(target_arch = "x86_64")]
                Level::Avx2 => unsafe { avx2(x) },
                _ => body(x),
            }
        }
    };
    (@pair $x:ident, $out:ident, $lane:path) => {
        for i in 0..WIDTH {
            let (s, c) = $lane($x[i]);
            $out.0[i] = s;
            $out.1[i] = c;
        }
    };
    (@single $x:ident, $out:ident, $lane:path) => {
        for i in 0..WIDTH {
            $out[i] = $lane($x[i]);
        }
    };
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

lanes16!(
    pair,
    /// (sin x, cos x) per lane, |x| ≤ 8192 (error ≤ 2e-7 absolute; see [`lane::sin_cos`]).
    sin_cos,
    lane::sin_cos,
    (F32x16, F32x16),
    ([0.0; WIDTH], [0.0; WIDTH])
);

lanes16!(
    single,
    /// 2^x per lane (relative error < 3e-7 for normal results; 0 below −127, ∞ from 128, NaN
    /// stays NaN).
    exp2,
    lane::exp2,
    F32x16,
    [0.0; WIDTH]
);

lanes16!(
    single,
    /// log2 x per lane (absolute error < 3e-7 near 1, relative < 2e-7 elsewhere; −∞ at 0,
    /// NaN below 0, subnormals exact).
    log2,
    lane::log2,
    F32x16,
    [0.0; WIDTH]
);

#[cfg(test)]
mod tests;
