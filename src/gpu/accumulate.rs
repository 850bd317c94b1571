//! Host-side accumulation of GPU pass results in f64.
//!
//! Each GPU batch returns, per pixel of a run of pixels, the f32 sum of a few camera samples
//! (at most [`super::MAX_SPP_PER_ROUND`]). Adding thousands of such sums in f32 would stall
//! (an f32 running sum stops changing once it is 2²⁴ times larger than the addend), so the
//! host adds them in f64, where a few million rounds still lose nothing visible.
//!
//! Samples are added in *rounds*: a round is one sample range `[j0, j1)` over every pixel.
//! Sums of the round in progress are kept apart and only join the total when the round is
//! complete, so every pixel of the result has the same sample count even when rendering
//! stops in the middle of a round.

use crate::color::Rgb32;
use crate::image::HdrImage;

/// Per-pixel f64 sums of whole rounds, plus the round in progress.
#[derive(Debug, Clone)]
pub struct Accumulator {
    width: u32,
    height: u32,
    total: Vec<[f64; 3]>,
    round: Vec<[f64; 3]>,
    spp: u64,
    nonfinite: u64,
}

impl Accumulator {
    /// An empty accumulator, or an error naming the memory the render needs when the host
    /// cannot have it (the size comes from user input: never an abort). The estimate counts
    /// both f64 sum buffers and the f32 image made from them.
    pub fn new(width: u32, height: u32) -> Result<Self, crate::memory::OutOfMemory> {
        let n = width as usize * height as usize;
        let total = (n as u64).saturating_mul(2 * 24 + 12);
        let what = format!("a {width}×{height} GPU render (its image's accumulation buffers)");
        crate::memory::check_fits(total, &what)?;
        let total_sums = crate::memory::try_filled(n, [0.0; 3], &what, total)?;
        let round = crate::memory::try_filled(n, [0.0; 3], &what, total)?;
        Ok(Self { width, height, total: total_sums, round, spp: 0, nonfinite: 0 })
    }

    /// Adds the sums of the pixels `first + k · stride` for `k < sums.len()` (row-major
    /// indices) to the round in progress.
    ///
    /// A non-finite sum (a kernel bug or an overflow) is dropped and counted rather than
    /// allowed to turn the pixel into NaN forever; see [`Self::nonfinite`].
    pub fn add_pixels(&mut self, first: usize, stride: usize, sums: &[[f64; 3]]) {
        let stride = stride.max(1);
        assert!(sums.is_empty() || first + (sums.len() - 1) * stride < self.round.len(), "pixels outside the image");
        for (dst, s) in self.round[first..].iter_mut().step_by(stride).zip(sums) {
            if s[0].is_finite() && s[1].is_finite() && s[2].is_finite() {
                for c in 0..3 {
                    dst[c] += s[c];
                }
            } else {
                self.nonfinite += 1;
            }
        }
    }

    /// Completes the round: its `samples` samples per pixel join the total.
    pub fn commit_round(&mut self, samples: u32) {
        for (t, r) in self.total.iter_mut().zip(self.round.iter_mut()) {
            for c in 0..3 {
                t[c] += r[c];
            }
            *r = [0.0; 3];
        }
        self.spp += u64::from(samples);
    }

    /// Forgets the round in progress (rendering stopped before it covered every pixel).
    pub fn discard_round(&mut self) {
        self.round.iter_mut().for_each(|r| *r = [0.0; 3]);
    }

    /// Samples per pixel in the committed total (the same for every pixel).
    pub fn spp(&self) -> u64 {
        self.spp
    }

    /// Pass sums dropped because they were not finite.
    pub fn nonfinite(&self) -> u64 {
        self.nonfinite
    }

    /// Committed per-pixel sums, row-major.
    pub fn sums(&self) -> &[[f64; 3]] {
        &self.total
    }

    /// The per-pixel mean in f64 (black before the first round).
    pub fn mean(&self) -> Vec<[f64; 3]> {
        let inv = if self.spp == 0 { 0.0 } else { 1.0 / self.spp as f64 };
        self.total.iter().map(|s| s.map(|c| c * inv)).collect()
    }

    /// The per-pixel mean as an image.
    pub fn mean_image(&self) -> HdrImage {
        let pixels = self.mean().into_iter().map(|m| Rgb32::new(m[0] as f32, m[1] as f32, m[2] as f32)).collect();
        HdrImage::from_pixels(self.width as usize, self.height as usize, pixels).expect("pixel count matches")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f64_accumulation_has_no_plateau() {
        // 2²⁴ + 1 in f32 is 2²⁴: an f32 running sum of ones would stop at 16_777_216.
        let mut acc = Accumulator::new(1, 1).unwrap();
        acc.add_pixels(0, 1, &[[16_777_216.0, 0.5, 0.0]]);
        acc.commit_round(1);
        for _ in 0..3 {
            acc.add_pixels(0, 1, &[[1.0, 0.5, 0.0]]);
            acc.commit_round(1);
        }
        assert_eq!(acc.sums()[0], [16_777_219.0, 2.0, 0.0]);
        assert_eq!(acc.mean()[0], [16_777_219.0 / 4.0, 0.5, 0.0]);
        assert_eq!(acc.spp(), 4);
    }

    #[test]
    fn pixel_runs_land_at_their_offsets_and_partial_rounds_are_discarded() {
        let mut acc = Accumulator::new(3, 2).unwrap();
        let px = |v: f64| [v, 2.0 * v, 3.0 * v];
        acc.add_pixels(0, 1, &[px(1.0), px(2.0)]);
        acc.add_pixels(2, 1, &[px(3.0), px(4.0), px(5.0), px(6.0)]);
        acc.commit_round(2);
        // A round cut short: must not leak into the result.
        acc.add_pixels(1, 1, &[px(100.0); 4]);
        acc.discard_round();
        let img = acc.mean_image();
        for (i, p) in img.pixels().iter().enumerate() {
            let v = (i + 1) as f32 / 2.0;
            assert_eq!(*p, Rgb32::new(v, 2.0 * v, 3.0 * v), "pixel {i}");
        }
    }

    #[test]
    fn nonfinite_sums_are_dropped_and_counted() {
        let mut acc = Accumulator::new(2, 1).unwrap();
        acc.add_pixels(0, 1, &[[f64::NAN, 0.0, 0.0], [1.0, 1.0, f64::INFINITY]]);
        acc.commit_round(1);
        assert_eq!(acc.nonfinite(), 2);
        assert!(acc.mean_image().pixels().iter().all(|p| *p == Rgb32::BLACK));
    }

    #[test]
    fn mean_before_any_round_is_black_not_nan() {
        let acc = Accumulator::new(2, 2).unwrap();
        assert!(acc.mean_image().pixels().iter().all(|p| *p == Rgb32::BLACK));
    }
}
