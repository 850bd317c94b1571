//! Portable Float Map (PFM) files: the simplest lossless HDR format, and Raytracer.jl's.
//!
//! Layout: three text lines, then raw `f32` samples.
//! ```text
//! PF\n            (colour; "Pf" = one grey channel, expanded to RGB on reading)
//! <width> <height>\n
//! <scale>\n       (its sign is the byte order: negative = little-endian)
//! <width·height·channels f32 samples, rows from the BOTTOM of the image to the top>
//! ```
//! Reading is strict: each header line must be exactly what is shown (spaces or tabs may
//! separate and surround the numbers, a `\r` before each `\n` is tolerated), the scale must
//! be finite and non-zero (its magnitude is a brightness hint that lumen, like most readers,
//! ignores), and the data must be exactly `width·height·channels·4` bytes: trailing bytes
//! are an error, because they mean the header and the data disagree. The size is checked
//! against [`check_size`] and against the data length before anything is allocated.
//! Writing always produces little-endian colour PFM with scale −1.

use thiserror::Error;

use super::size::{check_size, SizeError};
use super::HdrImage;
use crate::color::Rgb32;

/// What was wrong with a PFM file; `at byte N` is the offset where the problem starts.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PfmError {
    /// The first line is not `PF` or `Pf`.
    #[error("bad magic at byte 0: expected \"PF\" (colour) or \"Pf\" (grey) on the first line, found {found:?}")]
    BadMagic {
        /// The first line as read (lossy UTF-8), or the file's first 16 bytes when it has no
        /// complete first line.
        found: String,
    },
    /// The file ends, or 256 bytes pass without a newline, before a header line is complete.
    #[error(
        "header ends early at byte {offset}: no complete {what} line (a line ending in a newline within 256 bytes)"
    )]
    MissingLine {
        /// Byte offset where the missing line should start.
        offset: usize,
        /// Which header line: `"size"` or `"scale"`.
        what: &'static str,
    },
    /// The size line is not two plain decimal integers.
    #[error("bad size line at byte {offset}: expected \"<width> <height>\" as two positive integers, found {found:?}")]
    BadDimensions {
        /// Byte offset of the size line.
        offset: usize,
        /// The line as read (lossy UTF-8 when it is not text).
        found: String,
    },
    /// The size parsed but is empty or over lumen's limits ([`check_size`]).
    #[error("bad size at byte {offset}: {cause}")]
    BadSize {
        /// Byte offset of the size line.
        offset: usize,
        /// Which limit the size broke.
        cause: SizeError,
    },
    /// The scale line is not a finite, non-zero number.
    #[error("bad scale line at byte {offset}: expected a finite non-zero number (negative = little-endian), found {found:?}")]
    BadScale {
        /// Byte offset of the scale line.
        offset: usize,
        /// The line as read (lossy UTF-8 when it is not text).
        found: String,
    },
    /// Fewer bytes of samples follow the header than its size and channel count need.
    #[error(
        "pixel data at byte {offset} is {actual} bytes long, but a {width}×{height} {kind} image needs {expected}"
    )]
    ShortData {
        /// Byte offset where the pixel data starts (just after the header).
        offset: usize,
        /// Width from the header, in pixels.
        width: usize,
        /// Height from the header, in pixels.
        height: usize,
        /// `"colour"` (`PF`, three channels) or `"grey"` (`Pf`, one).
        kind: &'static str,
        /// Bytes of pixel data the header calls for.
        expected: usize,
        /// Bytes of pixel data present.
        actual: usize,
    },
    /// More bytes follow the pixel data than the header accounts for.
    #[error("{extra} trailing bytes after the pixel data (which ends at byte {end})")]
    TrailingData {
        /// Byte offset where the pixel data should end.
        end: usize,
        /// Number of bytes after it.
        extra: usize,
    },
}

/// Longest header line we look for, so a binary file is rejected without a long scan.
const MAX_LINE: usize = 256;

/// Reads the next `\n`-terminated line starting at `*pos`, without the `\n` or a final `\r`.
fn next_line<'a>(bytes: &'a [u8], pos: &mut usize, what: &'static str) -> Result<(usize, &'a [u8]), PfmError> {
    let start = *pos;
    let rest = &bytes[start..];
    let len =
        rest.iter().take(MAX_LINE).position(|&b| b == b'\n').ok_or(PfmError::MissingLine { offset: start, what })?;
    *pos = start + len + 1;
    let line = &rest[..len];
    Ok((start, line.strip_suffix(b"\r").unwrap_or(line)))
}

fn lossy(line: &[u8]) -> String {
    String::from_utf8_lossy(line).into_owned()
}

