//! Stratified vertex draws: the radiance samples of one pixel spread evenly over every
//! dimension a path vertex draws, not only over the pixel's area (DESIGN.md, "Stratified
//! vertex draws"; mirrored in `shaders/strata.wgsl`).
//!
//! A pixel's `N` samples (the stream rule's `j·n + k`) form blocks of M = 2^k, the largest
//! power of two ≤ N (at most [`STRATA_MAX`]). Sample `i` takes, in each dimension of each
//! vertex, stratum `π(i mod M)` of a pseudo-random permutation π of `0..M` and places
//! itself inside it with the stream's own 24-bit draw: `u = (π + ξ) / M`. In 2D (the light
//! point, the BSDF direction) the strata are the cells of a 2^⌈k/2⌉ × 2^⌊k/2⌋ grid. Each
//! permutation is picked by a key hashed from the tracer's seed, the pixel, the block, the
//! bounce and the dimension: nothing is stored, and dimensions are not correlated with
//! each other or with the camera's strata. Each sample stays uniform on its own (its
//! stratum is uniform over keys), so every estimator stays unbiased, also when a render
//! stops early or renders only a range of the samples; what stratification adds is that
//! each block of samples covers every dimension evenly, as Mitsuba's `stratified` and
//! pbrt's stratified samplers do. `N = 1` leaves the draws as the stream gave them.
//!
//! Why powers of two: every step is then a mask or a shift, exact in u32 on both devices
//! and cheap in a SIMD shading kernel. A first form with M = N (any count) needed integer
//! divisions and a cycle-walking loop, which llvmpipe scalarises lane by lane: it made
//! whole GPU renders 40–50 % slower (BENCHMARKS.md, "Stratified vertex draws").

use super::{hash32, unit24};
use crate::scene::PcgSeed;

/// Most strata per dimension: a pixel with more samples stratifies each block of
/// `STRATA_MAX` on its own. 2¹⁶ strata leave 8 of the stream's 24 bits for the place
/// inside a stratum.
pub const STRATA_MAX: u32 = 1 << 16;

/// log₂ of the strata per dimension (M = 2^k) for a pixel of `samples` radiance samples
/// (camera samples times the path tracer's paths per sample): the largest power of two
/// not above `samples`, at most [`STRATA_MAX`]; 0 for 0 or 1 sample.
pub fn strata_bits(samples: u64) -> u32 {
    let m = samples.clamp(1, u64::from(STRATA_MAX));
    63 - m.leading_zeros()
}

/// The stratum of element `i` under the permutation of `0..2^bits` that `key` picks.
///
/// Four rounds of bijections of the `bits`-bit integers, each a keyed xor or addition, a
/// multiplication by an odd number (whose carries move low bits into high ones; the first
/// and third multipliers are keyed) and an xor of the value with its upper half shifted
/// down (high bits into low ones), all modulo 2^bits; xors and additions alternate so that
/// carries keep the rounds from composing into one linear map. The rounds read only the
/// key's low 16 bits and its high 16 bits rotate the result modulo 2^bits, so for a
/// uniform key and `bits` ≤ 16 (every caller's: [`STRATA_MAX`], the camera's strata per
/// axis) each element's place is exactly uniform, whatever structure the rounds leave.
/// Each step is one SIMD instruction for a group of lanes; the four-round Feistel network
/// this replaced hashed five times per permutation for the same pairing quality (the tests
/// below; BENCHMARKS "A cheaper strata permutation").
///
/// ```
/// use lumen::sampling::permute;
/// let mut seen: Vec<u32> = (0..16).map(|i| permute(i, 4, 0xBEEF)).collect();
/// seen.sort();
/// assert_eq!(seen, (0..16).collect::<Vec<_>>());
/// ```
pub fn permute(i: u32, bits: u32, key: u32) -> u32 {
    if bits == 0 {
        return 0;
    }
    let mask = u32::MAX >> (32 - bits);
    // At least 1, so each xor-shift moves a high bit down (a no-op only for 1 bit).
    let half = bits.div_ceil(2);
    let s = key & 0xFFFF;
    let mut x = i & mask;
    x = (x ^ s).wrapping_mul((s >> 3) | 1) & mask;
    x ^= x >> half;
    x = x.wrapping_add(s >> 5).wrapping_mul(0x2C1B_3C6D) & mask;
    x ^= x >> half;
    x = (x ^ (s >> 9)).wrapping_mul((s >> 6) | 1) & mask;
    x ^= x >> half;
    x = x.wrapping_add(s >> 2).wrapping_mul(0x297A_2D39) & mask;
    x ^= x >> half;
    x.wrapping_add(key >> 16) & mask
}

