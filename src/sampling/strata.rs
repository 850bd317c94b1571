//! Stratified vertex draws: the radiance samples of one pixel spread evenly over every
//! dimension a path vertex draws, not only over the pixel's area (DESIGN.md, "Random
//! numbers"; mirrored in `shaders/strata.wgsl`).
//!
//! Sample `i` of a pixel's `N` (the stream rule's `j·n + k`) takes, in each dimension of
//! each vertex, the stratum `π(i)` of a pseudo-random permutation `π` of `0..M` (M = N, at
//! most [`STRATA_MAX`]) and places itself inside that stratum with the stream's own draw:
//! `u = (π(i) + ξ) / M`. In 2D (the light point, the BSDF direction) a square M = s² is an
//! s × s grid of cells, `(π(i) mod s + ξa, π(i) div s + ξb) / s`; any other M stratifies
//! each axis on its own (a Latin hypercube). Each permutation is chosen by a key hashed from
//! the tracer's seed, the pixel, the block of M samples, the bounce and the dimension, so
//! nothing is stored and dimensions are not correlated with each other or with the
//! camera's strata. Each sample stays uniform on its own (π(i) is uniform over the strata
//! for a random key), so every estimator stays unbiased, also when a render stops early or
//! renders only a range of the samples; what stratification adds is that the N samples of a
//! pixel together cover each dimension evenly, as Mitsuba's `stratified` and pbrt's
//! stratified samplers do. `N = 1` leaves the draws as the stream gave them.

use super::hash32;
use crate::scene::PcgSeed;

/// Most strata per dimension: a pixel with more samples stratifies each run of `STRATA_MAX`
/// samples on its own. 2¹⁶ strata leave 8 of f32's 24 bits for the position inside a
/// stratum, as fine as the stream's own floats.
pub const STRATA_MAX: u32 = 1 << 16;

/// Strata per dimension for a pixel of `samples` radiance samples (camera samples times
/// the path tracer's paths per sample): between 1 and [`STRATA_MAX`].
pub fn strata_count(samples: u64) -> u32 {
    samples.clamp(1, u64::from(STRATA_MAX)) as u32
}

/// The stratum of element `i` (< `n`) under the permutation of `0..n` that `key` picks.
///
/// A four-round Feistel network on the smallest power-of-two range holding `0..n` (its
/// bits split into a low and a high part; each round replaces the high part by itself
/// xor a hash of the low part and the round's key, then swaps the parts, which makes
/// every round a bijection whatever the hash), walked until it lands inside `0..n`
/// ("cycle walking": the walk ends because the orbit of `i` returns to `i`, and takes
/// fewer than two steps on average, since `n` fills more than half the range), then
/// rotated by a keyed offset modulo `n`.
///
/// ```
/// use lumen::sampling::permute;
/// let mut seen: Vec<u32> = (0..10).map(|i| permute(i, 10, 0xBEEF)).collect();
/// seen.sort();
/// assert_eq!(seen, (0..10).collect::<Vec<_>>());
/// ```
pub fn permute(i: u32, n: u32, key: u32) -> u32 {
    if n <= 1 {
        return 0;
    }
    let bits = 32 - (n - 1).leading_zeros();
    // Low part: `low` bits, then `bits - low` after each swap.
    let (a, b) = (bits / 2, bits - bits / 2);
    let mut x = i & (u32::MAX >> (32 - bits));
    loop {
        for round in 0..4u32 {
            let low = if round % 2 == 0 { a } else { b };
            let high = bits - low;
            let lo = x & ((1 << low) - 1);
            let hi = x >> low;
            let f = hash32(lo ^ key.wrapping_add(round.wrapping_mul(0x9E37_79B9)));
            x = (lo << high) | ((hi ^ f) & ((1 << high) - 1));
        }
        if x < n {
            // A rotation by a number of its own makes each element's place exactly uniform
            // over keys, whatever bias the few rounds leave on small ranges.
            return (x + hash32(key ^ 0x5851_F42D) % n) % n;
        }
    }
}

/// One word from the tracer's whole seed, for the permutation keys.
pub fn seed_word(seed: PcgSeed) -> u32 {
    let s = [seed.state as u32, (seed.state >> 32) as u32, seed.inc as u32, (seed.inc >> 32) as u32];
    hash32(s[0] ^ hash32(s[1] ^ hash32(s[2] ^ hash32(s[3]))))
}

/// The strata of one path vertex: where its sample falls in each dimension's permutation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VertexStrata {
    /// Strata per dimension (M).
    count: u32,
    /// s with s² = M, or 0 when M is not a square.
    side: u32,
    /// This sample's index among its block's M.
    index: u32,
    /// Key of this (seed, pixel, block, bounce); dimension d's key is `hash32(base ^ d)`.
    base: u32,
}

