//! lumen: a physically based path tracer that renders on any GPU through wgpu compute
//! shaders and checks every image against an f64 CPU reference.
//!
//! Architecture (one concept per module):
//! - [`scene`]: the scene model every renderer consumes;
//! - [`sampling`]: PCG32 and the per-(pixel, sample, bounce) stream rule;
//! - [`image`]: HDR images, tone mapping, PFM/EXR/HDR/PNG files.

// Diagnostics go through `diag!`, never `eprintln!` (below).
#![warn(clippy::print_stderr)]

/// Writes a line to standard error as `eprintln!` does, but never panics: `eprintln!`
/// panics when standard error cannot be written (redirected to a full disk, a pipe whose
/// reader left), which would end a render whose outputs are fine. Diagnostics are best
/// effort; results go to files or through `cli::output`, which reports its failures.
/// Diagnostics quote input, so control characters in them are shown, not obeyed, and
/// very long lines are shortened ([`printable::for_terminal`]).
///
/// ```
/// lumen::diag!("rendered {} samples", 16);
/// ```
#[macro_export]
macro_rules! diag {
    ($($arg:tt)*) => {{
        use ::std::io::Write as _;
        let text = ::std::format!($($arg)*);
        let _ = ::std::writeln!(::std::io::stderr(), "{}", $crate::printable::for_terminal(&text));
    }};
}

pub mod accel;
pub mod analysis;
pub mod cli;
pub mod color;
pub mod cpu;
pub mod device;
pub mod gpu;
pub mod image;
pub mod line_ends;
pub mod memory;
pub mod optics;
pub mod prepare;
pub mod printable;
pub mod regular_file;
pub mod sampling;
pub mod scene;
pub mod scenelang;
pub mod stop;
