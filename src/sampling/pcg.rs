//! PCG32 (O'Neill's XSH-RR 64/32), as Raytracer.jl seeds it with `Pcg(.state, .inc)`.

const MULTIPLIER: u64 = 6_364_136_223_846_793_005;

/// The PCG32 generator: 64-bit LCG state, 32-bit permuted output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    /// Seeds like the reference `pcg32_srandom_r(initstate, initseq)`.
    pub fn new(init_state: u64, init_seq: u64) -> Self {
        let mut p = Self { state: 0, inc: (init_seq << 1) | 1 };
        p.next_u32();
        p.state = p.state.wrapping_add(init_state);
        p.next_u32();
        p
    }

    /// Advances the state and returns the next 32 uniformly random bits (the reference
    /// `pcg32_random_r`).
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(MULTIPLIER).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// A uniform float in [0, 1) with 24 random bits (identical on CPU and GPU).
    pub fn next_f64(&mut self) -> f64 {
        unit24(self.next_u32() >> 8)
    }

    /// The same value as [`Self::next_f64`], in f32 (exact).
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }
}

/// A 24-bit draw (`next_u32() >> 8`) as a float in [0, 1): `x · 2⁻²⁴`, exact in f32 and f64.
pub fn unit24(x: u32) -> f64 {
    f64::from(x) * (1.0 / 16_777_216.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_reference_sequence() {
        // pcg32_srandom_r(42, 54) from the PCG reference implementation's demo output.
        let mut p = Pcg32::new(42, 54);
        let expected = [0xa15c02b7u32, 0x7b47f409, 0xba1d3330, 0x83d2f293, 0xbfa4784b, 0xcbed606e];
        for e in expected {
            assert_eq!(p.next_u32(), e);
        }
    }
}
