//! Reading and writing image files, the format chosen by the file extension.

use std::borrow::Cow;
use std::path::Path;

use super::atomic_file::write_atomically;
use super::error::ImageError;
use super::exr_file::{decode_exr, decode_exr_with_attributes, encode_exr_with_attributes, ExrDecodeError};
use super::ldr_file::{decode_ldr, encode_ldr, LdrFormat};
use super::pfm::{decode_pfm, encode_pfm};
use super::radiance_file::{decode_radiance, encode_radiance};
use super::render_metadata::RenderMetadata;
use super::size::{check_size, SizeError, MAX_SIDE};
use super::tone_map::ToneMap;
use super::HdrImage;
use crate::color::Rgb32;

/// The image file formats lumen reads and writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageFormat {
    /// `.pfm`: Portable Float Map, linear f32.
    Pfm,
    /// `.exr`: OpenEXR, linear f32 (f16 and u32 also read).
    Exr,
    /// `.hdr`: Radiance RGBE, linear, 8-bit shared-exponent.
    RadianceHdr,
    /// `.png`: 8-bit sRGB (tone-mapped on writing).
    Png,
    /// `.jpg`, `.jpeg`: 8-bit sRGB (tone-mapped on writing).
    Jpeg,
}

impl ImageFormat {
    /// The format named by `path`'s extension (case-insensitive).
    pub fn from_path(path: &Path) -> Result<Self, ImageError> {
        let ext = path.extension().map(|e| e.to_string_lossy().into_owned());
        match ext.as_deref().map(str::to_ascii_lowercase).as_deref() {
            Some("pfm") => Ok(Self::Pfm),
            Some("exr") => Ok(Self::Exr),
            Some("hdr") => Ok(Self::RadianceHdr),
            Some("png") => Ok(Self::Png),
            Some("jpg" | "jpeg") => Ok(Self::Jpeg),
            _ => Err(ImageError::UnsupportedExtension { path: path.to_owned(), ext }),
        }
    }

    /// True for the formats that store linear radiance (no tone mapping).
    pub fn is_hdr(self) -> bool {
        matches!(self, Self::Pfm | Self::Exr | Self::RadianceHdr)
    }

    /// The largest width or height a file of this format holds: lumen's [`MAX_SIDE`] but for
    /// JPEG, whose header holds each side in 16 bits.
    pub fn max_side(self) -> usize {
        match self {
            Self::Jpeg => 65535,
            _ => MAX_SIDE,
        }
    }

    /// A short name for messages.
    pub fn name(self) -> &'static str {
        match self {
            Self::Pfm => "PFM",
            Self::Exr => "OpenEXR",
            Self::RadianceHdr => "Radiance HDR",
            Self::Png => "PNG",
            Self::Jpeg => "JPEG",
        }
    }
}

/// True when `path` names a linear HDR format (`.pfm`, `.exr`, `.hdr`, any case).
///
/// ```
/// use lumen::image::is_hdr_path;
/// use std::path::Path;
/// assert!(is_hdr_path(Path::new("out.EXR")));
/// assert!(!is_hdr_path(Path::new("out.png")));
/// assert!(!is_hdr_path(Path::new("out")));
/// ```
pub fn is_hdr_path(path: &Path) -> bool {
    ImageFormat::from_path(path).is_ok_and(ImageFormat::is_hdr)
}

/// What [`write_image`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WriteReport {
    /// The format written, chosen by the path's extension.
    pub format: ImageFormat,
    /// Pixels with a NaN or infinite channel; they were written as black.
    pub non_finite: usize,
}

