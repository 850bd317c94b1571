//! The one error type of image reading, writing and tone mapping.

use std::path::{Path, PathBuf};

use thiserror::Error;

use super::pfm::PfmError;
use super::size::SizeError;
use super::tone_map::ToneMapError;

/// Every image error names the file and says what was wrong with it.
///
/// Messages are self-contained (the cause is part of the one line), so a caller that prints
/// only `{err}` still tells the user everything.
#[derive(Debug, Error)]
pub enum ImageError {
    /// The file's extension names no format lumen reads or writes (see [`SUPPORTED_EXTENSIONS`]).
    #[error("{}: {}", path.display(), describe_extension(ext))]
    UnsupportedExtension {
        /// The file that was to be read or written.
        path: PathBuf,
        /// The extension as given, without the dot and case kept; `None` when there is none.
        ext: Option<String>,
    },
    /// The file could not be read: missing, unreadable, or not a regular file.
    #[error("cannot read {}: {cause}", path.display())]
    Read {
        /// The file being read.
        path: PathBuf,
        /// The error from the file system.
        cause: std::io::Error,
    },
    /// The encoded image could not be written to its temporary file or renamed into place.
    #[error("cannot write {}: {cause}", path.display())]
    Write {
        /// The output file.
        path: PathBuf,
        /// The error from the file system.
        cause: std::io::Error,
    },
    /// A `.pfm` file whose header or data is malformed.
    #[error("{}: invalid PFM file: {cause}", path.display())]
    Pfm {
        /// The file being read.
        path: PathBuf,
        /// What was wrong, with the byte offset where it starts.
        cause: PfmError,
    },
    /// An OpenEXR, Radiance HDR, PNG or JPEG file that its decoder rejected (corrupt, a
    /// variant it cannot read, or too large for this process's memory).
    #[error("{}: cannot decode {format} image: {message}", path.display())]
    Decode {
        /// The file being read.
        path: PathBuf,
        /// The format's name for messages (`ImageFormat::name`).
        format: &'static str,
        /// The decoder's explanation.
        message: String,
    },
    /// The encoder for the output format failed; nothing was written.
    #[error("{}: cannot encode {format} image: {message}", path.display())]
    Encode {
        /// The output file.
        path: PathBuf,
        /// The format's name for messages (`ImageFormat::name`).
        format: &'static str,
        /// The encoder's explanation.
        message: String,
    },
    /// The image read, or the one to write, is empty or over lumen's size limits.
    #[error("{}: {cause}", path.display())]
    Size {
        /// The file read or to be written.
        path: PathBuf,
        /// Which limit was broken, with the size.
        cause: SizeError,
    },
    /// The tone mapping for an 8-bit output (PNG, JPEG) has a parameter out of range.
    #[error("{}: invalid tone mapping: {cause}", path.display())]
    ToneMap {
        /// The output file.
        path: PathBuf,
        /// Why the tone mapping failed.
        cause: ToneMapError,
    },
    /// A render shard (`lumen merge`'s input) that is not EXR, or whose lumen render metadata
    /// is missing or invalid.
    #[error("{}: {message}", path.display())]
    Metadata {
        /// The shard file.
        path: PathBuf,
        /// What is missing or wrong.
        message: String,
    },
}

/// The extensions [`crate::image::read_image`] and [`crate::image::write_image`] accept.
pub const SUPPORTED_EXTENSIONS: &str = ".pfm, .exr, .hdr (linear HDR); .png, .jpg, .jpeg (8-bit sRGB)";

fn describe_extension(ext: &Option<String>) -> String {
    match ext {
        Some(e) => format!("unsupported image extension \".{e}\"; supported: {SUPPORTED_EXTENSIONS}"),
        None => format!("no file extension to tell the image format; supported: {SUPPORTED_EXTENSIONS}"),
    }
}

impl ImageError {
    /// The file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            Self::UnsupportedExtension { path, .. }
            | Self::Read { path, .. }
            | Self::Write { path, .. }
            | Self::Pfm { path, .. }
            | Self::Decode { path, .. }
            | Self::Encode { path, .. }
            | Self::Size { path, .. }
            | Self::ToneMap { path, .. }
            | Self::Metadata { path, .. } => path,
        }
    }
}
