//! Limits on image sizes, checked before any pixel buffer is allocated.

use thiserror::Error;

/// Largest accepted width or height. Generous for renders and textures, small enough that
/// a corrupt header cannot make us allocate gigabytes.
pub const MAX_SIDE: usize = 1 << 16;
/// Largest accepted pixel count (2²⁸ pixels = 3 GiB of `Rgb32`).
pub const MAX_PIXELS: usize = 1 << 28;

/// Why an image size was refused.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum SizeError {
    #[error("image size {width}×{height} is empty (both sides must be at least 1)")]
    Empty { width: usize, height: usize },
    #[error("image size {width}×{height} is too large (at most {MAX_SIDE} per side and {MAX_PIXELS} pixels)")]
    TooLarge { width: usize, height: usize },
}

/// Validates a size taken from a file header or a user and returns the pixel count.
///
/// ```
/// use lumen::image::check_size;
/// assert_eq!(check_size(3, 2), Ok(6));
/// assert!(check_size(0, 5).is_err());
/// assert!(check_size(1 << 20, 1 << 20).is_err());
/// ```
pub fn check_size(width: usize, height: usize) -> Result<usize, SizeError> {
    if width == 0 || height == 0 {
        return Err(SizeError::Empty { width, height });
    }
    match width.checked_mul(height) {
        Some(n) if width <= MAX_SIDE && height <= MAX_SIDE && n <= MAX_PIXELS => Ok(n),
        _ => Err(SizeError::TooLarge { width, height }),
    }
}
