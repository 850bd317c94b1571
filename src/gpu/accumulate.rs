//! Host-side accumulation of GPU pass results in f64.
//!
//! Each GPU pass returns, per pixel of one tile, the f32 sum of a few camera samples. Adding
//! thousands of such sums in f32 would stall (an f32 running sum stops changing once it is
//! 2²⁴ times larger than the addend), so the host adds them in f64, where a few million
//! passes still lose nothing visible.
//!
//! Samples are added in *rounds*: a round is one sample range `[j0, j1)` over every tile.
//! Sums of the round in progress are kept apart and only join the total when the round is
//! complete, so every pixel of the result has the same sample count even when rendering
//! stops in the middle of a round.

use crate::color::Rgb32;
use crate::image::HdrImage;

/// A rectangle of pixels, `(x, y)` its top-left corner.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tile {
    pub x: u32,
    pub y: u32,
    pub width: u32,
    pub height: u32,
}

impl Tile {
    /// Tiles of at most `size × size` covering a `width × height` image, row by row.
    pub fn cover(width: u32, height: u32, size: u32) -> Vec<Tile> {
        let size = size.max(1);
        let mut tiles = Vec::new();
        for y in (0..height).step_by(size as usize) {
            for x in (0..width).step_by(size as usize) {
                tiles.push(Tile { x, y, width: size.min(width - x), height: size.min(height - y) });
            }
        }
        tiles
    }

    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

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
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Self { width, height, total: vec![[0.0; 3]; n], round: vec![[0.0; 3]; n], spp: 0, nonfinite: 0 }
    }

    /// Adds one tile's pass output to the round in progress. `sums` is row-major over the
    /// tile with a row stride of `tile.width`; only `.rgb` of each `[r, g, b, _]` is used.
    ///
    /// A non-finite sum (a kernel bug or an overflow) is dropped and counted rather than
    /// allowed to turn the pixel into NaN forever; see [`Self::nonfinite`].
    pub fn add_tile(&mut self, tile: Tile, sums: &[[f32; 4]]) {
        assert!(tile.x + tile.width <= self.width && tile.y + tile.height <= self.height, "tile outside image");
        assert!(sums.len() >= tile.pixel_count(), "tile output too short");
        for row in 0..tile.height {
            let src = &sums[(row * tile.width) as usize..][..tile.width as usize];
            let start = ((tile.y + row) * self.width + tile.x) as usize;
            for (dst, s) in self.round[start..start + tile.width as usize].iter_mut().zip(src) {
                if s[0].is_finite() && s[1].is_finite() && s[2].is_finite() {
                    for c in 0..3 {
                        dst[c] += f64::from(s[c]);
                    }
                } else {
                    self.nonfinite += 1;
                }
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

    /// Forgets the round in progress (rendering stopped before it covered every tile).
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
    fn tiles_cover_each_pixel_exactly_once() {
        for (w, h, s) in [(1, 1, 1), (10, 7, 3), (256, 256, 256), (300, 5, 128), (5, 300, 7)] {
            let mut seen = vec![0u8; (w * h) as usize];
            for t in Tile::cover(w, h, s) {
                assert!(t.width >= 1 && t.width <= s && t.height >= 1 && t.height <= s);
                for y in t.y..t.y + t.height {
                    for x in t.x..t.x + t.width {
                        seen[(y * w + x) as usize] += 1;
                    }
                }
            }
            assert!(seen.iter().all(|&c| c == 1), "{w}x{h} tiles {s}");
        }
    }

    #[test]
    fn f64_accumulation_has_no_plateau() {
        // 2²⁴ + 1 in f32 is 2²⁴: an f32 running sum of ones would stop at 16_777_216.
        let mut acc = Accumulator::new(1, 1);
        let tile = Tile { x: 0, y: 0, width: 1, height: 1 };
        acc.add_tile(tile, &[[16_777_216.0, 0.5, 0.0, 0.0]]);
        acc.commit_round(1);
        for _ in 0..3 {
            acc.add_tile(tile, &[[1.0, 0.5, 0.0, 0.0]]);
            acc.commit_round(1);
        }
        assert_eq!(acc.sums()[0], [16_777_219.0, 2.0, 0.0]);
        assert_eq!(acc.mean()[0], [16_777_219.0 / 4.0, 0.5, 0.0]);
        assert_eq!(acc.spp(), 4);
    }

    #[test]
    fn tiles_land_at_their_offsets_and_partial_rounds_are_discarded() {
        let mut acc = Accumulator::new(3, 2);
        let left = Tile { x: 0, y: 0, width: 2, height: 2 };
        let right = Tile { x: 2, y: 0, width: 1, height: 2 };
        let px = |v: f32| [v, 2.0 * v, 3.0 * v, 99.0];
        acc.add_tile(left, &[px(1.0), px(2.0), px(4.0), px(5.0)]);
        acc.add_tile(right, &[px(3.0), px(6.0)]);
        acc.commit_round(2);
        // A round cut short: must not leak into the result.
        acc.add_tile(left, &[px(100.0); 4]);
        acc.discard_round();
        let img = acc.mean_image();
        for (i, p) in img.pixels().iter().enumerate() {
            let v = (i + 1) as f32 / 2.0;
            assert_eq!(*p, Rgb32::new(v, 2.0 * v, 3.0 * v), "pixel {i}");
        }
    }

    #[test]
    fn nonfinite_sums_are_dropped_and_counted() {
        let mut acc = Accumulator::new(2, 1);
        acc.add_tile(
            Tile { x: 0, y: 0, width: 2, height: 1 },
            &[[f32::NAN, 0.0, 0.0, 0.0], [1.0, 1.0, f32::INFINITY, 0.0]],
        );
        acc.commit_round(1);
        assert_eq!(acc.nonfinite(), 2);
        assert!(acc.mean_image().pixels().iter().all(|p| *p == Rgb32::BLACK));
    }

    #[test]
    fn mean_before_any_round_is_black_not_nan() {
        let acc = Accumulator::new(2, 2);
        assert!(acc.mean_image().pixels().iter().all(|p| *p == Rgb32::BLACK));
    }
}
