//! The dataset's random numbers: what run `i` draws depends on the master seed and `i` alone.
//!
//! - **Seed of run `i`**: `run_seed(master, i) = mix(mix(master) ^ mix(i + φ))`, with `mix` the
//!   SplitMix64 finalizer (Steele, Lea & Flood 2014; Stafford's "Mix13" constants) and
//!   `φ = 0x9E3779B97F4A7C15`. No state is carried from one run to the next, so a run's values
//!   do not depend on the run count, the chunking, the shard, the thread count or the order.
//! - **One stream per varied key**: each `[vary]` key draws from its own generator seeded with
//!   `run_seed ^ fnv1a64(key)`, so adding or removing a key leaves the other keys' values alone.
//! - **Generator**: xoshiro256** (Blackman & Vigna 2018), its 256-bit state filled from the
//!   seed by SplitMix64, as its authors recommend.
//! - **Floats**: `u ∈ [0, 1)` from the top 53 bits (`(x >> 11) · 2⁻⁵³`). The transcendental
//!   functions of the samplers (`ln`, `exp`, `sin`, `cos`) come from the `libm` crate (a pure-Rust
//!   port of musl's libm), not the platform's, so every draw is bit-identical on every machine.

/// The golden-ratio increment of SplitMix64.
const PHI: u64 = 0x9E37_79B9_7F4A_7C15;

/// SplitMix64's output function: a bijective 64-bit mixer.
pub fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The seed of run `run` of a dataset with master seed `master`.
pub fn run_seed(master: u64, run: u64) -> u64 {
    mix(mix(master) ^ mix(run.wrapping_add(PHI)))
}

/// FNV-1a, 64 bit: the fixed hash naming a key's stream.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xCBF2_9CE4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01B3)
    })
}

/// xoshiro256**: 256-bit state, period 2²⁵⁶ − 1.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Rng {
    s: [u64; 4],
}

impl Rng {
    /// The state filled by SplitMix64 from `seed` (never all zero).
    pub fn new(seed: u64) -> Self {
        let mut x = seed;
        let mut next = || {
            x = x.wrapping_add(PHI);
            mix(x)
        };
        Self {
            s: [next(), next(), next(), next()],
        }
    }

    /// The stream of `key` in the run with seed `run_seed`.
    pub fn for_key(run_seed: u64, key: &str) -> Self {
        Self::new(run_seed ^ fnv1a64(key.as_bytes()))
    }

    pub fn next_u64(&mut self) -> u64 {
        let s = &mut self.s;
        let result = s[1].wrapping_mul(5).rotate_left(7).wrapping_mul(9);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
    }

    /// Uniform in `[0, 1)`, a multiple of 2⁻⁵³.
    pub fn uniform01(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `{0, ..., n - 1}` (Lemire's multiply-shift; the bias, at most `n / 2⁶⁴`, is
    /// irrelevant for the handful of choices a spec lists). `n` must be positive.
    pub fn below(&mut self, n: u64) -> u64 {
        ((u128::from(self.next_u64()) * u128::from(n)) >> 64) as u64
    }

    /// Standard normal by Box–Muller (one output per pair of uniforms): `√(−2 ln u₁) cos(2π u₂)`,
    /// `u₁ ∈ (0, 1]`.
    pub fn standard_normal(&mut self) -> f64 {
        let u1 = 1.0 - self.uniform01();
        let u2 = self.uniform01();
        libm::sqrt(-2.0 * libm::log(u1)) * libm::cos(std::f64::consts::TAU * u2)
    }

    /// A uniformly distributed unit quaternion `[x, y, z, w]` (Shoemake 1992, "Uniform random
    /// rotations", Graphics Gems III): with `u₁, u₂, u₃ ~ U[0, 1)`,
    /// `q = (√(1−u₁) sin 2πu₂, √(1−u₁) cos 2πu₂, √u₁ sin 2πu₃, √u₁ cos 2πu₃)`.
    pub fn unit_quaternion_xyzw(&mut self) -> [f64; 4] {
        use std::f64::consts::TAU;
        let (u1, u2, u3) = (self.uniform01(), self.uniform01(), self.uniform01());
        let (a, b) = (libm::sqrt(1.0 - u1), libm::sqrt(u1));
        [
            a * libm::sin(TAU * u2),
            a * libm::cos(TAU * u2),
            b * libm::sin(TAU * u3),
            b * libm::cos(TAU * u3),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The published xoshiro256** reference: state {1, 2, 3, 4} gives 11520, 0, 1509978240,
    /// 1215971899390074240 (Vigna's xoshiro256starstar.c).
    #[test]
    fn xoshiro_matches_the_reference_output() {
        let mut rng = Rng { s: [1, 2, 3, 4] };
        let got: Vec<u64> = (0..4).map(|_| rng.next_u64()).collect();
        assert_eq!(got, [11520, 0, 1509978240, 1215971899390074240]);
    }

    /// SplitMix64 from seed 1234567: 6457827717110365317, 3203168211198807973 (the reference
    /// implementation's first two outputs).
    #[test]
    fn splitmix_matches_the_reference_output() {
        let mut x: u64 = 1234567;
        let mut next = || {
            x = x.wrapping_add(PHI);
            mix(x)
        };
        assert_eq!(next(), 6457827717110365317);
        assert_eq!(next(), 3203168211198807973);
    }

    #[test]
    fn run_seeds_differ_and_are_pure() {
        let seeds: std::collections::HashSet<u64> = (0..10_000).map(|i| run_seed(42, i)).collect();
        assert_eq!(seeds.len(), 10_000);
        assert_eq!(run_seed(42, 7), run_seed(42, 7));
        assert_ne!(run_seed(42, 7), run_seed(43, 7));
    }

    #[test]
    fn below_stays_in_range_and_hits_every_value() {
        let mut rng = Rng::new(1);
        let mut seen = [0u32; 5];
        for _ in 0..1000 {
            seen[rng.below(5) as usize] += 1;
        }
        // Each value expects 200 hits, std √(1000·0.2·0.8) ≈ 12.6: 100 is ≈ 8 std away.
        assert!(seen.iter().all(|&n| n > 100), "{seen:?}");
    }

    #[test]
    fn quaternions_are_unit() {
        let mut rng = Rng::new(9);
        for _ in 0..1000 {
            let q = rng.unit_quaternion_xyzw();
            let n: f64 = q.iter().map(|x| x * x).sum();
            // sin² + cos² and (1−u) + u in floating point: a few ulp (measured ≤ 4.5e-16).
            assert!((n - 1.0).abs() < 1e-15, "{n}");
        }
    }
}
