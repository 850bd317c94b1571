//! lumen: a physically based path tracer that renders on any GPU through wgpu compute
//! shaders and checks every image against an f64 CPU reference.
//!
//! Architecture (one concept per module):
//! - [`scene`]: the scene model every renderer consumes;
//! - [`sampling`]: PCG32 and the per-(pixel, sample, bounce) stream rule;
//! - [`image`]: HDR images, tone mapping, PFM/EXR/HDR/PNG files.

pub mod accel;
pub mod analysis;
pub mod cli;
pub mod color;
pub mod cpu;
pub mod device;
pub mod gpu;
pub mod image;
pub mod memory;
pub mod optics;
pub mod prepare;
pub mod regular_file;
pub mod sampling;
pub mod scene;
pub mod scenelang;
pub mod stop;
