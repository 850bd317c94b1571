//! Error of an image against a reference, over all pixels and the three channels.

use crate::image::HdrImage;

/// ε in relMSE = mean((x − r)² / (r² + ε)): keeps black reference pixels from dividing by
/// zero while leaving pixels brighter than about 0.1 weighted by their own brightness.
pub const REL_MSE_EPSILON: f64 = 1e-2;

/// Every metric `lumen converge` reports for one image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorMetrics {
    /// Mean squared error per channel ([`mse`]).
    pub mse: f64,
    /// Square root of `mse`, in the image's radiance units ([`rmse`]).
    pub rmse: f64,
    /// Relative MSE, each channel's squared error over its reference value squared plus
    /// [`REL_MSE_EPSILON`] ([`rel_mse`]).
    pub rel_mse: f64,
}

impl ErrorMetrics {
    /// All metrics of `image` against `reference`; `None` when the sizes differ.
    pub fn of(image: &HdrImage, reference: &HdrImage) -> Option<Self> {
        let mse = mse(image, reference)?;
        Some(Self { mse, rmse: mse.sqrt(), rel_mse: rel_mse(image, reference)? })
    }
}

/// Mean over channels of `f(x, r)` in f64; `None` when the sizes differ or the image is empty.
fn mean_over_channels(image: &HdrImage, reference: &HdrImage, f: impl Fn(f64, f64) -> f64) -> Option<f64> {
    if !image.same_size(reference) || image.pixels().is_empty() {
        return None;
    }
    let sum: f64 = image
        .pixels()
        .iter()
        .zip(reference.pixels())
        .map(|(x, r)| {
            let (x, r) = (x.to_array(), r.to_array());
            (0..3).map(|c| f(f64::from(x[c]), f64::from(r[c]))).sum::<f64>()
        })
        .sum();
    Some(sum / (3 * image.pixels().len()) as f64)
}

/// Mean squared error per channel; `None` when the sizes differ.
pub fn mse(image: &HdrImage, reference: &HdrImage) -> Option<f64> {
    mean_over_channels(image, reference, |x, r| (x - r) * (x - r))
}

/// Root of [`mse`].
pub fn rmse(image: &HdrImage, reference: &HdrImage) -> Option<f64> {
    mse(image, reference).map(f64::sqrt)
}

/// Relative MSE, mean((x − r)² / (r² + [`REL_MSE_EPSILON`])): error that counts as much in
/// dark regions as in bright ones.
pub fn rel_mse(image: &HdrImage, reference: &HdrImage) -> Option<f64> {
    mean_over_channels(image, reference, |x, r| (x - r) * (x - r) / (r * r + REL_MSE_EPSILON))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::color::Rgb32;

    fn rgb(r: f32, g: f32, b: f32) -> Rgb32 {
        Rgb32 { r, g, b }
    }

    #[test]
    fn hand_computed_errors() {
        // Two pixels; differences (1, 0, 0) and (0, 2, −1): squared sum 6 over 6 channels.
        let reference = HdrImage::from_pixels(2, 1, vec![rgb(1.0, 0.0, 2.0), rgb(0.0, 0.0, 0.0)]).unwrap();
        let image = HdrImage::from_pixels(2, 1, vec![rgb(2.0, 0.0, 2.0), rgb(0.0, 2.0, -1.0)]).unwrap();
        assert!((mse(&image, &reference).unwrap() - 1.0).abs() < 1e-15);
        assert!((rmse(&image, &reference).unwrap() - 1.0).abs() < 1e-15);
        let e = REL_MSE_EPSILON;
        let expected = (1.0 / (1.0 + e) + 4.0 / e + 1.0 / e) / 6.0;
        assert!((rel_mse(&image, &reference).unwrap() - expected).abs() < 1e-12);
        let m = ErrorMetrics::of(&image, &reference).unwrap();
        assert_eq!((m.mse, m.rmse), (1.0, 1.0));
    }

    #[test]
    fn identical_images_have_zero_error_and_sizes_must_match() {
        let a = HdrImage::from_fn(3, 2, |x, y| rgb(x as f32, y as f32, 0.5));
        assert_eq!(mse(&a, &a), Some(0.0));
        assert_eq!(rel_mse(&a, &a), Some(0.0));
        assert_eq!(mse(&a, &HdrImage::new(2, 3)), None);
        assert_eq!(ErrorMetrics::of(&a, &HdrImage::new(3, 3)), None);
    }

    #[test]
    fn constant_offset_gives_known_rmse() {
        let r = HdrImage::from_fn(5, 4, |_, _| rgb(0.25, 0.5, 1.0));
        let x = r.map(|c| rgb(c.r + 0.125, c.g + 0.125, c.b + 0.125));
        assert!((rmse(&x, &r).unwrap() - 0.125).abs() < 1e-12);
    }
}
