//! The in-memory HDR image every renderer writes and every file format reads.

use crate::color::Rgb32;

/// A `width × height` grid of linear RGB `f32` pixels, row 0 at the top.
///
/// ```
/// use lumen::image::HdrImage;
/// use lumen::color::Rgb32;
/// let mut img = HdrImage::new(3, 2);
/// img.set(2, 1, Rgb32::new(1.0, 2.0, 3.0));
/// assert_eq!(img.get(2, 1), Rgb32::new(1.0, 2.0, 3.0));
/// assert_eq!(img.pixels().len(), 6);
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct HdrImage {
    width: usize,
    height: usize,
    pixels: Vec<Rgb32>,
}

impl HdrImage {
    /// A black image. Panics only if `width * height` overflows `usize`; callers that take
    /// sizes from users validate them first (see [`crate::image::check_size`]).
    pub fn new(width: usize, height: usize) -> Self {
        let n = width.checked_mul(height).expect("image size overflows usize");
        Self { width, height, pixels: vec![Rgb32::BLACK; n] }
    }

    /// Wraps existing pixels (row-major, top row first). `None` if the count is wrong.
    pub fn from_pixels(width: usize, height: usize, pixels: Vec<Rgb32>) -> Option<Self> {
        (width.checked_mul(height) == Some(pixels.len())).then_some(Self { width, height, pixels })
    }

    pub fn width(&self) -> usize {
        self.width
    }
    pub fn height(&self) -> usize {
        self.height
    }
    pub fn pixels(&self) -> &[Rgb32] {
        &self.pixels
    }
    pub fn pixels_mut(&mut self) -> &mut [Rgb32] {
        &mut self.pixels
    }
    pub fn into_pixels(self) -> Vec<Rgb32> {
        self.pixels
    }

    fn offset(&self, col: usize, row: usize) -> usize {
        assert!(col < self.width && row < self.height, "pixel ({col}, {row}) outside {}×{}", self.width, self.height);
        row * self.width + col
    }
    /// The pixel at column `col`, row `row` (0 = top).
    pub fn get(&self, col: usize, row: usize) -> Rgb32 {
        self.pixels[self.offset(col, row)]
    }
    pub fn set(&mut self, col: usize, row: usize, c: Rgb32) {
        let i = self.offset(col, row);
        self.pixels[i] = c;
    }
}