impl VertexStrata {
    /// Sample `sample` (the stream rule's `j·n + k`) of pixel `pixel` at vertex `bounce`,
    /// with `count` strata per dimension ([`strata_count`]); `seed_word` = [`seed_word`].
    pub fn new(seed_word: u32, pixel: u32, sample: u32, bounce: u32, count: u32) -> Self {
        let count = count.clamp(1, STRATA_MAX);
        let side = count.isqrt();
        let (block, index) = (sample / count, sample % count);
        let base = hash32(hash32(hash32(pixel ^ seed_word) ^ block) ^ bounce);
        Self { count, side: if side * side == count { side } else { 0 }, index, base }
    }

    fn stratum(&self, dimension: u32) -> u32 {
        permute(self.index, self.count, hash32(self.base ^ dimension))
    }

    /// Dimension `dimension`'s uniform: the stream's 24-bit draw `x` (`next_u32() >> 8`)
    /// moved into this sample's stratum, on the same 24-bit grid ([`in_stratum`]).
    pub fn one(&self, dimension: u32, x: u32) -> f64 {
        unit(in_stratum(self.stratum(dimension), self.count, x))
    }

    /// Dimensions `dimension` and `dimension + 1` as one 2D point: a cell of the s × s grid
    /// when M is a square, else each axis stratified on its own.
    pub fn two(&self, dimension: u32, x: [u32; 2]) -> [f64; 2] {
        if self.side == 0 {
            return [self.one(dimension, x[0]), self.one(dimension + 1, x[1])];
        }
        let cell = self.stratum(dimension);
        let s = self.side;
        [unit(in_stratum(cell % s, s, x[0])), unit(in_stratum(cell / s, s, x[1]))]
    }
}

/// ⌊(c·2²⁴ + x) / m⌋ for stratum `c` < `m` ≤ 2¹⁶ and a 24-bit draw `x`: the draw's place in
/// stratum c of m on the grid of 2⁻²⁴ steps the stream's floats use (each stratum's start
/// rounded down to it). In u32 arithmetic only (with 2²⁴ = q·m + r: c·q, then c·r split
/// into whole multiples of m and a remainder), so WGSL computes the same bits, and a draw
/// is exact in f32 and f64 alike.
pub fn in_stratum(c: u32, m: u32, x: u32) -> u32 {
    const T: u32 = 1 << 24;
    let (q, r) = (T / m, T % m);
    // c·r < m² ≤ 2³²; y % m + x < 2¹⁶ + 2²⁴.
    let y = c * r;
    c * q + y / m + (y % m + x) / m
}

