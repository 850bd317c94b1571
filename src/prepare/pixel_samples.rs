//! Where camera samples fall inside a pixel (DESIGN.md, "Random numbers").

use crate::sampling::{stream, CAMERA_BOUNCE};
use crate::scene::{PcgSeed, Tracer};

/// The placement of camera samples in a pixel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PixelSamples {
    /// One sample at the pixel centre, no random draws (`samples_per_side` 0).
    Centre,
    /// s × s jittered strata.
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
    /// the pixel's top-left corner, drawn from the camera stream (sample j, CAMERA_BOUNCE).
    pub fn position(&self, seed: PcgSeed, pixel: u32, j: u32) -> (f64, f64) {
        if *self == PixelSamples::Centre {
            return (0.5, 0.5);
        }
        let mut rng = stream(seed, pixel, j, CAMERA_BOUNCE);
        let (xi0, xi1) = (rng.next_f64(), rng.next_f64());
        match *self {
            PixelSamples::Strata(s) => {
                let s_f = f64::from(s);
                (((j % s) as f64 + xi0) / s_f, ((j / s) as f64 + xi1) / s_f)
            }
            _ => (xi0, xi1),
        }
    }
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
            // The jitter is the camera stream's first two draws.
            let mut rng = stream(t3.rng, 11, j, CAMERA_BOUNCE);
            assert_eq!(u, ((j % 3) as f64 + rng.next_f64()) / 3.0);
        }
    }
}
