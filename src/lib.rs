//! lumen: a physically based path tracer that renders on any GPU through wgpu compute
//! shaders and checks every image against an f64 CPU reference.
//!
//! A scene comes from a SceneLang script ([`scenelang`]) or is built in Rust
//! ([`scene::SceneBuilder`]); either renderer takes it as it is, and both draw the same
//! random numbers for the same (pixel, sample, bounce), so their images agree pixel by pixel:
//!
//! ```
//! use lumen::cpu::{render, Progress, RenderOptions};
//! use lumen::image::{read_image, write_image, ToneMap};
//! use lumen::scenelang::{load_str, LoadOptions};
//!
//! // A reddish sphere under a white sky, path traced.
//! let script = r#"
//!     SPAWN Shape.Sphere(.material Material(.brdf Brdf.Diffuse(Pigment.Uniform(<0.8, 0.2, 0.2>))),
//!                        .transformation TRANSLATE(.X 3))
//!     USING Camera.Perspective() Image(32, 18) Renderer.PathTracer(.n 1, .max_depth 3) Tracer()
//!           Environment.Uniform(<1, 1, 1>)
//! "#;
//! let scene = load_str(script, "doc.sl", std::path::Path::new("."), &LoadOptions::default()).unwrap();
//! let cpu = render(&scene, &RenderOptions::default(), Progress::Hidden).image;
//! assert_eq!(cpu.get(0, 0).r, 1.0); // a corner sees the sky of radiance 1
//! let centre = cpu.get(16, 9);
//! assert!(centre.r > 2.0 * centre.g); // the sphere, lit by the sky
//!
//! // The same scene on a GPU, where one is present.
//! if let Some(gpu) = lumen::gpu::gpu_for_tests("crate_example") {
//!     let out = lumen::gpu::render::render(&gpu, &scene, &Default::default()).unwrap();
//!     let (g, c) = (out.image.mean(), cpu.mean());
//!     assert!((g.r - c.r).abs() < 0.01 * c.r && (g.g - c.g).abs() < 0.01 * c.g);
//! }
//!
//! // PNG and JPEG are tone-mapped; EXR, PFM and HDR keep the linear radiance.
//! let path = std::env::temp_dir().join(format!("lumen-crate-example-{}.pfm", std::process::id()));
//! write_image(&path, &cpu, &ToneMap::default()).unwrap();
//! assert_eq!(read_image(&path).unwrap().get(16, 9), centre);
//! std::fs::remove_file(&path).unwrap();
//! ```
//!
//! Architecture (one concept per module; docs/DESIGN.md has the decisions):
//! - [`scene`]: the scene model every renderer consumes, and [`scene::SceneBuilder`];
//! - [`scenelang`]: the SceneLang lexer, parser, evaluator and diagnostics;
//! - [`sampling`]: PCG32 and the per-(pixel, sample, bounce) stream rule;
//! - [`accel`]: the binned-SAH BVH and its quantized form for the GPU;
//! - [`prepare`]: what both renderers derive from a scene (BVH, light tables, the
//!   environment's distribution, camera sample placement);
//! - [`cpu`]: the f64 reference renderer on rayon, also the fallback without a GPU;
//! - [`gpu`]: the wgpu device, the packed scene, shader assembly and the wavefront renderer;
//! - [`optics`]: surface optics both renderers share (Fresnel, GGX, energy compensation);
//! - [`device`]: where a render runs (`--device cpu|gpu|auto`);
//! - [`image`]: HDR images, tone mapping, PFM/EXR/HDR/PNG/JPEG files, atomic writes;
//! - [`color`]: RGB in f64 (scene, CPU) and f32 (images, GPU);
//! - [`analysis`]: measuring renderers (error metrics, fits, tables, plots, memory, time);
//! - [`cli`]: one module per `lumen` subcommand;
//! - [`stop`], [`regular_file`], [`memory`], [`printable`], [`line_ends`]: how a render
//!   stops, reading only regular files, memory limits, text safe for a terminal, line ends.

// Diagnostics go through `diag!`, never `eprintln!` (below).
#![warn(clippy::print_stderr)]
// Every public item says what it is (CI's clippy and rustdoc runs make this an error).
#![warn(missing_docs)]

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
