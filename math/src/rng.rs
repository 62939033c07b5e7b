//! Random streams keyed by (seed, stream, id, tick).
//!
//! Every random draw of a mission comes from an RNG built here from the mission seed and
//! the *identity* of the draw (what it is for, which vehicle or link, which tick), never
//! from a shared RNG consumed in arrival order. That is what makes a lockstep run
//! independent of OS scheduling and lets the in-process simulator and the multi-process
//! system draw exactly the same numbers (docs/ARCHITECTURE.md §4).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// What a random draw is for. The discriminant is part of the key: never reorder.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u64)]
pub enum Stream {
    /// Sensor noise of vehicle `id` at tick `tick`.
    SensorNoise = 1,
    /// Initial position of vehicle `id` (tick 0).
    InitialPosition = 2,
    /// Link model: delay, jitter, loss of message `tick` on link `id`.
    Link = 3,
    /// Multi-start points of the optimal formation search.
    FormationSearch = 4,
    /// Acoustic channel: transmission offsets (`id` = 2·sender, `tick` = transmission
    /// number) and decoding draws (`id` = 1 + 2·(sender·1024 + receiver)).
    Acoustic = 5,
    /// Anything a test needs.
    Test = 99,
}

/// SplitMix64 finaliser: a bijective mix of 64 bits with good avalanche.
const fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The 256-bit ChaCha seed for the key (seed, stream, id, tick).
pub fn key(seed: u64, stream: Stream, id: u64, tick: u64) -> [u8; 32] {
    let mut out = [0u8; 32];
    let mut h = mix64(seed ^ 0x5eed_0000_0000_0000);
    for (i, part) in [stream as u64, id, tick, 0x76_62_61_70]
        .into_iter()
        .enumerate()
    {
        h = mix64(h ^ part.wrapping_add(0x9e37_79b9_7f4a_7c15u64.wrapping_mul(i as u64 + 1)));
        out[i * 8..i * 8 + 8].copy_from_slice(&h.to_le_bytes());
    }
    out
}

/// A fresh RNG for one keyed draw (or a few draws belonging together).
pub fn keyed(seed: u64, stream: Stream, id: u64, tick: u64) -> ChaCha8Rng {
    ChaCha8Rng::from_seed(key(seed, stream, id, tick))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    #[test]
    fn same_key_same_numbers_different_key_different_numbers() {
        let a: f64 = keyed(7, Stream::SensorNoise, 3, 10).random();
        let b: f64 = keyed(7, Stream::SensorNoise, 3, 10).random();
        let c: f64 = keyed(7, Stream::SensorNoise, 3, 11).random();
        let d: f64 = keyed(7, Stream::SensorNoise, 4, 10).random();
        let e: f64 = keyed(8, Stream::SensorNoise, 3, 10).random();
        let f: f64 = keyed(7, Stream::Link, 3, 10).random();
        assert_eq!(a, b);
        for other in [c, d, e, f] {
            assert_ne!(a, other);
        }
    }
}