/// A 24-bit draw as a float in [0, 1): exact in f32 and f64.
fn unit(u: u32) -> f64 {
    f64::from(u) * (1.0 / 16_777_216.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn permutations_are_bijections() {
        for n in (1..=70).chain([100, 127, 128, 129, 1000, 4096, 4097, STRATA_MAX]) {
            for key in [0u32, 1, 0xDEAD_BEEF, u32::MAX, 0x8000_0000] {
                let mut hit = vec![false; n as usize];
                for i in 0..n {
                    let p = permute(i, n, key);
                    assert!(p < n, "n {n} key {key:#x}: {i} -> {p}");
                    assert!(!hit[p as usize], "n {n} key {key:#x}: {p} twice");
                    hit[p as usize] = true;
                }
            }
        }
    }

    /// Over many keys, where an element lands is uniform (a chi-square test at a fixed
    /// seed; the bound is far above the 99.9th percentile) and two elements' places are
    /// not tied to each other: the permutation is not a shift or a fixed pattern.
    #[test]
    fn places_are_uniform_over_keys() {
        for n in [3u32, 7, 64, 100] {
            let keys = 20_000u32;
            for i in [0, n / 2, n - 1] {
                let mut counts = vec![0u32; n as usize];
                for k in 0..keys {
                    counts[permute(i, n, hash32(k)) as usize] += 1;
                }
                let expected = f64::from(keys) / f64::from(n);
                let chi2: f64 = counts.iter().map(|&c| (f64::from(c) - expected).powi(2) / expected).sum();
                let dof = f64::from(n - 1);
                assert!(chi2 < dof + 6.0 * (2.0 * dof).sqrt() + 10.0, "n {n} element {i}: chi² {chi2:.1}");
            }
            // The difference of two neighbours' places is spread too, not one value.
            let mut diffs = vec![0u32; n as usize];
            for k in 0..keys {
                let (a, b) = (permute(0, n, hash32(k)), permute(1, n, hash32(k)));
                diffs[((b + n - a) % n) as usize] += 1;
            }
            let most = *diffs.iter().max().unwrap();
            assert!(f64::from(most) < 3.0 * f64::from(keys) / f64::from(n - 1), "n {n}: {diffs:?}");
        }
    }

    /// The N samples of a pixel fill every stratum of every dimension exactly once: the
    /// 1D strata, the cells of a square grid, and both axes of a Latin hypercube.
    #[test]
    fn a_pixels_samples_cover_each_dimension_once() {
        let word = seed_word(PcgSeed::default());
        for (count, bounce) in [(64u32, 0u32), (48, 3), (9, 1), (2, 0), (STRATA_MAX, 2)] {
            let strata: Vec<VertexStrata> = (0..count).map(|i| VertexStrata::new(word, 77, i, bounce, count)).collect();
            for d in 0..7 {
                let mut hit = vec![false; count as usize];
                for v in &strata {
                    let u = v.one(d, 1 << 23);
                    let cell = (u * f64::from(count)) as usize;
                    assert!(!hit[cell], "count {count} dimension {d}: stratum {cell} twice");
                    hit[cell] = true;
                }
            }
            let side = count.isqrt();
            for d in [1, 4] {
                let points: Vec<[f64; 2]> = strata.iter().map(|v| v.two(d, [1 << 23, 1 << 23])).collect();
                if side * side == count {
                    let mut hit = vec![false; count as usize];
                    for p in &points {
                        let cell =
                            (p[1] * f64::from(side)) as usize * side as usize + (p[0] * f64::from(side)) as usize;
                        assert!(!hit[cell], "count {count}: cell {cell} twice");
                        hit[cell] = true;
                    }
                } else {
                    for axis in 0..2 {
                        let mut rows: Vec<usize> =
                            points.iter().map(|p| (p[axis] * f64::from(count)) as usize).collect();
                        rows.sort_unstable();
                        assert_eq!(rows, (0..count as usize).collect::<Vec<_>>(), "count {count} axis {axis}");
                    }
                }
            }
        }
    }

    /// Dimensions, bounces, pixels, blocks and seeds get permutations of their own.
    #[test]
    fn keys_differ_per_dimension_bounce_pixel_block_and_seed() {
        let count = 64;
        let order =
            |v: &dyn Fn(u32) -> VertexStrata, d: u32| -> Vec<u32> { (0..count).map(|i| v(i).stratum(d)).collect() };
        let w = seed_word(PcgSeed::default());
        let other = seed_word(PcgSeed { state: 1, inc: 2 });
        let base = order(&|i| VertexStrata::new(w, 5, i, 0, count), 0);
        assert_ne!(base, order(&|i| VertexStrata::new(w, 5, i, 0, count), 1));
        assert_ne!(base, order(&|i| VertexStrata::new(w, 5, i, 1, count), 0));
        assert_ne!(base, order(&|i| VertexStrata::new(w, 6, i, 0, count), 0));
        assert_ne!(base, order(&|i| VertexStrata::new(w, 5, i + count, 0, count), 0));
        assert_ne!(base, order(&|i| VertexStrata::new(other, 5, i, 0, count), 0));
    }

    /// The integer placement is the exact floor of (c·2²⁴ + x)/m, also where c·r is
    /// near 2³² and at the edges of the range.
    #[test]
    fn placement_in_a_stratum_is_the_exact_floor() {
        for m in [1u32, 2, 3, 7, 48, 64, 1000, 4095, 65521, 65535, STRATA_MAX] {
            for c in [0, 1, m / 2, m.saturating_sub(2), m - 1].into_iter().filter(|&c| c < m) {
                for x in [0u32, 1, 12_345, (1 << 23) + 7, (1 << 24) - 1] {
                    let want = ((u64::from(c) << 24) + u64::from(x)) / u64::from(m);
                    assert_eq!(u64::from(in_stratum(c, m, x)), want, "c {c} m {m} x {x}");
                    assert!(want < 1 << 24);
                }
            }
        }
    }

    /// One sample per pixel is not stratified: the stream's draw is kept as it is.
    #[test]
    fn one_sample_keeps_the_streams_draws() {
        let v = VertexStrata::new(seed_word(PcgSeed::default()), 3, 0, 0, strata_count(1));
        assert_eq!(v.one(0, 6 << 20), 0.375);
        assert_eq!(v.two(1, [4 << 20, 10 << 20]), [0.25, 0.625]);
        assert_eq!(strata_count(0), 1);
        assert_eq!(strata_count(u64::MAX), STRATA_MAX);
    }
}
