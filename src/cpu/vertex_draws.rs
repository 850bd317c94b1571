//! The seven uniforms every path vertex draws (DESIGN.md, "Random numbers").

use crate::sampling::{Pcg32, VertexStrata};

/// The draws of one path vertex, in the contract's order. All seven are drawn up front,
/// used or not, so the CPU and the GPU consume the same numbers at every vertex.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VertexDraws {
    /// ξ0: which light next-event estimation samples.
    pub light: f64,
    /// ξ1, ξ2: the point (or direction) on that light.
    pub light_point: [f64; 2],
    /// ξ3: the BSDF lobe (the dielectric's reflect/refract choice).
    pub lobe: f64,
    /// ξ4, ξ5: the BSDF direction.
    pub direction: [f64; 2],
    /// ξ6: Russian roulette.
    pub roulette: f64,
}

/// Number of uniforms a vertex draws.
pub const DRAWS_PER_VERTEX: usize = 7;

impl VertexDraws {
    /// The vertex's seven stream draws, each moved into its sample's stratum of its
    /// dimension ([`VertexStrata::draws`]; the light point and the direction are 2D).
    pub fn draw(rng: &mut Pcg32, strata: &VertexStrata) -> Self {
        let mut x = [0u32; DRAWS_PER_VERTEX];
        for v in &mut x {
            // The 24 bits of Pcg32::next_f64.
            *v = rng.next_u32() >> 8;
        }
        let u = strata.draws(x);
        Self { light: u[0], light_point: [u[1], u[2]], lobe: u[3], direction: [u[4], u[5]], roulette: u[6] }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::sampling::{seed_word, strata_bits};
    use crate::scene::PcgSeed;

    fn flat(d: &VertexDraws) -> [f64; 7] {
        [d.light, d.light_point[0], d.light_point[1], d.lobe, d.direction[0], d.direction[1], d.roulette]
    }

    /// With one sample per pixel the draws are the stream's, in order; seven are drawn.
    #[test]
    fn draws_are_the_stream_in_order() {
        let mut a = Pcg32::new(5, 6);
        let mut b = a;
        let d = VertexDraws::draw(&mut a, &VertexStrata::new(1, 2, 0, 3, strata_bits(1)));
        let seq: Vec<f64> = (0..7).map(|_| b.next_f64()).collect();
        assert_eq!(flat(&d), seq[..]);
        assert_eq!(a, b);
    }

    /// With 16 samples, draw k of sample i lies in its stratum of 16 (2D: of the 4 × 4
    /// grid), at the stream's 24-bit draw scaled into it and rounded down to 24 bits, and
    /// the 16 samples fill every stratum once.
    #[test]
    fn draws_sit_in_their_strata() {
        let word = seed_word(PcgSeed::default());
        let mut filled: [std::collections::BTreeSet<(u64, u64)>; 5] = Default::default();
        for i in 0..16 {
            let strata = VertexStrata::new(word, 9, i, 1, 4);
            let mut a = Pcg32::new(7, u64::from(i));
            let x: Vec<u64> = {
                let mut b = a;
                (0..7).map(|_| u64::from(b.next_u32() >> 8)).collect()
            };
            let d = flat(&VertexDraws::draw(&mut a, &strata));
            for (k, m) in [(0, 16), (3, 16), (6, 16), (1, 4), (2, 4), (4, 4), (5, 4)] {
                let bits = (d[k] * 16_777_216.0) as u64;
                assert_eq!(bits as f64, d[k] * 16_777_216.0, "draw {k} is on the 24-bit grid");
                let stratum = d[k] * m as f64;
                assert_eq!(bits, ((stratum.floor() as u64) << 24 | x[k]) / m, "draw {k} of sample {i}");
            }
            // The 1D draws' strata of 16, and the 2D pairs' cells of the 4 × 4 grid.
            let cell = |k: usize, m: f64| (d[k] * m).floor() as u64;
            for (set, (a, b)) in filled.iter_mut().zip([(0, 0), (3, 3), (6, 6), (1, 2), (4, 5)]) {
                set.insert(if a == b { (cell(a, 16.0), 0) } else { (cell(a, 4.0), cell(b, 4.0)) });
            }
        }
        assert!(filled.iter().all(|set| set.len() == 16), "{filled:?}");
    }
}
