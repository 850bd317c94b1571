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
    /// A side is zero.
    #[error("image size {width}×{height} is empty (both sides must be at least 1)")]
    Empty {
        /// Width asked for, in pixels.
        width: usize,
        /// Height asked for, in pixels.
        height: usize,
    },
    /// A side is over [`MAX_SIDE`], or the pixel count is over [`MAX_PIXELS`].
    #[error("image size {width}×{height} is too large (at most {MAX_SIDE} per side and {MAX_PIXELS} pixels)")]
    TooLarge {
        /// Width asked for, in pixels.
        width: usize,
        /// Height asked for, in pixels.
        height: usize,
    },
    /// A side is over what the output file's format holds (JPEG: 65535), though within
    /// lumen's own limits.
    #[error(
        "image size {width}×{height} is too large for {format} (at most {max_side} pixels per side; \
         .png, .exr, .hdr and .pfm take up to {MAX_SIDE})"
    )]
    TooLargeForFormat {
        /// Width asked for, in pixels.
        width: usize,
        /// Height asked for, in pixels.
        height: usize,
        /// The format's name for messages.
        format: &'static str,
        /// The format's largest side.
        max_side: usize,
    },
}

/// Decodes `bytes` as `format` with the `image` crate under lumen's limits rather than the
/// crate's own, which refuses any decode over 512 MiB ("Memory limit exceeded"): that turned
/// away a 16384×8192 Radiance HDR (1.5 GiB as f32), the size of common HDRI skies, though
/// `lumen tonemap` writes such files. Here the header's size must pass [`check_size`], and
/// the decoded image plus `extra_bytes_per_pixel` (the caller's copies) must fit this
/// process's memory ([`crate::memory::check_fits`]); then the crate decodes uncapped.
pub(crate) fn decode_within_limits(
    bytes: &[u8],
    format: ::image::ImageFormat,
    extra_bytes_per_pixel: u64,
) -> Result<::image::DynamicImage, String> {
    use ::image::ImageDecoder as _;
    let mut reader = ::image::ImageReader::with_format(std::io::Cursor::new(bytes), format);
    reader.no_limits();
    let decoder = reader.into_decoder().map_err(|e| e.to_string())?;
    let (width, height) = decoder.dimensions();
    let pixels = check_size(width as usize, height as usize).map_err(|e| e.to_string())?;
    let needed = decoder.total_bytes().saturating_add((pixels as u64).saturating_mul(extra_bytes_per_pixel));
    crate::memory::check_fits(needed, &format!("decoding a {width}×{height} image")).map_err(|e| e.to_string())?;
    ::image::DynamicImage::from_decoder(decoder).map_err(|e| e.to_string())
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
