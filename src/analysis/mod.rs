//! Measuring renderers: image error metrics, least-squares fits on log-log data, result
//! tables (CSV and Markdown), a log-log plot written as PNG, the process's peak memory and
//! CPU time, and the machine the figures were measured on.
//!
//! `lumen converge` and `lumen bench` are thin drivers over this module, so everything that
//! turns numbers into conclusions (slopes, plateaus, efficiencies) is unit-tested here on
//! synthetic data with known answers.
//!
//! ```
//! use lumen::analysis::{fit_loglog, mse};
//! use lumen::color::Rgb32;
//! use lumen::image::HdrImage;
//!
//! let reference = HdrImage::from_fn(4, 4, |_, _| Rgb32 { r: 1.0, g: 1.0, b: 1.0 });
//! let noisy = reference.map(|c| Rgb32 { r: c.r + 0.5, ..c });
//! assert!((mse(&noisy, &reference).unwrap() - 0.25 / 3.0).abs() < 1e-12);
//!
//! // MSE ∝ 1/spp: slope exactly −1 in log-log.
//! let spp = [1.0, 4.0, 16.0, 64.0];
//! let err: Vec<f64> = spp.iter().map(|s| 0.3 / s).collect();
//! assert!((fit_loglog(&spp, &err).unwrap().slope + 1.0).abs() < 1e-12);
//! ```

mod cpu_time;
mod font;
mod host;
mod line_fit;
mod measure;
mod metrics;
mod plot;
mod table;

pub use crate::memory::{format_bytes, peak_memory_bytes};
pub use cpu_time::{cores_busy, process_cpu_seconds};
pub use host::{machine_line, parse_cpuinfo, Host};
pub use line_fit::{fit_line, fit_loglog, tail_flattens, LineFit};
pub use measure::{measure, measure_with, open_devices, Device, Measurement, OpenDevice};
pub use metrics::{mse, rel_mse, rmse, ErrorMetrics, REL_MSE_EPSILON};
pub use plot::{plot_loglog, plot_loglog_svg, Plot, Series};
pub use table::{format_seconds, markdown_table, ConvergeRow, ConvergeTable};
