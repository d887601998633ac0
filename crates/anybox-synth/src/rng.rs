//! Deterministic randomness.
//!
//! Two kinds of streams, both independent of thread scheduling so that the same
//! [`crate::SynthConfig`] always yields the same bytes:
//! - sequential decisions (scene layout, camera placement) draw from a ChaCha8 stream seeded by a
//!   hash of `(seed, scene, view, purpose)`;
//! - per-pixel noise is a counter-based hash of `(view key, pixel index, purpose)`, so rows can be
//!   processed in parallel in any order.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// SplitMix64 finaliser (Steele, Lea & Flood 2014): a bijective 64-bit mixer.
#[inline]
pub(crate) fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Hash of three words.
#[inline]
pub(crate) fn hash3(a: u64, b: u64, c: u64) -> u64 {
    splitmix64(splitmix64(splitmix64(a) ^ b) ^ c)
}

/// Uniform in `[0, 1)` from a hash.
#[inline]
pub(crate) fn unit(h: u64) -> f64 {
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Standard normal sample from a hash (Box–Muller on two derived uniforms).
#[inline]
pub(crate) fn gauss(h: u64) -> f64 {
    let u1 = unit(splitmix64(h ^ 0x5151_5151)).max(1e-300);
    let u2 = unit(splitmix64(h ^ 0xA3A3_A3A3_0000));
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Cheap approximately normal sample (Irwin–Hall sum of four 16-bit uniforms, rescaled to unit
/// variance); for RGB sensor noise where the exact shape of the tails does not matter.
#[inline]
pub(crate) fn gauss_fast(h: u64) -> f64 {
    let s: u64 = (0..4).map(|i| (h >> (16 * i)) & 0xFFFF).sum();
    (s as f64 / 65536.0 - 2.0) * 3f64.sqrt()
}

/// Purposes, so that streams for different decisions never coincide.
pub(crate) mod purpose {
    pub const SCENE: u64 = 1;
    pub const CAMERA: u64 = 2;
    pub const NOISE: u64 = 3;
    pub const RGB: u64 = 4;
    pub const HOLES: u64 = 5;
}

/// A ChaCha8 stream for `(seed, scene, view, purpose)`.
pub(crate) fn stream(seed: u64, scene: u32, view: u32, purpose: u64) -> ChaCha8Rng {
    let key = hash3(seed, ((scene as u64) << 32) | view as u64, purpose);
    ChaCha8Rng::seed_from_u64(key)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_has_unit_variance() {
        let n = 200_000u64;
        let (mut s, mut s2) = (0.0, 0.0);
        for i in 0..n {
            let g = gauss(hash3(7, i, 3));
            s += g;
            s2 += g * g;
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((var - 1.0).abs() < 0.02, "var {var}");
    }
}