fn parse_dimension(word: &str) -> Option<usize> {
    // Only plain decimal digits: no sign, no "0x", no exponent.
    (!word.is_empty() && word.bytes().all(|b| b.is_ascii_digit())).then(|| word.parse().ok()).flatten()
}

/// Decodes a PFM file held in memory.
///
/// ```
/// use lumen::image::{decode_pfm, encode_pfm, HdrImage};
/// use lumen::color::Rgb32;
/// let mut img = HdrImage::new(2, 1);
/// img.set(1, 0, Rgb32::new(0.5, 1.0, 8.0));
/// assert_eq!(decode_pfm(&encode_pfm(&img)).unwrap(), img);
/// assert!(decode_pfm(b"P6\n2 1\n255\n").is_err());
/// ```
pub fn decode_pfm(bytes: &[u8]) -> Result<HdrImage, PfmError> {
    let mut pos = 0;
    let magic = next_line(bytes, &mut pos, "magic")
        .map_err(|_| PfmError::BadMagic { found: lossy(&bytes[..bytes.len().min(16)]) })?;
    let channels = match magic.1 {
        b"PF" => 3,
        b"Pf" => 1,
        other => return Err(PfmError::BadMagic { found: lossy(other) }),
    };
    let (offset, line) = next_line(bytes, &mut pos, "size")?;
    let text = std::str::from_utf8(line).map_err(|_| PfmError::BadDimensions { offset, found: lossy(line) })?;
    let words: Vec<&str> = text.split([' ', '\t']).filter(|w| !w.is_empty()).collect();
    let (width, height) = match words.as_slice() {
        [w, h] => match (parse_dimension(w), parse_dimension(h)) {
            (Some(w), Some(h)) => (w, h),
            _ => return Err(PfmError::BadDimensions { offset, found: text.to_owned() }),
        },
        _ => return Err(PfmError::BadDimensions { offset, found: text.to_owned() }),
    };
    let count = check_size(width, height).map_err(|cause| PfmError::BadSize { offset, cause })?;
    let (offset, line) = next_line(bytes, &mut pos, "scale")?;
    let text = std::str::from_utf8(line).map_err(|_| PfmError::BadScale { offset, found: lossy(line) })?;
    let scale: f32 = match text.trim_matches([' ', '\t']).parse::<f32>() {
        Ok(s) if s.is_finite() && s != 0.0 => s,
        _ => return Err(PfmError::BadScale { offset, found: text.to_owned() }),
    };
    let little_endian = scale < 0.0;

    let data = &bytes[pos..];
    // check_size bounds count by 2^28, so this product cannot overflow a 64-bit usize; the
    // checked form keeps 32-bit targets honest.
    let expected = count
        .checked_mul(channels * 4)
        .ok_or(PfmError::BadSize { offset, cause: SizeError::TooLarge { width, height } })?;
    let kind = if channels == 3 { "colour" } else { "grey" };
    if data.len() < expected {
        return Err(PfmError::ShortData { offset: pos, width, height, kind, expected, actual: data.len() });
    }
    if data.len() > expected {
        return Err(PfmError::TrailingData { end: pos + expected, extra: data.len() - expected });
    }

    let read = |chunk: &[u8]| {
        let b = [chunk[0], chunk[1], chunk[2], chunk[3]];
        if little_endian {
            f32::from_le_bytes(b)
        } else {
            f32::from_be_bytes(b)
        }
    };
    let mut pixels = Vec::with_capacity(count);
    // File rows run bottom to top; image rows top to bottom.
    for row in data.chunks_exact(width * channels * 4).rev() {
        pixels.extend(row.chunks_exact(channels * 4).map(|px| {
            if channels == 3 {
                Rgb32::new(read(&px[0..4]), read(&px[4..8]), read(&px[8..12]))
            } else {
                Rgb32::gray(read(px))
            }
        }));
    }
    Ok(HdrImage::from_pixels(width, height, pixels).expect("pixel count checked against the header"))
}

