//! Where camera samples fall inside a pixel (DESIGN.md, "Random numbers").

use crate::sampling::{hash32, permute_below, seed_word, stream, CAMERA_BOUNCE};
use crate::scene::{PcgSeed, Tracer};

/// The placement of camera samples in a pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PixelSamples {
    /// One sample at the pixel centre, no random draws (`samples_per_side` 0).
    Centre,
    /// s × s strata, multi-jittered: one sample in each cell of the s × s grid and in each
    /// of the s² columns and rows of width 1/s² (see [`PixelSamples::position`]).
    Strata(u32),
    /// n samples jittered over the whole pixel.
    Jittered(u32),
}

impl PixelSamples {
    /// The scene tracer's placement, or the `--spp` override: a perfect square s² means
    /// s × s strata, any other count n jitters n samples over the whole pixel.
    pub fn new(tracer: &Tracer, spp_override: Option<u32>) -> Self {
        match spp_override {
            Some(n) => {
                let s = n.isqrt();
                if s * s == n {
                    PixelSamples::Strata(s)
                } else {
                    PixelSamples::Jittered(n)
                }
            }
            None if tracer.samples_per_side == 0 => PixelSamples::Centre,
            None => PixelSamples::Strata(tracer.samples_per_side),
        }
    }

    /// log₂ of the strata per dimension of a path vertex ([`crate::sampling::strata_bits`])
    /// for pixels of these camera samples with `paths` paths each: what the CPU reference
    /// and the packed GPU settings both stratify by.
    pub fn strata_bits(&self, paths: u64) -> u32 {
        crate::sampling::strata_bits(self.count().saturating_mul(paths))
    }

    /// Camera samples per pixel.
    pub fn count(&self) -> u64 {
        match *self {
            PixelSamples::Centre => 1,
            PixelSamples::Strata(s) => u64::from(s) * u64::from(s),
            PixelSamples::Jittered(n) => u64::from(n),
        }
    }

    /// Position (u_px, v_px) ∈ [0, 1)² of camera sample `j` in pixel `pixel`, measured from
    /// the pixel's top-left corner, jittered by the camera stream's first two draws (sample
    /// j, CAMERA_BOUNCE).
    ///
    /// s × s strata are multi-jittered (Chiu, Shirley and Wang 1994, in the correlated form
    /// of Kensler 2013): sample j lies in cell (c, r) = (j mod s, j div s), and within it in
    /// sub-column π_x(r) and sub-row π_y(c) of an s × s subgrid, for two permutations of
    /// 0..s keyed by the pixel and the tracer's seed. So besides one sample per cell, each
    /// of the pixel's s² columns of width 1/s² holds one sample (column c·s + π_x(r) is
    /// distinct for every cell), and so does each row: an edge crossing the pixel nearly
    /// horizontally or vertically is measured s times more finely than by jittered strata
    /// alone (cornell.sl's lamp and walls; BENCHMARKS.md "Multi-jittered camera samples").
    /// Every sample is still uniform over its cell, so estimates stay unbiased, also for a
    /// render that stops before all s² samples.
    pub fn position(&self, seed: PcgSeed, pixel: u32, j: u32) -> (f64, f64) {
        if *self == PixelSamples::Centre {
            return (0.5, 0.5);
        }
        let mut rng = stream(seed, pixel, j, CAMERA_BOUNCE);
        let (xi0, xi1) = (rng.next_f64(), rng.next_f64());
        match *self {
            PixelSamples::Strata(s) => {
                let (c, r) = (j % s, j / s);
                let key = camera_strata_key(seed_word(seed), pixel);
                let (sub_col, sub_row) = (permute_below(r, s, key), permute_below(c, s, hash32(key)));
                let n = f64::from(s) * f64::from(s);
                ((f64::from(c * s + sub_col) + xi0) / n, (f64::from(r * s + sub_row) + xi1) / n)
            }
            _ => (xi0, xi1),
        }
    }
}

/// Salt of the camera strata's keys (π's digits), so that their hash chain is not the
/// vertex strata's. WGSL reads it from the generated tags (`CAMERA_STRATA_SALT`).
pub const CAMERA_STRATA_SALT: u32 = 0x243F_6A88;

/// The key of pixel `pixel`'s sub-column permutation (its sub-row permutation's is this
/// hashed once more), from the seed's word ([`seed_word`], `Settings::strata_seed` on the
/// GPU): its own hash chain, apart from the vertex strata's keys.
pub fn camera_strata_key(seed_word: u32, pixel: u32) -> u32 {
    hash32(hash32(pixel ^ seed_word) ^ CAMERA_STRATA_SALT)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layouts_and_strata() {
        let t = Tracer { samples_per_side: 0, ..Tracer::default() };
        assert_eq!(PixelSamples::new(&t, None), PixelSamples::Centre);
        assert_eq!(PixelSamples::new(&t, Some(16)), PixelSamples::Strata(4));
        assert_eq!(PixelSamples::new(&t, Some(1)), PixelSamples::Strata(1));
        assert_eq!(PixelSamples::new(&t, Some(10)), PixelSamples::Jittered(10));
        let t3 = Tracer { samples_per_side: 3, ..Tracer::default() };
        let p = PixelSamples::new(&t3, None);
        assert_eq!(p.count(), 9);
        assert_eq!(PixelSamples::Centre.position(t.rng, 7, 0), (0.5, 0.5));
        for j in 0..9 {
            let (u, v) = p.position(t3.rng, 11, j);
            assert!((u * 3.0).floor() as u32 == j % 3 && (v * 3.0).floor() as u32 == j / 3);
            // The jitter is the camera stream's first two draws, inside a 1/9-wide column.
            let mut rng = stream(t3.rng, 11, j, CAMERA_BOUNCE);
            let xi0 = rng.next_f64();
            assert_eq!((u * 9.0).fract(), xi0, "{u}");
        }
    }

    /// Multi-jittered strata: for every s, one sample in each of the s × s cells and in
    /// each of the s² columns and the s² rows; different pixels get different permutations.
    #[test]
    fn strata_are_multi_jittered() {
        let seed = PcgSeed { state: 3, inc: 5 };
        for s in [1u32, 2, 3, 5, 8, 13] {
            let p = PixelSamples::Strata(s);
            let n = (s * s) as usize;
            let mut layouts = std::collections::BTreeSet::new();
            for pixel in [0u32, 1, 77, 4_000_000] {
                let (mut cells, mut cols, mut rows) = (vec![0; n], vec![0; n], vec![0; n]);
                let mut layout = Vec::new();
                for j in 0..s * s {
                    let (u, v) = p.position(seed, pixel, j);
                    assert!((0.0..1.0).contains(&u) && (0.0..1.0).contains(&v));
                    let (cu, cv) = ((u * f64::from(s)) as usize, (v * f64::from(s)) as usize);
                    cells[cv * s as usize + cu] += 1;
                    let (col, row) = ((u * n as f64) as usize, (v * n as f64) as usize);
                    cols[col] += 1;
                    rows[row] += 1;
                    layout.push((col, row));
                }
                assert!(cells.iter().chain(&cols).chain(&rows).all(|&k| k == 1), "s = {s}, pixel {pixel}");
                layouts.insert(layout);
            }
            if s >= 3 {
                assert!(layouts.len() > 1, "s = {s}: every pixel has the same layout");
            }
        }
    }
}