/// Reads an image file; the format comes from the extension (see [`ImageFormat`]).
/// 8-bit files are decoded from sRGB to linear values.
///
/// ```
/// use lumen::image::{read_image, write_image, HdrImage, ToneMap};
/// use lumen::color::Rgb32;
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("two.pfm");
/// let img = HdrImage::from_fn(2, 1, |c, _| Rgb32::gray(c as f32 + 0.5));
/// let report = write_image(&path, &img, &ToneMap::default()).unwrap();
/// assert_eq!(report.non_finite, 0);
/// assert_eq!(read_image(&path).unwrap(), img);
/// let err = read_image(&dir.path().join("x.tga")).unwrap_err().to_string();
/// assert!(err.contains("x.tga") && err.contains(".tga") && err.contains(".exr"), "{err}");
/// ```
pub fn read_image(path: &Path) -> Result<HdrImage, ImageError> {
    let format = ImageFormat::from_path(path)?;
    let bytes = crate::regular_file::read(path).map_err(|cause| ImageError::Read { path: path.to_owned(), cause })?;
    let decode_err = |message: String| ImageError::Decode {
        path: path.to_owned(),
        format: format.name(),
        message: decoder_words(format.name(), &message),
    };
    let img = match format {
        ImageFormat::Pfm => decode_pfm(&bytes).map_err(|cause| ImageError::Pfm { path: path.to_owned(), cause })?,
        ImageFormat::Exr => decode_exr(&bytes).map_err(|e| exr_error(path, e))?,
        ImageFormat::RadianceHdr => decode_radiance(&bytes).map_err(decode_err)?,
        ImageFormat::Png => decode_ldr(&bytes, LdrFormat::Png).map_err(decode_err)?,
        ImageFormat::Jpeg => decode_ldr(&bytes, LdrFormat::Jpeg).map_err(decode_err)?,
    };
    check_size(img.width(), img.height()).map_err(|cause| ImageError::Size { path: path.to_owned(), cause })?;
    Ok(img)
}

/// A decoder's message as a person reads it, on one line: the image crate's "Format error
/// decoding Png:" prefix and zune-jpeg's "I/O errors" dropped (the error already names the
/// format), and a read past the end, which the decoders report as an I/O detail ("failed to
/// fill whole buffer", "Not enough bytes, expected 162 but found 31", "EOF in header"),
/// said as what it means.
fn decoder_words(format: &str, message: &str) -> String {
    let message = message.trim();
    let message = match message.split_once(": ") {
        Some((prefix, rest)) if prefix.starts_with("Format error decoding ") => rest.trim(),
        _ => message,
    };
    let message = message.strip_prefix("I/O errors ").unwrap_or(message);
    const ENDS_EARLY: [&str; 6] = [
        "failed to fill whole buffer",
        "reference to missing bytes",
        "unexpected end of file",
        "Not enough bytes",
        "EOF in header",
        "EOF in dimensions line",
    ];
    if ENDS_EARLY.iter().any(|m| message.contains(m)) {
        return format!("the file ends early (cut short, or not a whole {format} file)");
    }
    one_line(message)
}

/// `message`'s lines joined with "; " (zune-jpeg's end with a newline, and the image crate
/// puts an encoder's cause on a line of its own), so that an error stays one line.
fn one_line(message: &str) -> String {
    crate::printable::one_line(message, "; ", usize::MAX)
}

/// An encoder's message as a person reads it: see [`decoder_words`].
fn encoder_words(message: &str) -> String {
    let message = message.trim();
    let message = match message.split_once(':') {
        Some((prefix, rest)) if prefix.starts_with("Format error encoding ") => rest.trim(),
        _ => message,
    };
    one_line(message)
}

fn exr_error(path: &Path, e: ExrDecodeError) -> ImageError {
    let decode_err = |message: String| ImageError::Decode {
        path: path.to_owned(),
        format: "OpenEXR",
        message: decoder_words("OpenEXR", &message),
    };
    match e {
        ExrDecodeError::Size(cause) => ImageError::Size { path: path.to_owned(), cause },
        ExrDecodeError::Other(message) => decode_err(message),
        ExrDecodeError::Memory(e) => decode_err(e.to_string()),
    }
}

/// Reads an EXR file that `lumen render` wrote, with its render metadata (what `lumen merge`
/// combines): an error naming the file for another format, or an EXR without lumen's
/// attributes.
pub fn read_render_part(path: &Path) -> Result<(HdrImage, RenderMetadata), ImageError> {
    let format = ImageFormat::from_path(path)?;
    if format != ImageFormat::Exr {
        return Err(ImageError::Metadata {
            path: path.to_owned(),
            message: format!("a {} file cannot carry lumen's render metadata; shards must be .exr", format.name()),
        });
    }
    let bytes = crate::regular_file::read(path).map_err(|cause| ImageError::Read { path: path.to_owned(), cause })?;
    let (img, attrs) = decode_exr_with_attributes(&bytes).map_err(|e| exr_error(path, e))?;
    check_size(img.width(), img.height()).map_err(|cause| ImageError::Size { path: path.to_owned(), cause })?;
    let meta = RenderMetadata::from_attributes(&attrs)
        .map_err(|e| ImageError::Metadata { path: path.to_owned(), message: e.to_string() })?;
    Ok((img, meta))
}

