//! 8-bit PNG and JPEG files through the `image` crate.
//!
//! Reading decodes the sRGB transfer curve to linear values (so an 8-bit texture means the
//! colour it shows on screen); 16-bit PNGs keep their precision; grey is expanded to RGB
//! and alpha is dropped. Writing stores already tone-mapped, encoded 8-bit RGB.

use ::image::codecs::jpeg::JpegEncoder;
use ::image::codecs::png::PngEncoder;
use ::image::{DynamicImage, ExtendedColorType, ImageEncoder, ImageFormat};

use super::srgb::srgb_to_linear;
use super::HdrImage;
use crate::color::Rgb32;

/// JPEG quality for tone-mapped output: high enough that banding and blocks do not show.
pub const JPEG_QUALITY: u8 = 95;

/// The two 8-bit formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum LdrFormat {
    Png,
    Jpeg,
}

impl LdrFormat {
    fn image_format(self) -> ImageFormat {
        match self {
            Self::Png => ImageFormat::Png,
            Self::Jpeg => ImageFormat::Jpeg,
        }
    }
}

pub(crate) fn decode_ldr(bytes: &[u8], format: LdrFormat) -> Result<HdrImage, String> {
    // Beside the decoded image: its RGB conversion (up to 6 bytes a pixel) and our f32 copy.
    let img = super::size::decode_within_limits(bytes, format.image_format(), 6 + 12).map_err(|message| {
        match (format, unknown_critical_chunk(bytes)) {
            (LdrFormat::Png, Some(name)) if message.contains("Unrecognized critical chunk") => {
                format!("an unknown critical chunk \"{name}\" (the file is corrupt, or needs a PNG extension)")
            }
            _ => message,
        }
    })?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let sixteen_bit = matches!(
        img,
        DynamicImage::ImageLuma16(_)
            | DynamicImage::ImageLumaA16(_)
            | DynamicImage::ImageRgb16(_)
            | DynamicImage::ImageRgba16(_)
    );
    let pixels: Vec<Rgb32> = if sixteen_bit {
        let rgb = img.into_rgb16();
        rgb.pixels()
            .map(|p| crate::color::Rgb::new(p[0], p[1], p[2]).map(|v| srgb_to_linear(f32::from(v) / 65535.0)))
            .collect()
    } else {
        let lut: Vec<f32> = (0..=255u8).map(|v| srgb_to_linear(f32::from(v) / 255.0)).collect();
        let rgb = img.into_rgb8();
        rgb.pixels().map(|p| Rgb32::new(lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize])).collect()
    };
    HdrImage::from_pixels(w, h, pixels).ok_or_else(|| "decoder returned the wrong pixel count".to_owned())
}

/// The name of the first chunk of a PNG file that a reader must understand but the format
/// does not define, as a person reads it: the png crate names it only in Rust's debug
/// form (`ChunkType { type: IDA«, critical: true, ... }`). Letters and digits are shown
/// as they are, other bytes as `\xAB`. `None` when the file holds no such chunk.
fn unknown_critical_chunk(bytes: &[u8]) -> Option<String> {
    let mut at = 8; // after the signature
    while let Some(head) = bytes.get(at..at + 8) {
        let name = &head[4..8];
        // A chunk whose first letter is upper-case (bit 5 clear) is critical.
        if name[0] & 0x20 == 0 && ![&b"IHDR"[..], b"PLTE", b"IDAT", b"IEND"].contains(&name) {
            return Some(
                name.iter()
                    .map(|&b| if b.is_ascii_alphanumeric() { char::from(b).to_string() } else { format!("\\x{b:02X}") })
                    .collect(),
            );
        }
        let length = u32::from_be_bytes([head[0], head[1], head[2], head[3]]) as usize;
        // Length, name, data and CRC.
        at = at.checked_add(12)?.checked_add(length)?;
    }
    None
}

/// Encodes `rgb8` (row-major RGB bytes, `width·height·3` of them).
pub(crate) fn encode_ldr(rgb8: &[u8], width: usize, height: usize, format: LdrFormat) -> Result<Vec<u8>, String> {
    let (w, h) = (
        u32::try_from(width).map_err(|_| format!("width {width} too large"))?,
        u32::try_from(height).map_err(|_| format!("height {height} too large"))?,
    );
    let mut out = Vec::new();
    let result = match format {
        LdrFormat::Png => PngEncoder::new(&mut out).write_image(rgb8, w, h, ExtendedColorType::Rgb8),
        LdrFormat::Jpeg => {
            JpegEncoder::new_with_quality(&mut out, JPEG_QUALITY).write_image(rgb8, w, h, ExtendedColorType::Rgb8)
        }
    };
    result.map_err(|e| e.to_string())?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::srgb::{linear_to_srgb, quantize_u8};

    #[test]
    fn png_round_trip_is_exact_in_8_bit_codes() {
        let rgb8: Vec<u8> = (0..4 * 3 * 3).map(|i| (i * 7) as u8).collect();
        let png = encode_ldr(&rgb8, 4, 3, LdrFormat::Png).unwrap();
        let img = decode_ldr(&png, LdrFormat::Png).unwrap();
        assert_eq!((img.width(), img.height()), (4, 3));
        let back: Vec<u8> =
            img.pixels().iter().flat_map(|c| c.to_array().map(|v| quantize_u8(linear_to_srgb(v)))).collect();
        assert_eq!(back, rgb8);
        // Code 128 decodes to the sRGB standard's linear value.
        let mid = decode_ldr(&encode_ldr(&[128, 128, 128], 1, 1, LdrFormat::Png).unwrap(), LdrFormat::Png).unwrap();
        assert!((mid.get(0, 0).r - 0.215_860_53).abs() < 1e-6);
    }

    #[test]
    fn sixteen_bit_grey_alpha_png_keeps_precision_and_drops_alpha() {
        let buf = ::image::ImageBuffer::<::image::LumaA<u16>, Vec<u16>>::from_raw(2, 1, vec![65535, 0, 32768, 65535])
            .unwrap();
        let mut png = Vec::new();
        DynamicImage::ImageLumaA16(buf).write_to(&mut std::io::Cursor::new(&mut png), ImageFormat::Png).unwrap();
        let img = decode_ldr(&png, LdrFormat::Png).unwrap();
        assert_eq!(img.get(0, 0), Rgb32::WHITE);
        let want = srgb_to_linear(32768.0 / 65535.0);
        assert_eq!(img.get(1, 0), Rgb32::gray(want));
    }

    #[test]
    fn jpeg_round_trip_is_close() {
        let rgb8 = vec![200u8; 8 * 8 * 3];
        let jpg = encode_ldr(&rgb8, 8, 8, LdrFormat::Jpeg).unwrap();
        let img = decode_ldr(&jpg, LdrFormat::Jpeg).unwrap();
        let want = srgb_to_linear(200.0 / 255.0);
        assert!(img.pixels().iter().all(|c| c.approx_eq(Rgb32::gray(want), 0.01)));
    }

    #[test]
    fn garbage_is_an_error() {
        assert!(decode_ldr(b"\x89PNG\r\n\x1a\nxx", LdrFormat::Png).is_err());
        assert!(decode_ldr(b"hello", LdrFormat::Jpeg).is_err());
    }
}
