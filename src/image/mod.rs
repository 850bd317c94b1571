//! HDR images, tone mapping and image files: everything after rendering.
//!
//! - [`HdrImage`]: linear `f32` RGB pixels, with per-pixel arithmetic;
//! - [`ToneMap`]: linear radiance → display values (Raytracer.jl's Reinhard pipeline,
//!   an ACES filmic fit, or plain exposure);
//! - [`read_image`] / [`write_image`]: PFM, OpenEXR, Radiance HDR (linear) and PNG, JPEG
//!   (8-bit sRGB), chosen by extension; writes are atomic.

mod atomic_file;
mod digest;
mod error;
mod exr_file;
mod hdr_image;
mod image_file;
mod ldr_file;
mod pfm;
mod radiance_file;
pub mod render_metadata;
mod size;
mod srgb;
mod tone_map;

pub use atomic_file::{
    abandon_writes, check_destination, produce_atomically, write_atomically, write_set_atomically, SetWriteError,
    WritesAbandoned,
};
pub use error::{ImageError, SUPPORTED_EXTENSIONS};
pub use hdr_image::HdrImage;
pub use image_file::{
    check_output_size, is_hdr_path, read_image, read_render_part, write_image, write_image_with, ImageFormat,
    WriteReport,
};
pub use ldr_file::JPEG_QUALITY;
pub use pfm::{decode_pfm, encode_pfm, PfmError};
pub use render_metadata::RenderMetadata;
pub use size::{check_size, SizeError, MAX_PIXELS, MAX_SIDE};
pub use srgb::{linear_to_srgb, quantize_u8, srgb_to_linear};
pub use tone_map::{
    aces_narkowicz, average_luminosity, reinhard, Curve, ToneMap, ToneMapError, ToneMapped, LUMINOSITY_DELTA,
};