/// Checks that an image of `width × height` pixels can be written to `path`: within lumen's
/// limits ([`check_size`]) and the format's ([`ImageFormat::max_side`]). [`write_image`]
/// checks this before tone mapping; a command that knows the size before its work calls it
/// then, so that a 65536-pixel-wide JPEG is refused before the render rather than after.
///
/// ```
/// use lumen::image::check_output_size;
/// use std::path::Path;
/// assert!(check_output_size(Path::new("wide.png"), 65536, 1).is_ok());
/// let e = check_output_size(Path::new("wide.jpg"), 65536, 1).unwrap_err().to_string();
/// assert!(e.starts_with("wide.jpg: ") && e.contains("at most 65535"), "{e}");
/// ```
pub fn check_output_size(path: &Path, width: usize, height: usize) -> Result<(), ImageError> {
    let format = ImageFormat::from_path(path)?;
    let size_err = |cause| ImageError::Size { path: path.to_owned(), cause };
    check_size(width, height).map_err(size_err)?;
    let max_side = format.max_side();
    if width > max_side || height > max_side {
        return Err(size_err(SizeError::TooLargeForFormat { width, height, format: format.name(), max_side }));
    }
    Ok(())
}

/// Writes an image atomically (temporary file in the same directory, then rename: on any
/// error neither the output nor a temporary file remains). HDR formats get the linear
/// values; PNG and JPEG get the image tone-mapped by `tm`. NaN/Inf pixels are written as
/// black and counted in the report.
pub fn write_image(path: &Path, img: &HdrImage, tm: &ToneMap) -> Result<WriteReport, ImageError> {
    write_image_with(path, img, tm, None)
}

