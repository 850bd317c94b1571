//! The seven uniforms every path vertex draws (DESIGN.md, "Random numbers").

use crate::sampling::Pcg32;

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
    pub fn draw(rng: &mut Pcg32) -> Self {
        let mut x = [0.0; DRAWS_PER_VERTEX];
        for v in &mut x {
            *v = rng.next_f64();
        }
        Self { light: x[0], light_point: [x[1], x[2]], lobe: x[3], direction: [x[4], x[5]], roulette: x[6] }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_are_the_stream_in_order() {
        let mut a = Pcg32::new(5, 6);
        let mut b = a;
        let d = VertexDraws::draw(&mut a);
        let seq: Vec<f64> = (0..7).map(|_| b.next_f64()).collect();
        assert_eq!(
            [d.light, d.light_point[0], d.light_point[1], d.lobe, d.direction[0], d.direction[1], d.roulette],
            seq[..]
        );
        assert_eq!(a, b);
    }
}
