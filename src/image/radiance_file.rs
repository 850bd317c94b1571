//! Radiance RGBE (`.hdr`) files through the `image` crate, but for the widths whose
//! scanlines are written flat (see [`RLE_WIDTHS`]). RGBE stores no negative values:
//! negative channels are written as 0.

use std::ops::RangeInclusive;

use ::image::codecs::hdr::HdrEncoder;
use ::image::ImageFormat;

use super::HdrImage;
use crate::color::Rgb32;

/// Widths a run-length scanline can have: its marker holds the width in 15 bits, and a
/// reader takes a scanline of any other width as flat. The `image` crate's encoder also
/// run-length encodes width 32768, whose marker readers then take for a pixel ("the file
/// ends early"), so lumen writes the other widths itself.
const RLE_WIDTHS: RangeInclusive<usize> = 8..=32767;

/// The smallest value RGBE holds, 2⁻¹²⁸ (exponent byte 1, mantissa 128): a pixel whose
/// largest channel is below it is written black, where the crate wraps its exponent byte
/// around and writes about 2¹²⁰.
const RGBE_MIN: f32 = f32::from_bits(1 << 21);
/// The largest value RGBE holds, 255·2¹¹⁹ (exponent byte 255, mantissa 255): larger
/// channels are clamped to it, where the crate's exponent byte wraps to 0 (black).
const RGBE_MAX: f32 = f32::from_bits(0x7eff_0000);

pub(crate) fn decode_radiance(bytes: &[u8]) -> Result<HdrImage, String> {
    // Beside the decoded f32 image: our copy of it.
    let img = super::size::decode_within_limits(bytes, ImageFormat::Hdr, 12)
        .map_err(|message| if header_is_cut(bytes) { "EOF in header".to_owned() } else { message })?
        .into_rgb32f();
    let (w, h) = (img.width() as usize, img.height() as usize);
    let pixels = img.pixels().map(|p| Rgb32::new(p[0], p[1], p[2])).collect();
    HdrImage::from_pixels(w, h, pixels).ok_or_else(|| "decoder returned the wrong pixel count".to_owned())
}

/// True when `bytes` start like a Radiance file but end within its header, where the crate
/// reads the last line cut short as it is: "The image format `32` is not supported" for
/// `FORMAT=32`, "Dimensions line too short" for `-Y 30`.
fn header_is_cut(bytes: &[u8]) -> bool {
    // The header ends with a blank line, then the dimensions line.
    let Some(blank) = bytes.windows(2).position(|w| w == b"\n\n") else {
        return bytes.starts_with(b"#?");
    };
    bytes.starts_with(b"#?") && !bytes[blank + 2..].contains(&b'\n')
}

pub(crate) fn encode_radiance(img: &HdrImage) -> Result<Vec<u8>, String> {
    let pixels: Vec<[f32; 3]> = img.pixels().iter().map(|&c| within_rgbe(c)).collect();
    if !RLE_WIDTHS.contains(&img.width()) {
        return Ok(encode_flat(&pixels, img.width(), img.height()));
    }
    let pixels: Vec<::image::Rgb<f32>> = pixels.into_iter().map(::image::Rgb).collect();
    let mut out = Vec::new();
    HdrEncoder::new(&mut out).encode(&pixels, img.width(), img.height()).map_err(|e| e.to_string())?;
    Ok(out)
}

/// `c` as RGBE can hold it: negative channels 0, a pixel too dark for RGBE black, channels
/// too bright for it clamped (see [`RGBE_MIN`], [`RGBE_MAX`]).
fn within_rgbe(c: Rgb32) -> [f32; 3] {
    let c = c.map(|v| v.max(0.0));
    if c.max_component() < RGBE_MIN {
        return [0.0; 3];
    }
    c.map(|v| v.min(RGBE_MAX)).to_array()
}

/// A Radiance file with flat scanlines: the header, then 4 bytes a pixel, rows top to
/// bottom. `pixels` must be [`within_rgbe`].
fn encode_flat(pixels: &[[f32; 3]], width: usize, height: usize) -> Vec<u8> {
    let header = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {height} +X {width}\n");
    let mut out = Vec::with_capacity(header.len() + 4 * pixels.len());
    out.extend_from_slice(header.as_bytes());
    for &c in pixels {
        out.extend_from_slice(&rgbe(c));
    }
    out
}