/// Element `i` (< `n`) under the permutation of `0..n` that `key` picks, for any `n` ≥ 1:
/// [`permute`] on the smallest power of two ≥ n, applied again until the result falls below
/// n (cycle walking: the cycle through i comes back below n, so this ends, after fewer
/// than two steps on average). For the camera's multi-jittered samples
/// (`prepare::PixelSamples`), once per camera sample: the per-vertex draws keep powers of
/// two, whose permutations need no loop.
///
/// ```
/// use lumen::sampling::permute_below;
/// let mut seen: Vec<u32> = (0..11).map(|i| permute_below(i, 11, 0xBEEF)).collect();
/// seen.sort();
/// assert_eq!(seen, (0..11).collect::<Vec<_>>());
/// ```
pub fn permute_below(i: u32, n: u32, key: u32) -> u32 {
    if n <= 1 {
        return 0;
    }
    let bits = 32 - (n - 1).leading_zeros();
    let mut x = permute(i, bits, key);
    while x >= n {
        x = permute(x, bits, key);
    }
    x
}

/// ⌊(c·2²⁴ + x) / 2^bits⌋: the 24-bit draw `x` placed in stratum `c` of 2^bits, on the
/// stream's grid of 2⁻²⁴ steps (so exact in f32 and f64).
pub fn in_stratum(c: u32, bits: u32, x: u32) -> u32 {
    (c << (24 - bits)) | (x >> bits)
}

/// One word from the tracer's whole seed, for the permutation keys.
pub fn seed_word(seed: PcgSeed) -> u32 {
    let s = seed.words();
    hash32(s[0] ^ hash32(s[1] ^ hash32(s[2] ^ hash32(s[3]))))
}

/// The strata of one path vertex: where its sample falls in each dimension's permutation.
///
/// ```
/// use lumen::sampling::{seed_word, strata_bits, VertexStrata};
/// use lumen::scene::PcgSeed;
/// // The 16 samples of pixel 7 at bounce 0: each takes a different sixteenth of
/// // dimension 0, whatever the stream draws inside it (here its middle).
/// let (word, bits) = (seed_word(PcgSeed::default()), strata_bits(16));
/// let mut strata: Vec<u32> =
///     (0..16).map(|i| (VertexStrata::new(word, 7, i, 0, bits).draws([1 << 23; 7])[0] * 16.0) as u32).collect();
/// strata.sort();
/// assert_eq!(strata, (0..16).collect::<Vec<u32>>());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VertexStrata {
    /// k: 2^k strata per dimension.
    bits: u32,
    /// This sample's index in its block of 2^k.
    index: u32,
    /// Key of this (seed, pixel, block, bounce); dimension d's key is `hash32(base ^ d)`.
    base: u32,
}

impl VertexStrata {
    /// Sample `sample` (the stream rule's `j·n + k`) of pixel `pixel` at vertex `bounce`,
    /// with 2^`bits` strata per dimension ([`strata_bits`]); `seed_word` = [`seed_word`].
    pub fn new(seed_word: u32, pixel: u32, sample: u32, bounce: u32, bits: u32) -> Self {
        let bits = bits.min(STRATA_MAX.trailing_zeros());
        let (block, index) = (sample >> bits, sample & ((1 << bits) - 1));
        let base = hash32(hash32(hash32(pixel ^ seed_word) ^ block) ^ bounce);
        Self { bits, index, base }
    }

    fn stratum(&self, dimension: u32) -> u32 {
        permute(self.index, self.bits, hash32(self.base ^ dimension))
    }

