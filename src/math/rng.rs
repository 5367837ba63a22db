//! Deterministic random numbers: the stream of a sample is a pure function of (seed, pixel, sample
//! index), never of the thread or tile schedule (docs/conventions.md, "Determinism").

/// PCG32 (O'Neill 2014, XSH-RR variant): small state, good statistics, cheap to seed per sample.
#[derive(Clone, Debug)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

const PCG_MULT: u64 = 6364136223846793005;

/// SplitMix64 finaliser: decorrelates nearby integer keys (pixel 0, 1, 2 …) before seeding.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl Pcg32 {
    /// An unseeded generator (state 0, stream 0): a placeholder for arrays of generators that
    /// are overwritten before use.
    pub const PLACEHOLDER: Pcg32 = Pcg32 { state: 0, inc: 1 };

    /// A generator with the given initial state and stream selector.
    pub fn new(init_state: u64, stream: u64) -> Self {
        let mut r = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        r.next_u32();
        r.state = r.state.wrapping_add(init_state);
        r.next_u32();
        r
    }

    /// The stream for one sample of one pixel of a render with `seed`.
    pub fn for_sample(seed: u64, pixel: u64, sample: u64) -> Self {
        let key = mix64(seed ^ mix64(pixel ^ mix64(sample)));
        Pcg32::new(key, mix64(key ^ 0xDA44_2D24_C9D0_F3A1))
    }

    /// Next 32 uniformly distributed bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(PCG_MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1), with 24 bits of resolution so that 1.0 is never returned.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Two uniform numbers in [0, 1)².
    #[inline]
    pub fn next_2d(&mut self) -> glam::Vec2 {
        let a = self.next_f32();
        let b = self.next_f32();
        glam::Vec2::new(a, b)
    }

    /// Uniform integer in [0, n) (n > 0) by Lemire's multiply-shift (bias < 2⁻³² · n).
    #[inline]
    pub fn next_below(&mut self, n: u32) -> u32 {
        ((self.next_u32() as u64 * n as u64) >> 32) as u32
    }
}

/// Sixteen [`Pcg32`] streams in SoA, the packet kernels' twin: each lane steps exactly as its
/// own generator would, and a lane outside a draw's mask keeps its state, so every path draws
/// its scalar sequence. One draw for all lanes is a few 16-lane integer operations instead of
/// sixteen dependent scalar chains.
#[derive(Clone, Copy, Debug)]
pub struct Pcg32x {
    state: [u64; W],
    inc: [u64; W],
}

const W: usize = crate::math::simd::WIDTH;

impl Pcg32x {
    /// Lane l takes the generator `gens[idx[l]]` for l < n; the others a placeholder.
    #[inline(always)]
    pub fn gather(gens: &[Pcg32], idx: &[usize; W], n: usize) -> Pcg32x {
        let mut r = Pcg32x {
            state: [Pcg32::PLACEHOLDER.state; W],
            inc: [Pcg32::PLACEHOLDER.inc; W],
        };
        for l in 0..n.min(W) {
            let g = &gens[idx[l]];
            r.state[l] = g.state;
            r.inc[l] = g.inc;
        }
        r
    }

    /// [`Pcg32::for_sample`] per lane: the streams of (`pixel[l]`, `sample[l]`) of a render with
    /// `seed` (the packet integrator seeds its refills 16 at a time).
    #[inline(always)]
    pub fn for_samples(seed: u64, pixel: &[u64; W], sample: &[u64; W]) -> Pcg32x {
        let mut r = Pcg32x {
            state: [0; W],
            inc: [0; W],
        };
        for l in 0..W {
            let key = mix64(seed ^ mix64(pixel[l] ^ mix64(sample[l])));
            let stream = mix64(key ^ 0xDA44_2D24_C9D0_F3A1);
            // Pcg32::new(key, stream): a step from state 0 (to inc), + key, another step.
            let inc = (stream << 1) | 1;
            r.state[l] = inc
                .wrapping_add(key)
                .wrapping_mul(PCG_MULT)
                .wrapping_add(inc);
            r.inc[l] = inc;
        }
        r
    }

    /// Lane `l` as a scalar generator.
    #[inline(always)]
    pub fn lane(&self, l: usize) -> Pcg32 {
        Pcg32 {
            state: self.state[l],
            inc: self.inc[l],
        }
    }

    /// Writes lanes 0..n back to `gens[idx[l]]`.
    #[inline(always)]
    pub fn scatter(&self, gens: &mut [Pcg32], idx: &[usize; W], n: usize) {
        for l in 0..n.min(W) {
            gens[idx[l]] = self.lane(l);
        }
    }

    /// [`Pcg32::next_f32`] in the lanes of `m` (the others' streams do not move and their
    /// values are meaningless).
    #[inline(always)]
    pub fn next_f32(&mut self, m: &[bool; W]) -> [f32; W] {
        let mut out = [0.0f32; W];
        for l in 0..W {
            let old = self.state[l];
            let new = old.wrapping_mul(PCG_MULT).wrapping_add(self.inc[l]);
            self.state[l] = if m[l] { new } else { old };
            let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
            let rot = (old >> 59) as u32;
            out[l] = (xorshifted.rotate_right(rot) >> 8) as f32 * (1.0 / 16_777_216.0);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each lane of the SoA streams draws its scalar generator's numbers, bit for bit, under
    /// random masks.
    #[test]
    fn soa_streams_follow_their_scalar_generators() {
        let mut gens: Vec<Pcg32> = (0..40).map(|k| Pcg32::for_sample(5, k, 3)).collect();
        let mut want = gens.clone();
        let idx: [usize; W] = std::array::from_fn(|l| 39 - 2 * l);
        let mut masks = Pcg32::new(1, 2);
        for n in [W, 9, 1] {
            let mut x = Pcg32x::gather(&gens, &idx, n);
            for _ in 0..50 {
                let m: [bool; W] = std::array::from_fn(|_| masks.next_u32() & 3 != 0);
                let got = x.next_f32(&m);
                for l in 0..n {
                    if m[l] {
                        let w = want[idx[l]].next_f32();
                        assert_eq!(got[l].to_bits(), w.to_bits(), "n {n} lane {l}");
                    }
                }
            }
            x.scatter(&mut gens, &idx, n);
            for l in 0..n {
                assert_eq!(gens[idx[l]].state, want[idx[l]].state);
            }
        }
        let pixel: [u64; W] = std::array::from_fn(|l| 1000 * l as u64 + 7);
        let sample: [u64; W] = std::array::from_fn(|l| (l as u64) % 3);
        let x = Pcg32x::for_samples(42, &pixel, &sample);
        for l in 0..W {
            let (a, b) = (x.lane(l), Pcg32::for_sample(42, pixel[l], sample[l]));
            assert_eq!((a.state, a.inc), (b.state, b.inc), "lane {l}");
        }
    }

    #[test]
    fn same_key_same_stream_and_unit_interval() {
        let mut a = Pcg32::for_sample(7, 123, 4);
        let mut b = Pcg32::for_sample(7, 123, 4);
        let mut c = Pcg32::for_sample(7, 123, 5);
        let mut differ = false;
        let mut mean = 0.0f64;
        for _ in 0..10_000 {
            let x = a.next_f32();
            assert_eq!(x, b.next_f32());
            assert!((0.0..1.0).contains(&x));
            differ |= x != c.next_f32();
            mean += x as f64;
        }
        assert!(differ);
        assert!((mean / 10_000.0 - 0.5).abs() < 0.02);
    }
}