/// The `image` crate's RGBE conversion (its encoder's `to_rgbe8`), so that a value is
/// written alike whatever the width, with one change: where `log2` rounds a largest channel
/// just under a power of two up to it, the crate's largest mantissa is 127, and a flat
/// scanline that starts with (2, 2, under 128) reads as a run-length one; here the
/// exponent is lowered instead. `c` must be [`within_rgbe`].
fn rgbe(c: [f32; 3]) -> [u8; 4] {
    let largest = c[0].max(c[1]).max(c[2]);
    if largest <= 0.0 {
        return [0; 4];
    }
    let mut exp = (largest.log2().floor() as i32 + 1).clamp(-127, 127);
    if largest < 0.5 * 2f32.powi(exp) && exp > -127 {
        exp -= 1;
    }
    let scale = 2f32.powi(exp);
    let mantissa = |v: f32| (v / scale * 256.0).trunc() as u8;
    [mantissa(c[0]), mantissa(c[1]), mantissa(c[2]), (exp + 128) as u8]
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

    /// Values RGBE holds exactly, so that a round trip gives them back unchanged.
    fn exact_pixel(i: usize) -> Rgb32 {
        [Rgb32::new(1.0, 0.5, 0.25), Rgb32::gray(1000.0), Rgb32::BLACK, Rgb32::new(0.0, 3.0, 0.0), Rgb32::gray(0.125)]
            [i % 5]
    }

    #[test]
    fn widths_at_the_run_length_limit_round_trip() {
        // 32768 was written with a run-length marker that no reader takes as one.
        for width in [1, 7, 8, 32767, 32768, 32769] {
            let img = HdrImage::from_fn(width, 1, |c, _| exact_pixel(c));
            let back = decode_radiance(&encode_radiance(&img).unwrap()).unwrap_or_else(|e| panic!("{width}: {e}"));
            assert_eq!((back.width(), back.height()), (width, 1));
            assert!(back == img, "width {width}: the pixels changed");
        }
        let img = HdrImage::from_fn(32768, 2, |c, r| exact_pixel(c + r));
        assert!(decode_radiance(&encode_radiance(&img).unwrap()).unwrap() == img);
    }

    #[test]
    fn flat_scanlines_convert_as_the_crate_does() {
        // Across the range, as many mantissas and exponents as possible; the crate writes
        // widths under 8 flat, so its bytes can be compared with ours one for one.
        let mut pixels: Vec<[f32; 3]> = (-250..250)
            .map(|i| {
                let v = 1.37f32.powi(i);
                [v, 0.3 * v, v * 0.9]
            })
            .collect();
        pixels.extend([
            [1.0, 0.0, 0.0],
            [0.0, 0.0, 0.5],
            [255.0, 1.0, 7.0],
            [RGBE_MAX, 1.0, 0.0],
            [RGBE_MIN, 0.0, 0.0],
        ]);
        let pixels: Vec<[f32; 3]> = pixels.into_iter().map(|p| within_rgbe(Rgb32::new(p[0], p[1], p[2]))).collect();
        let theirs = {
            let rgb: Vec<::image::Rgb<f32>> = pixels.iter().map(|&p| ::image::Rgb(p)).collect();
            let mut out = Vec::new();
            HdrEncoder::new(&mut out).encode(&rgb, 1, rgb.len()).unwrap();
            out.split_off(out.len() - 4 * rgb.len())
        };
        let mut compared = 0;
        for (p, want) in pixels.iter().zip(theirs.chunks(4)) {
            // The crate's mantissas are un-normalised where log2 rounds up; ours are not.
            if want[..3].iter().any(|&m| m >= 128) {
                assert_eq!(rgbe(*p), want, "{p:?}");
                compared += 1;
            }
            assert!(rgbe(*p)[..3].iter().any(|&m| m >= 128) || *p == [0.0; 3], "{p:?}: {:?}", rgbe(*p));
        }
        assert!(compared > 450, "{compared}");
    }

    #[test]
    fn a_flat_scanline_never_starts_like_a_run_length_one() {
        // log2 rounds 1024·(1 − 2⁻²³) up to 10; the crate wrote (2, 2, 127, 139), which a
        // reader takes for a run-length marker.
        let first = Rgb32::new(16.0, 16.0, 1024.0 * (1.0 - f32::EPSILON));
        for width in [2, 32768] {
            let img = HdrImage::from_fn(width, 1, |c, _| if c == 0 { first } else { Rgb32::gray(1.0) });
            let back = decode_radiance(&encode_radiance(&img).unwrap()).unwrap();
            assert!(back.get(0, 0).approx_eq(first, 8.0), "{width}: {:?}", back.get(0, 0));
            assert_eq!(back.get(width - 1, 0), Rgb32::gray(1.0));
        }
    }

    #[test]
    fn values_beyond_rgbe_are_black_or_clamped_not_wrapped() {
        // Flat (3) and run-length (8) scanlines.
        for width in [3, 8] {
            let img = HdrImage::from_fn(width, 1, |c, _| match c {
                0 => Rgb32::new(1e-39, 0.0, 0.0),
                1 => Rgb32::new(3e38, 1.0, 0.0),
                _ => Rgb32::gray(2f32.powi(-127) * 0.5),
            });
            let back = decode_radiance(&encode_radiance(&img).unwrap()).unwrap();
            assert_eq!(back.get(0, 0), Rgb32::BLACK, "{width}");
            assert_eq!(back.get(1, 0).r, RGBE_MAX, "{width}");
            assert_eq!(back.get(2, 0), Rgb32::gray(RGBE_MIN), "{width}");
        }
    }

    #[test]
    fn garbage_is_an_error() {
        assert!(decode_radiance(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X").is_err());
        assert!(decode_radiance(b"P6 1 1 255\n").is_err());
        // A header cut short, wherever it is cut, is said alike (decoder_words reads it).
        for cut in ["#?RADIANCE\n# Rust HD", "#?RADIANCE\nFORMAT=32", "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1"] {
            assert_eq!(decode_radiance(cut.as_bytes()).unwrap_err(), "EOF in header", "{cut:?}");
        }
        assert!(decode_radiance(b"#?RADIANCE\nFORMAT=16-bit\n\n-Y 1 +X 1\n").unwrap_err().contains("16-bit"));
    }
}
