//! The `lumen` command line. Each subcommand lives in its own file and is one variant of
//! [`Command`]; errors print as one line plus context and exit non-zero.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

pub mod bench;
mod check;
pub mod converge;
pub mod devices;
pub mod gpu_args;
pub mod render;
pub mod script_args;
mod shader;
mod tonemap;

/// lumen: a physically based path tracer on wgpu compute shaders, checked against an
/// f64 CPU reference.
#[derive(Debug, Parser)]
#[command(name = "lumen", version, about, long_about = None, propagate_version = true)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Tone-map or convert an image file (PFM, OpenEXR, Radiance HDR, PNG, JPEG).
    Tonemap(tonemap::TonemapArgs),
    /// List the GPU adapters lumen can render on.
    Devices(devices::DevicesArgs),
    /// Load a SceneLang script and summarise it (or print its first error).
    Check(check::CheckArgs),
    /// Render a SceneLang script to image files.
    Render(render::RenderArgs),
    /// Print the WGSL kernel assembled for a scene (only what the scene uses).
    Shader(shader::ShaderArgs),
    /// Measure how error falls with samples and time on each device (table + log-log plot).
    Converge(converge::ConvergeArgs),
    /// Benchmark devices on the example scenes, object-count scaling and kernel specialisation.
    Bench(bench::BenchArgs),
}

/// Runs one parsed command.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Tonemap(args) => tonemap::run(args),
        Command::Devices(args) => devices::run(args),
        Command::Check(args) => check::run(args),
        Command::Render(args) => render::run(args),
        Command::Shader(args) => shader::run(args),
        Command::Converge(args) => converge::run(args),
        Command::Bench(args) => bench::run(args),
    }
}

/// Entry point of the binary: parse, run, report.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            for cause in e.chain().skip(1) {
                eprintln!("  caused by: {cause}");
            }
            ExitCode::FAILURE
        }
    }
}
