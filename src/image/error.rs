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
    #[error("{}: {}", path.display(), describe_extension(ext))]
    UnsupportedExtension { path: PathBuf, ext: Option<String> },
    #[error("cannot read {}: {cause}", path.display())]
    Read { path: PathBuf, cause: std::io::Error },
    #[error("cannot write {}: {cause}", path.display())]
    Write { path: PathBuf, cause: std::io::Error },
    #[error("{}: invalid PFM file: {cause}", path.display())]
    Pfm { path: PathBuf, cause: PfmError },
    #[error("{}: cannot decode {format} image: {message}", path.display())]
    Decode { path: PathBuf, format: &'static str, message: String },
    #[error("{}: cannot encode {format} image: {message}", path.display())]
    Encode { path: PathBuf, format: &'static str, message: String },
    #[error("{}: {cause}", path.display())]
    Size { path: PathBuf, cause: SizeError },
    #[error("{}: invalid tone mapping: {cause}", path.display())]
    ToneMap { path: PathBuf, cause: ToneMapError },
    #[error("{}: {message}", path.display())]
    Metadata { path: PathBuf, message: String },
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
