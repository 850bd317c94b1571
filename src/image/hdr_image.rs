//! The in-memory HDR image every renderer writes and every file format reads.

use std::ops::{Add, Index, IndexMut, Mul, Sub};

use crate::color::{Color, Rgb32};
use crate::memory::{try_filled, OutOfMemory};

/// A `width × height` grid of linear RGB `f32` pixels, row 0 at the top.
///
/// Index with `(col, row)`; whole-image arithmetic (`+`, `-`, `*` by an image or a scalar)
/// works pixel by pixel and panics if the sizes differ (a programming error; use
/// [`HdrImage::try_zip_with`] when sizes come from input).
///
/// ```
/// use lumen::image::HdrImage;
/// use lumen::color::Rgb32;
/// let mut img = HdrImage::new(3, 2);
/// img.set(2, 1, Rgb32::new(1.0, 2.0, 3.0));
/// assert_eq!(img.get(2, 1), Rgb32::new(1.0, 2.0, 3.0));
/// assert_eq!(img.pixels().len(), 6);
/// img[(0, 0)] = Rgb32::gray(f32::NAN);
/// let doubled = &img * 2.0;
/// assert_eq!(doubled[(2, 1)], Rgb32::new(2.0, 4.0, 6.0));
/// assert_eq!(doubled.non_finite_count(), 1);
/// ```
#[derive(Clone, PartialEq)]
pub struct HdrImage {
    width: usize,
    height: usize,
    pixels: Vec<Rgb32>,
}

/// The size and a 64-bit digest of the pixels' bits rather than every value: equal images
/// print alike and any changed bit changes the text, which is what a scene's fingerprint
/// (`render_metadata::fingerprint`, a hash of `Debug` text) needs, while formatting each
/// of a 1024×512 environment map's 1.5 M floats cost every render tens of milliseconds.
///
/// ```
/// use lumen::image::HdrImage;
/// let a = HdrImage::new(3, 2);
/// let mut b = a.clone();
/// assert_eq!(format!("{a:?}"), format!("{b:?}"));
/// b[(1, 1)].g = 1e-30;
/// assert_ne!(format!("{a:?}"), format!("{b:?}"));
/// assert!(format!("{a:?}").starts_with("HdrImage { width: 3, height: 2, pixel_bits: "));
/// ```
impl std::fmt::Debug for HdrImage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut digest = super::digest::Digest::new();
        digest.scalars::<4, _>(&self.pixels);
        f.debug_struct("HdrImage")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("pixel_bits", &format_args!("{:016x}", digest.finish()))
            .finish()
    }
}

impl HdrImage {
    /// A black image. Panics only if `width * height` overflows `usize`; callers that take
    /// sizes from users validate them first (see [`crate::image::check_size`]).
    pub fn new(width: usize, height: usize) -> Self {
        let n = width.checked_mul(height).expect("image size overflows usize");
        Self { width, height, pixels: vec![Rgb32::BLACK; n] }
    }

    /// A black image, or an error saying how much memory it needs when that cannot be had:
    /// for sizes that come from input (a script's `Image(w, h)`, `--width`, a file header).
    ///
    /// ```
    /// use lumen::image::HdrImage;
    /// assert_eq!(HdrImage::try_new(3, 2).unwrap().pixels().len(), 6);
    /// assert!(HdrImage::try_new(1 << 31, 1 << 31).is_err());
    /// ```
    pub fn try_new(width: usize, height: usize) -> Result<Self, OutOfMemory> {
        let n = width.saturating_mul(height);
        let bytes = (n as u64).saturating_mul(std::mem::size_of::<Rgb32>() as u64);
        let pixels = try_filled(n, Rgb32::BLACK, &format!("a {width}×{height} image"), bytes)?;
        Ok(Self { width, height, pixels })
    }

    /// Wraps existing pixels (row-major, top row first). `None` if the count is wrong.
    pub fn from_pixels(width: usize, height: usize, pixels: Vec<Rgb32>) -> Option<Self> {
        (width.checked_mul(height) == Some(pixels.len())).then_some(Self { width, height, pixels })
    }

    /// Builds an image by evaluating `f(col, row)` at every pixel.
    pub fn from_fn(width: usize, height: usize, f: impl Fn(usize, usize) -> Rgb32) -> Self {
        let n = width.checked_mul(height).expect("image size overflows usize");
        let pixels = (0..n).map(|i| f(i % width, i / width)).collect();
        Self { width, height, pixels }
    }

    /// Number of columns, in pixels.
    pub fn width(&self) -> usize {
        self.width
    }
    /// Number of rows, in pixels.
    pub fn height(&self) -> usize {
        self.height
    }
    /// All pixels, row-major from the top-left: pixel (col, row) is at `row * width + col`.
    pub fn pixels(&self) -> &[Rgb32] {
        &self.pixels
    }
    /// All pixels, mutable, in the order of [`pixels`](Self::pixels).
    pub fn pixels_mut(&mut self) -> &mut [Rgb32] {
        &mut self.pixels
    }
    /// The pixel buffer, in the order of [`pixels`](Self::pixels), without copying it.
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
    /// Replaces the pixel at column `col`, row `row` (0 = top). Panics outside the image.
    pub fn set(&mut self, col: usize, row: usize, c: Rgb32) {
        let i = self.offset(col, row);
        self.pixels[i] = c;
    }