/// [`write_image`], with lumen's render metadata in the header when the file is EXR (the
/// other formats have no place for it).
pub fn write_image_with(
    path: &Path,
    img: &HdrImage,
    tm: &ToneMap,
    meta: Option<&RenderMetadata>,
) -> Result<WriteReport, ImageError> {
    let format = ImageFormat::from_path(path)?;
    let owned = || path.to_owned();
    check_output_size(path, img.width(), img.height())?;
    let encode_err =
        |message: String| ImageError::Encode { path: owned(), format: format.name(), message: encoder_words(&message) };
    let non_finite = img.non_finite_count();
    let bytes = if format.is_hdr() {
        let clean: Cow<HdrImage> = if non_finite == 0 {
            Cow::Borrowed(img)
        } else {
            Cow::Owned(img.map(|c| if c.is_finite() { c } else { Rgb32::BLACK }))
        };
        match format {
            ImageFormat::Pfm => encode_pfm(&clean),
            ImageFormat::Exr => {
                let attrs = meta.map(RenderMetadata::to_attributes).unwrap_or_default();
                encode_exr_with_attributes(&clean, attrs).map_err(encode_err)?
            }
            _ => encode_radiance(&clean).map_err(encode_err)?,
        }
    } else {
        let mapped = tm.apply(img).map_err(|cause| ImageError::ToneMap { path: owned(), cause })?;
        let ldr = if format == ImageFormat::Png { LdrFormat::Png } else { LdrFormat::Jpeg };
        encode_ldr(&mapped.to_rgb8(), img.width(), img.height(), ldr).map_err(encode_err)?
    };
    write_atomically(path, &bytes).map_err(|cause| ImageError::Write { path: owned(), cause })?;
    Ok(WriteReport { format, non_finite })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn nan_image() -> HdrImage {
        HdrImage::from_pixels(2, 1, vec![Rgb32::new(f32::NAN, 1.0, 2.0), Rgb32::new(0.25, 0.5, 4.0)]).unwrap()
    }

    #[test]
    fn extensions_are_case_insensitive() {
        for (name, f) in [
            ("a.PFM", ImageFormat::Pfm),
            ("a.Exr", ImageFormat::Exr),
            ("a.hdr", ImageFormat::RadianceHdr),
            ("a.PNG", ImageFormat::Png),
            ("a.jpg", ImageFormat::Jpeg),
            ("dir.d/a.JPEG", ImageFormat::Jpeg),
        ] {
            assert_eq!(ImageFormat::from_path(Path::new(name)).unwrap(), f, "{name}");
        }
        let e = ImageFormat::from_path(Path::new("dir/a.bmp")).unwrap_err().to_string();
        assert!(e.contains("dir/a.bmp") && e.contains("\".bmp\"") && e.contains(".pfm"), "{e}");
        let e = ImageFormat::from_path(Path::new("noext")).unwrap_err().to_string();
        assert!(e.contains("noext") && e.contains("no file extension"), "{e}");
    }

    #[test]
    fn hdr_round_trips_and_non_finite_pixels_are_black() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["a.pfm", "a.exr"] {
            let path = dir.path().join(name);
            let report = write_image(&path, &nan_image(), &ToneMap::default()).unwrap();
            assert_eq!(report.non_finite, 1);
            let back = read_image(&path).unwrap();
            assert_eq!(back.pixels(), &[Rgb32::BLACK, Rgb32::new(0.25, 0.5, 4.0)], "{name}");
        }
        let path = dir.path().join("a.hdr");
        write_image(&path, &nan_image(), &ToneMap::default()).unwrap();
        // 0.25, 0.5 and 4 share RGBE's exponent range exactly (powers of two).
        assert_eq!(read_image(&path).unwrap().pixels(), &[Rgb32::BLACK, Rgb32::new(0.25, 0.5, 4.0)]);
    }

    #[test]
    fn ldr_output_is_tone_mapped() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.png");
        let tm = ToneMap { luminosity: Some(1.0), alpha: 1.0, ..ToneMap::raytracer_jl() };
        let report = write_image(&path, &nan_image(), &tm).unwrap();
        assert_eq!((report.non_finite, report.format), (1, ImageFormat::Png));
        let raw = ::image::open(&path).unwrap().into_rgb8().into_raw();
        // x/(1+x): 0.25 → 0.2 → 51; 0.5 → 1/3 → 85; 4 → 0.8 → 204.
        assert_eq!(raw, vec![0, 0, 0, 51, 85, 204]);
    }

    #[test]
    fn failed_writes_leave_nothing_behind() {
        let dir = tempfile::tempdir().unwrap();
        let img = nan_image();
        // Unsupported extension, bad tone map, empty image, target is a directory.
        assert!(write_image(&dir.path().join("a.bmp"), &img, &ToneMap::default()).is_err());
        let bad = ToneMap { alpha: -1.0, ..ToneMap::raytracer_jl() };
        let e = write_image(&dir.path().join("b.png"), &img, &bad).unwrap_err().to_string();
        assert!(e.contains("b.png") && e.contains("alpha"), "{e}");
        assert!(write_image(&dir.path().join("c.pfm"), &HdrImage::new(0, 3), &ToneMap::default()).is_err());
        std::fs::create_dir(dir.path().join("d.pfm")).unwrap();
        let e = write_image(&dir.path().join("d.pfm"), &img, &ToneMap::default()).unwrap_err();
        assert!(matches!(e, ImageError::Write { .. }), "{e}");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names, vec![std::ffi::OsString::from("d.pfm")]);
        // Missing directory.
        assert!(write_image(&dir.path().join("nope/e.pfm"), &img, &ToneMap::default()).is_err());
    }

    #[test]
    fn overwrites_an_existing_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.pfm");
        std::fs::write(&path, b"old").unwrap();
        write_image(&path, &nan_image(), &ToneMap::default()).unwrap();
        assert_eq!(read_image(&path).unwrap().width(), 2);
    }

    #[test]
    fn read_errors_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("missing.exr");
        let e = read_image(&missing).unwrap_err().to_string();
        assert!(e.contains("missing.exr") && e.starts_with("cannot read"), "{e}");
        for name in ["bad.pfm", "bad.exr", "bad.hdr", "bad.png", "bad.jpg"] {
            let path = dir.path().join(name);
            std::fs::write(&path, b"garbage").unwrap();
            let e = read_image(&path).unwrap_err();
            assert_eq!(e.path(), path);
            assert!(e.to_string().contains(name), "{e}");
            assert!(!e.to_string().contains("Format error decoding"), "{e}");
        }
        // A file cut short says so, not the decoder's I/O detail.
        let img = HdrImage::new(16, 16);
        for (name, format) in [("cut.hdr", "Radiance HDR"), ("cut.exr", "OpenEXR")] {
            let path = dir.path().join(name);
            write_image(&path, &img, &ToneMap::default()).unwrap();
            let bytes = std::fs::read(&path).unwrap();
            std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
            let e = read_image(&path).unwrap_err().to_string();
            let says =
                format!("cannot decode {format} image: the file ends early (cut short, or not a whole {format} file)");
            assert!(e.ends_with(&says), "{e}");
        }
    }

    /// `name` written by lumen from a 40×30 image of varied pixels, as bytes.
    fn written(dir: &Path, name: &str) -> Vec<u8> {
        let path = dir.join(name);
        let img = HdrImage::from_fn(40, 30, |c, r| Rgb32::new(c as f32 / 40.0, r as f32 / 30.0, ((c * r) % 7) as f32));
        write_image(&path, &img, &ToneMap::default()).unwrap();
        std::fs::read(path).unwrap()
    }

    /// The message of reading `bytes` as file `name`, after the file's name.
    fn read_message(dir: &Path, name: &str, bytes: &[u8]) -> String {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        let e = read_image(&path).unwrap_err().to_string();
        e.strip_prefix(&format!("{}: ", path.display())).unwrap_or(&e).to_string()
    }

    #[test]
    fn decoder_messages_are_said_in_words() {
        let dir = tempfile::tempdir().unwrap();
        // zune-jpeg: "I/O errors Not enough bytes, expected 162 but found 31" and a newline.
        let jpg = written(dir.path(), "a.jpg");
        assert_eq!(
            read_message(dir.path(), "cut.jpg", &jpg[..200]),
            "cannot decode JPEG image: the file ends early (cut short, or not a whole JPEG file)"
        );
        // The image crate: "EOF in header".
        let hdr = written(dir.path(), "a.hdr");
        assert_eq!(
            read_message(dir.path(), "cut.hdr", &hdr[..20]),
            "cannot decode Radiance HDR image: the file ends early (cut short, or not a whole Radiance HDR file)"
        );
        // The png crate: "Unrecognized critical chunk: ChunkType { type: IDA«, critical: true, ... }".
        let mut png = written(dir.path(), "a.png");
        let t = png.windows(4).position(|w| w == b"IDAT").unwrap() + 3;
        for (byte, name) in [(b'T' ^ 0xff, "IDA\\xAB"), (0x1b, "IDA\\x1B"), (b'X', "IDAX")] {
            png[t] = byte;
            assert_eq!(
                read_message(dir.path(), "bad.png", &png),
                format!(
                    "cannot decode PNG image: an unknown critical chunk \"{name}\" (the file is corrupt, or needs a \
                     PNG extension)"
                )
            );
        }
    }

    #[test]
    fn messages_are_one_line() {
        assert_eq!(decoder_words("JPEG", "I/O errors Generic I/O error: odd\n"), "Generic I/O error: odd",);
        assert_eq!(
            encoder_words("Format error encoding Jpeg:\nInvalid image size (65536 x 1) to encode as JPEG: width and height must be >= 1 and <= 65535"),
            "Invalid image size (65536 x 1) to encode as JPEG: width and height must be >= 1 and <= 65535"
        );
    }

    #[test]
    fn jpeg_sides_over_65535_are_refused_before_tone_mapping() {
        let dir = tempfile::tempdir().unwrap();
        let wide = HdrImage::new(65536, 1);
        // A tone map that would fail: the size is refused first.
        let bad = ToneMap { alpha: -1.0, ..ToneMap::raytracer_jl() };
        for name in ["w.jpg", "w.JPEG"] {
            let path = dir.path().join(name);
            let e = write_image(&path, &wide, &bad).unwrap_err();
            assert_eq!(
                e.to_string(),
                format!(
                    "{}: image size 65536×1 is too large for JPEG (at most 65535 pixels per side; .png, .exr, .hdr \
                     and .pfm take up to 65536)",
                    path.display()
                )
            );
        }
        let tall = HdrImage::new(1, 65536);
        assert!(matches!(
            write_image(&dir.path().join("t.jpg"), &tall, &ToneMap::default()),
            Err(ImageError::Size { .. })
        ));
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        write_image(&dir.path().join("w.png"), &wide, &ToneMap::default()).unwrap();
        write_image(&dir.path().join("w.jpg"), &HdrImage::new(65535, 1), &ToneMap::default()).unwrap();
        assert_eq!(read_image(&dir.path().join("w.jpg")).unwrap().width(), 65535);
    }
}
