//! HDR images, tone mapping and image files.

mod hdr_image;

pub use hdr_image::HdrImage;