    /// True when `other` has the same width and height.
    pub fn same_size(&self, other: &HdrImage) -> bool {
        self.width == other.width && self.height == other.height
    }

    /// A new image with `f` applied to every pixel.
    pub fn map(&self, f: impl Fn(Rgb32) -> Rgb32) -> HdrImage {
        HdrImage { width: self.width, height: self.height, pixels: self.pixels.iter().map(|&c| f(c)).collect() }
    }

    /// Applies `f` to every pixel in place.
    pub fn map_in_place(&mut self, f: impl Fn(Rgb32) -> Rgb32) {
        self.pixels.iter_mut().for_each(|c| *c = f(*c));
    }

    /// Combines two images pixel by pixel; `None` if their sizes differ.
    pub fn try_zip_with(&self, other: &HdrImage, f: impl Fn(Rgb32, Rgb32) -> Rgb32) -> Option<HdrImage> {
        self.same_size(other).then(|| HdrImage {
            width: self.width,
            height: self.height,
            pixels: self.pixels.iter().zip(&other.pixels).map(|(&a, &b)| f(a, b)).collect(),
        })
    }

    fn zip_or_panic(&self, other: &HdrImage, op: &str, f: impl Fn(Rgb32, Rgb32) -> Rgb32) -> HdrImage {
        self.try_zip_with(other, f).unwrap_or_else(|| {
            panic!("image {op}: sizes differ ({}×{} and {}×{})", self.width, self.height, other.width, other.height)
        })
    }

    /// How many pixels have a NaN or infinite channel.
    pub fn non_finite_count(&self) -> usize {
        self.pixels.iter().filter(|c| !c.is_finite()).count()
    }

    /// The mean pixel, accumulated in `f64` (non-finite pixels included: the mean is then
    /// non-finite too, which is what a test comparing means wants to see).
    pub fn mean(&self) -> Color {
        let sum = self.pixels.iter().fold(Color::BLACK, |acc, &c| acc + Color::from(c));
        sum / self.pixels.len().max(1) as f64
    }
}

impl Index<(usize, usize)> for HdrImage {
    type Output = Rgb32;
    /// `img[(col, row)]`, row 0 at the top.
    fn index(&self, (col, row): (usize, usize)) -> &Rgb32 {
        &self.pixels[self.offset(col, row)]
    }
}

impl IndexMut<(usize, usize)> for HdrImage {
    fn index_mut(&mut self, (col, row): (usize, usize)) -> &mut Rgb32 {
        let i = self.offset(col, row);
        &mut self.pixels[i]
    }
}

impl Add for &HdrImage {
    type Output = HdrImage;
    fn add(self, o: &HdrImage) -> HdrImage {
        self.zip_or_panic(o, "sum", |a, b| a + b)
    }
}

impl Sub for &HdrImage {
    type Output = HdrImage;
    fn sub(self, o: &HdrImage) -> HdrImage {
        self.zip_or_panic(o, "difference", |a, b| a - b)
    }
}

impl Mul for &HdrImage {
    type Output = HdrImage;
    fn mul(self, o: &HdrImage) -> HdrImage {
        self.zip_or_panic(o, "product", |a, b| a * b)
    }
}

impl Mul<f32> for &HdrImage {
    type Output = HdrImage;
    fn mul(self, s: f32) -> HdrImage {
        self.map(|c| c * s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp() -> HdrImage {
        HdrImage::from_fn(3, 2, |c, r| Rgb32::new(c as f32, r as f32, (c + 10 * r) as f32))
    }

    #[test]
    fn from_fn_and_indexing_are_column_row() {
        let img = ramp();
        assert_eq!(img[(2, 1)], Rgb32::new(2.0, 1.0, 12.0));
        assert_eq!(img.pixels()[5], Rgb32::new(2.0, 1.0, 12.0));
        assert_eq!(img.pixels()[1], Rgb32::new(1.0, 0.0, 1.0));
    }

    #[test]
    fn arithmetic_is_per_pixel() {
        let a = ramp();
        let b = a.map(|c| c + Rgb32::WHITE);
        assert_eq!((&a + &b)[(1, 1)], Rgb32::new(3.0, 3.0, 23.0));
        assert_eq!((&b - &a).pixels(), &[Rgb32::WHITE; 6]);
        assert_eq!((&a * &b)[(2, 0)], Rgb32::new(6.0, 0.0, 6.0));
        assert_eq!((&a * 0.5)[(2, 1)], Rgb32::new(1.0, 0.5, 6.0));
        assert_eq!(a.mean(), Color::new(1.0, 0.5, 1.0 + 5.0));
    }

    #[test]
    fn mismatched_sizes_are_none() {
        assert!(ramp().try_zip_with(&HdrImage::new(2, 3), |a, _| a).is_none());
    }

    #[test]
    #[should_panic(expected = "sizes differ")]
    fn mismatched_operator_panics() {
        let _ = &ramp() + &HdrImage::new(1, 1);
    }

    #[test]
    fn counts_non_finite_pixels() {
        let mut img = ramp();
        assert_eq!(img.non_finite_count(), 0);
        img[(0, 0)].g = f32::NAN;
        img[(1, 1)].b = f32::NEG_INFINITY;
        img.map_in_place(|c| c * 2.0);
        assert_eq!(img.non_finite_count(), 2);
    }
}