/// Encodes an image as little-endian colour PFM (scale −1), rows bottom to top.
/// Samples are written as they are, NaN and infinities included.
pub fn encode_pfm(img: &HdrImage) -> Vec<u8> {
    let header = format!("PF\n{} {}\n-1.0\n", img.width(), img.height());
    let mut out = Vec::with_capacity(header.len() + img.pixels().len() * 12);
    out.extend_from_slice(header.as_bytes());
    if img.width() > 0 {
        for row in img.pixels().chunks_exact(img.width()).rev() {
            for c in row {
                for v in c.to_array() {
                    out.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The 3×2 image Raytracer.jl's PFM tests use, built by hand in both byte orders.
    fn reference_image() -> HdrImage {
        let px = [
            (1.0e1, 2.0e1, 3.0e1),
            (4.0e1, 5.0e1, 6.0e1),
            (7.0e1, 8.0e1, 9.0e1),
            (1.0e2, 2.0e2, 3.0e2),
            (4.0e2, 5.0e2, 6.0e2),
            (7.0e2, 8.0e2, 9.0e2),
        ];
        HdrImage::from_pixels(3, 2, px.iter().map(|&(r, g, b)| Rgb32::new(r, g, b)).collect()).unwrap()
    }

    /// Raytracer.jl's `reference_le.pfm`: header then the bottom row (100..900) first.
    const REFERENCE_LE: &[u8] = &[
        0x50, 0x46, 0x0a, 0x33, 0x20, 0x32, 0x0a, 0x2d, 0x31, 0x2e, 0x30, 0x0a, 0x00, 0x00, 0xc8, 0x42, 0x00, 0x00,
        0x48, 0x43, 0x00, 0x00, 0x96, 0x43, 0x00, 0x00, 0xc8, 0x43, 0x00, 0x00, 0xfa, 0x43, 0x00, 0x00, 0x16, 0x44,
        0x00, 0x00, 0x2f, 0x44, 0x00, 0x00, 0x48, 0x44, 0x00, 0x00, 0x61, 0x44, 0x00, 0x00, 0x20, 0x41, 0x00, 0x00,
        0xa0, 0x41, 0x00, 0x00, 0xf0, 0x41, 0x00, 0x00, 0x20, 0x42, 0x00, 0x00, 0x48, 0x42, 0x00, 0x00, 0x70, 0x42,
        0x00, 0x00, 0x8c, 0x42, 0x00, 0x00, 0xa0, 0x42, 0x00, 0x00, 0xb4, 0x42,
    ];
    /// Raytracer.jl's `reference_be.pfm`.
    const REFERENCE_BE: &[u8] = &[
        0x50, 0x46, 0x0a, 0x33, 0x20, 0x32, 0x0a, 0x31, 0x2e, 0x30, 0x0a, 0x42, 0xc8, 0x00, 0x00, 0x43, 0x48, 0x00,
        0x00, 0x43, 0x96, 0x00, 0x00, 0x43, 0xc8, 0x00, 0x00, 0x43, 0xfa, 0x00, 0x00, 0x44, 0x16, 0x00, 0x00, 0x44,
        0x2f, 0x00, 0x00, 0x44, 0x48, 0x00, 0x00, 0x44, 0x61, 0x00, 0x00, 0x41, 0x20, 0x00, 0x00, 0x41, 0xa0, 0x00,
        0x00, 0x41, 0xf0, 0x00, 0x00, 0x42, 0x20, 0x00, 0x00, 0x42, 0x48, 0x00, 0x00, 0x42, 0x70, 0x00, 0x00, 0x42,
        0x8c, 0x00, 0x00, 0x42, 0xa0, 0x00, 0x00, 0x42, 0xb4, 0x00, 0x00,
    ];

    #[test]
    fn reads_both_byte_orders() {
        assert_eq!(decode_pfm(REFERENCE_LE).unwrap(), reference_image());
        assert_eq!(decode_pfm(REFERENCE_BE).unwrap(), reference_image());
    }

    #[test]
    fn writes_little_endian_bottom_row_first() {
        // Our header spells the scale "-1.0" like Raytracer.jl, so the bytes agree exactly.
        assert_eq!(encode_pfm(&reference_image()), REFERENCE_LE);
    }

    #[test]
    fn reads_grey_pfm_and_crlf_header() {
        let mut bytes = b"Pf\r\n2 1\r\n1\r\n".to_vec();
        bytes.extend_from_slice(&0.25f32.to_be_bytes());
        bytes.extend_from_slice(&4.0f32.to_be_bytes());
        let img = decode_pfm(&bytes).unwrap();
        assert_eq!(img.pixels(), &[Rgb32::gray(0.25), Rgb32::gray(4.0)]);
    }

    fn header_then(header: &str, data_len: usize) -> Vec<u8> {
        let mut v = header.as_bytes().to_vec();
        v.resize(v.len() + data_len, 0);
        v
    }

    #[test]
    fn rejects_bad_headers_with_clear_errors() {
        let err = |b: &[u8]| decode_pfm(b).unwrap_err();
        assert!(matches!(err(b"P6\n1 1\n-1\n"), PfmError::BadMagic { .. }));
        assert!(matches!(err(b""), PfmError::BadMagic { .. }));
        assert!(matches!(err(b"PF"), PfmError::BadMagic { .. }));
        assert!(matches!(err(b"PF\n"), PfmError::MissingLine { offset: 3, what: "size" }));
        assert!(matches!(err(b"PF\n3\n-1\n"), PfmError::BadDimensions { offset: 3, .. }));
        assert!(matches!(err(b"PF\n3 2 1\n-1\n"), PfmError::BadDimensions { .. }));
        assert!(matches!(err(b"PF\n-3 2\n-1\n"), PfmError::BadDimensions { .. }));
        assert!(matches!(err(b"PF\n3 x\n-1\n"), PfmError::BadDimensions { .. }));
        assert!(matches!(err(b"PF\n0 2\n-1\n"), PfmError::BadSize { cause: SizeError::Empty { .. }, .. }));
        assert!(matches!(
            err(b"PF\n99999999999 99999999999\n-1\n"),
            PfmError::BadSize { cause: SizeError::TooLarge { .. }, .. }
        ));
        assert!(matches!(err(b"PF\n1 1\n"), PfmError::MissingLine { what: "scale", .. }));
        assert!(matches!(err(&header_then("PF\n1 1\n0\n", 12)), PfmError::BadScale { offset: 7, .. }));
        assert!(matches!(err(&header_then("PF\n1 1\nnan\n", 12)), PfmError::BadScale { .. }));
        assert!(matches!(err(&header_then("PF\n1 1\ninf\n", 12)), PfmError::BadScale { .. }));
        assert!(matches!(err(&header_then("PF\n1 1\nabc\n", 12)), PfmError::BadScale { .. }));
    }

    #[test]
    fn data_length_must_match_exactly() {
        let short = decode_pfm(&header_then("PF\n2 1\n-1\n", 23)).unwrap_err();
        assert_eq!(
            short,
            PfmError::ShortData { offset: 10, width: 2, height: 1, kind: "colour", expected: 24, actual: 23 }
        );
        let long = decode_pfm(&header_then("PF\n2 1\n-1\n", 25)).unwrap_err();
        assert_eq!(long, PfmError::TrailingData { end: 34, extra: 1 });
        assert!(decode_pfm(&header_then("PF\n2 1\n-1\n", 24)).is_ok());
        // A huge (but allowed) size with no data is refused without allocating.
        assert!(matches!(decode_pfm(b"PF\n65536 4096\n-1\n"), Err(PfmError::ShortData { .. })));
    }

    #[test]
    fn messages_name_the_problem() {
        let e = decode_pfm(b"PF\n3 two\n-1\n").unwrap_err().to_string();
        assert!(e.contains("byte 3") && e.contains("3 two"), "{e}");
    }

    #[test]
    fn non_finite_samples_round_trip() {
        let img =
            HdrImage::from_pixels(2, 1, vec![Rgb32::new(f32::NAN, f32::INFINITY, -0.0), Rgb32::gray(-3.0)]).unwrap();
        let back = decode_pfm(&encode_pfm(&img)).unwrap();
        assert!(back.get(0, 0).r.is_nan());
        assert_eq!(back.get(0, 0).g, f32::INFINITY);
        assert_eq!(back.get(1, 0), Rgb32::gray(-3.0));
    }

    proptest! {
        #[test]
        fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..256)) {
            let _ = decode_pfm(&bytes);
        }

        #[test]
        fn random_data_after_a_plausible_header_never_panics(
            w in 0usize..6, h in 0usize..6, scale in prop::sample::select(vec!["-1", "1", "0", "-0.5", "x"]),
            data in proptest::collection::vec(any::<u8>(), 0..400),
        ) {
            let mut bytes = format!("PF\n{w} {h}\n{scale}\n").into_bytes();
            bytes.extend_from_slice(&data);
            let ok = w > 0 && h > 0 && scale != "0" && scale != "x" && data.len() == w * h * 12;
            prop_assert_eq!(decode_pfm(&bytes).is_ok(), ok);
        }

        #[test]
        fn truncations_are_errors(cut in 0usize..REFERENCE_BE.len()) {
            // The big-endian file is one byte shorter ("1.0" against "-1.0").
            prop_assert!(decode_pfm(&REFERENCE_LE[..cut + 1]).is_err());
            prop_assert!(decode_pfm(&REFERENCE_BE[..cut]).is_err());
        }

        #[test]
        fn round_trip(w in 1usize..5, h in 1usize..5, seed in proptest::collection::vec(-1e6f32..1e6, 48)) {
            let px = (0..w * h).map(|i| Rgb32::new(seed[3 * i], seed[3 * i + 1], seed[3 * i + 2])).collect();
            let img = HdrImage::from_pixels(w, h, px).unwrap();
            prop_assert_eq!(decode_pfm(&encode_pfm(&img)).unwrap(), img);
        }
    }
}