    /// The seven draws of a path vertex: the stream's 24-bit draws `x` (`next_u32() >> 8`)
    /// moved into this sample's strata ([`in_stratum`]). Dimensions 0, 3 and 6 are 1D;
    /// (1, 2) and (4, 5) are cells of the 2^⌈k/2⌉ × 2^⌊k/2⌋ grid, whose second coordinate
    /// reuses the cell its first one drew. `shaders/strata.wgsl`'s `stratified_draws` is
    /// this loop, line for line.
    pub fn draws(&self, x: [u32; 7]) -> [f64; 7] {
        let k = self.bits;
        let across = k.div_ceil(2);
        let mut xi = [0.0; 7];
        let mut cell = 0;
        for d in 0..7u32 {
            let second = d == 2 || d == 5;
            if !second {
                cell = self.stratum(d);
            }
            let (c, n) = if d == 1 || d == 4 {
                (cell & ((1 << across) - 1), across)
            } else if second {
                (cell >> across, k - across)
            } else {
                (cell, k)
            };
            xi[d as usize] = unit24(in_stratum(c, n, x[d as usize]));
        }
        xi
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn permutations_are_bijections() {
        for bits in 0..=16 {
            for key in [0u32, 1, 0xDEAD_BEEF, u32::MAX, 0x8000_0000] {
                let n = 1u32 << bits;
                let mut hit = vec![false; n as usize];
                for i in 0..n {
                    let p = permute(i, bits, key);
                    assert!(p < n, "bits {bits} key {key:#x}: {i} -> {p}");
                    assert!(!hit[p as usize], "bits {bits} key {key:#x}: {p} twice");
                    hit[p as usize] = true;
                }
            }
        }
    }

    /// Over many keys, where an element lands is uniform (a chi-square test at a fixed
    /// seed; the bound is far above the 99.9th percentile) and two elements' places are
    /// not tied to each other: the permutation is not a rotation or a fixed pattern.
    #[test]
    fn places_are_uniform_over_keys() {
        for bits in [1u32, 2, 3, 6, 7] {
            let (n, keys) = (1u32 << bits, 20_000u32);
            for i in [0, n / 2, n - 1] {
                let mut counts = vec![0u32; n as usize];
                for k in 0..keys {
                    counts[permute(i, bits, hash32(k)) as usize] += 1;
                }
                let expected = f64::from(keys) / f64::from(n);
                let chi2: f64 = counts.iter().map(|&c| (f64::from(c) - expected).powi(2) / expected).sum();
                let dof = f64::from(n - 1);
                assert!(chi2 < dof + 6.0 * (2.0 * dof).sqrt() + 10.0, "bits {bits} element {i}: chi² {chi2:.1}");
            }
            if n > 2 {
                // The gap between two neighbours' places is spread too, not one value.
                let mut gaps = vec![0u32; n as usize];
                for k in 0..keys {
                    let (a, b) = (permute(0, bits, hash32(k)), permute(1, bits, hash32(k)));
                    gaps[((b + n - a) % n) as usize] += 1;
                }
                let most = *gaps.iter().max().unwrap();
                assert!(f64::from(most) < 3.0 * f64::from(keys) / f64::from(n - 1), "bits {bits}: {gaps:?}");
            }
        }
    }

    /// Two dimensions' permutations pair their strata as two independent shuffles would:
    /// the points (π_a(i), π_b(i)) of a block fill as many cells of a coarse grid, on
    /// average over keys, as the points of two Fisher–Yates shuffles do (the oracle, drawn
    /// from a PCG stream). Rotations alone would put a block on one diagonal, affine
    /// maps on a lattice (too few cells or too many).
    #[test]
    fn two_dimensions_pair_like_independent_shuffles() {
        fn occupancy(bits: u32, a: &[u32], b: &[u32]) -> f64 {
            let h = bits / 2;
            let mut hit = vec![false; 1 << bits];
            for (&x, &y) in a.iter().zip(b) {
                hit[(((x >> (bits - h)) << (bits - h)) | (y >> h)) as usize] = true;
            }
            hit.iter().filter(|&&h| h).count() as f64 / hit.len() as f64
        }
        // The shuffles' generator: a PCG stream, which `permute` does not use.
        let mut rng = crate::sampling::Pcg32::new(0x853C_49E6_748F_EA9B, 0xDA3E_39CB_94B9_5BDB);
        let trials = 2000u32;
        for bits in [2u32, 4, 5, 6, 8, 10] {
            let n = 1u32 << bits;
            let (mut ours, mut shuffles) = (0.0, 0.0);
            for t in 0..trials {
                let (ka, kb) = (hash32(2 * t), hash32(2 * t + 1));
                let a: Vec<u32> = (0..n).map(|i| permute(i, bits, ka)).collect();
                let b: Vec<u32> = (0..n).map(|i| permute(i, bits, kb)).collect();
                ours += occupancy(bits, &a, &b);
                let mut shuffle = || {
                    let mut p: Vec<u32> = (0..n).collect();
                    for i in (1..n as usize).rev() {
                        p.swap(i, (rng.next_u32() % (i as u32 + 1)) as usize);
                    }
                    p
                };
                let (a, b) = (shuffle(), shuffle());
                shuffles += occupancy(bits, &a, &b);
            }
            let (ours, shuffles) = (ours / f64::from(trials), shuffles / f64::from(trials));
            assert!((ours - shuffles).abs() < 0.015, "bits {bits}: {ours:.4} of the cells, shuffles {shuffles:.4}");
        }
    }

    /// A block's samples fill every stratum of every dimension exactly once: the 1D strata
    /// and the cells of the 2D grid, square (k even) or 2:1 (k odd).
    #[test]
    fn a_blocks_samples_cover_each_dimension_once() {
        let word = seed_word(PcgSeed::default());
        for (bits, bounce, block) in [(6u32, 0u32, 0u32), (5, 3, 2), (3, 1, 0), (1, 0, 7), (16, 2, 1)] {
            let count = 1u32 << bits;
            let strata: Vec<VertexStrata> =
                (0..count).map(|i| VertexStrata::new(word, 77, block * count + i, bounce, bits)).collect();
            let draws: Vec<[f64; 7]> = strata.iter().map(|v| v.draws([1 << 23; 7])).collect();
            for d in [0, 3, 6] {
                let mut hit = vec![false; count as usize];
                for u in &draws {
                    let cell = (u[d] * f64::from(count)) as usize;
                    assert!(!hit[cell], "bits {bits} dimension {d}: stratum {cell} twice");
                    hit[cell] = true;
                }
            }
            let (across, down) = (1usize << bits.div_ceil(2), 1usize << (bits / 2));
            for d in [1, 4] {
                let mut hit = vec![false; count as usize];
                for u in &draws {
                    let cell = (u[d + 1] * down as f64) as usize * across + (u[d] * across as f64) as usize;
                    assert!(!hit[cell], "bits {bits}: cell {cell} twice");
                    hit[cell] = true;
                }
            }
        }
    }

    #[test]
    fn placement_is_the_exact_floor() {
        for bits in 0..=16u32 {
            for c in [0u32, 1, (1 << bits) / 2, (1 << bits) - 1].into_iter().filter(|&c| c < 1 << bits) {
                for x in [0u32, 1, 12_345, (1 << 23) + 7, (1 << 24) - 1] {
                    let want = ((u64::from(c) << 24) + u64::from(x)) >> bits;
                    assert_eq!(u64::from(in_stratum(c, bits, x)), want, "c {c} bits {bits} x {x}");
                }
            }
        }
    }

    /// Dimensions, bounces, pixels, blocks and seeds get permutations of their own.
    #[test]
    fn keys_differ_per_dimension_bounce_pixel_block_and_seed() {
        let bits = 6;
        let order =
            |v: &dyn Fn(u32) -> VertexStrata, d: u32| -> Vec<u32> { (0..64).map(|i| v(i).stratum(d)).collect() };
        let w = seed_word(PcgSeed::default());
        let other = seed_word(PcgSeed { state: 1, inc: 2 });
        let base = order(&|i| VertexStrata::new(w, 5, i, 0, bits), 0);
        assert_ne!(base, order(&|i| VertexStrata::new(w, 5, i, 0, bits), 1));
        assert_ne!(base, order(&|i| VertexStrata::new(w, 5, i, 1, bits), 0));
        assert_ne!(base, order(&|i| VertexStrata::new(w, 6, i, 0, bits), 0));
        assert_ne!(base, order(&|i| VertexStrata::new(w, 5, i + 64, 0, bits), 0));
        assert_ne!(base, order(&|i| VertexStrata::new(other, 5, i, 0, bits), 0));
    }

    /// One sample per pixel is not stratified: the stream's draw is kept as it is. Counts
    /// round down to powers of two.
    #[test]
    fn one_sample_keeps_the_streams_draws() {
        let v = VertexStrata::new(seed_word(PcgSeed::default()), 3, 0, 0, strata_bits(1));
        let x = [6 << 20, 4 << 20, 10 << 20, 1, 0, (1 << 24) - 1, 12 << 20];
        assert_eq!(v.draws(x), x.map(|x| f64::from(x) / 16_777_216.0));
        assert_eq!([strata_bits(0), strata_bits(1), strata_bits(2), strata_bits(3), strata_bits(64)], [0, 0, 1, 1, 6]);
        assert_eq!(strata_bits(100), 6);
        assert_eq!(strata_bits(u64::MAX), 16);
    }
}
