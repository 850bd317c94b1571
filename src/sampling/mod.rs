//! Random numbers shared by the CPU reference and the GPU: PCG32 and the rule that gives
//! every (pixel, sample, bounce) its own stream.
//!
//! The rule (mirrored in `shaders/random.wgsl`):
//! 1. `key_lo = h(h(h(pixel) ^ sample) ^ bounce)` with `h` = [`hash32`] (a bijection on
//!    u32), `key_hi = h(key_lo ^ 0x9E37_79B9)`.
//! 2. The stream is `Pcg32::new(seed.state + (key_hi << 32 | key_lo), seed.inc)` (wrapping
//!    64-bit add), where `seed` is the tracer's `Pcg(.state, .inc)`.
//! 3. `pixel = row · width + col` over the whole image; `sample = j · n + i` for camera
//!    sample `j` and path `i` of the path tracer's `n` (n = 1 for other renderers);
//!    `bounce` is the path vertex index (0 = the camera ray's hit). The camera's own jitter
//!    uses sample `j` and bounce [`CAMERA_BOUNCE`].
//! 4. Floats are `(next_u32() >> 8) · 2⁻²⁴`: 24 bits, exact in f32 and f64, in [0, 1).
//! 5. A path vertex moves its draws into its sample's strata ([`VertexStrata`]), so that
//!    a pixel's samples together cover each dimension evenly.
//!
//! Because each stream depends only on these indices, images do not depend on thread
//! count, tile order or how samples are split into GPU passes.

pub mod distribution;
mod pcg;
mod strata;

pub use distribution::{Distribution1D, Distribution2D};
pub use pcg::{unit24, Pcg32};
pub use strata::{in_stratum, permute, permute_below, seed_word, strata_bits, VertexStrata, STRATA_MAX};

use crate::scene::PcgSeed;

/// Bounce index reserved for the camera's sub-pixel jitter stream.
pub const CAMERA_BOUNCE: u32 = u32::MAX;

/// A 32-bit integer hash with good avalanche (Wellons' "lowbias32"); a bijection.
pub const fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// The stream for one (pixel, sample, bounce), per the rule above.
///
/// ```
/// use lumen::sampling::stream;
/// use lumen::scene::PcgSeed;
/// let mut a = stream(PcgSeed::default(), 10, 3, 0);
/// let mut b = stream(PcgSeed::default(), 10, 3, 0);
/// assert_eq!(a.next_u32(), b.next_u32());
/// let x = a.next_f64();
/// assert!((0.0..1.0).contains(&x));
/// ```
pub fn stream(seed: PcgSeed, pixel: u32, sample: u32, bounce: u32) -> Pcg32 {
    let key_lo = hash32(hash32(hash32(pixel) ^ sample) ^ bounce);
    let key_hi = hash32(key_lo ^ 0x9E37_79B9);
    let key = (u64::from(key_hi) << 32) | u64::from(key_lo);
    Pcg32::new(seed.state.wrapping_add(key), seed.inc)
}
