//! Radiance RGBE (`.hdr`) files through the `image` crate. RGBE stores no negative
//! values: negative channels are written as 0.

use ::image::codecs::hdr::HdrEncoder;
use ::image::ImageFormat;

use super::HdrImage;
use crate::color::Rgb32;

pub(crate) fn decode_radiance(bytes: &[u8]) -> Result<HdrImage, String> {
    // Beside the decoded f32 image: our copy of it.
    let img = super::size::decode_within_limits(bytes, ImageFormat::Hdr, 12)?.into_rgb32f();
    let (w, h) = (img.width() as usize, img.height() as usize);
    let pixels = img.pixels().map(|p| Rgb32::new(p[0], p[1], p[2])).collect();
    HdrImage::from_pixels(w, h, pixels).ok_or_else(|| "decoder returned the wrong pixel count".to_owned())
}

pub(crate) fn encode_radiance(img: &HdrImage) -> Result<Vec<u8>, String> {
    let pixels: Vec<::image::Rgb<f32>> =
        img.pixels().iter().map(|c| ::image::Rgb(c.map(|v| v.max(0.0)).to_array())).collect();
    let mut out = Vec::new();
    HdrEncoder::new(&mut out).encode(&pixels, img.width(), img.height()).map_err(|e| e.to_string())?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_within_rgbe_precision() {
        // RGBE keeps 8 mantissa bits per channel relative to the largest channel.
        let img = HdrImage::from_fn(4, 3, |c, r| Rgb32::new(1.0 + c as f32, 0.5 * r as f32 + 0.25, 100.0));
        let back = decode_radiance(&encode_radiance(&img).unwrap()).unwrap();
        assert_eq!((back.width(), back.height()), (4, 3));
        for (a, b) in img.pixels().iter().zip(back.pixels()) {
            assert!(a.approx_eq(*b, a.max_component() / 128.0), "{a:?} vs {b:?}");
        }
    }

    #[test]
    fn negative_channels_become_zero() {
        let img = HdrImage::from_pixels(1, 1, vec![Rgb32::new(-1.0, 0.5, 1.0)]).unwrap();
        let back = decode_radiance(&encode_radiance(&img).unwrap()).unwrap();
        assert_eq!(back.get(0, 0), Rgb32::new(0.0, 0.5, 1.0));
    }

    #[test]
    fn garbage_is_an_error() {
        assert!(decode_radiance(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X").is_err());
        assert!(decode_radiance(b"P6 1 1 255\n").is_err());
    }
}
