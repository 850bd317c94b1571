//! The `lumen` command line. Each subcommand lives in its own file and is one variant of
//! [`Command`]; errors print as one line plus context and exit non-zero. Results go to
//! standard output only through [`output`] (the lint below holds every file to it).
#![deny(clippy::print_stdout)]

use std::process::ExitCode;

use clap::{Parser, Subcommand};

pub mod bench;
mod check;
pub mod converge;
pub mod devices;
pub mod gpu_args;
#[cfg(unix)]
pub mod headless;
pub mod merge;
pub mod number_args;
pub mod output;
pub mod own_process;
pub mod render;
mod rescue;
pub mod script_args;
mod shader;
pub mod software_driver;
mod tonemap;

/// lumen: a physically based path tracer on wgpu compute shaders, checked against an
/// f64 CPU reference.
#[derive(Debug, Parser)]
#[command(name = "lumen", version, about, long_about = None, propagate_version = true)]
pub struct Cli {
    /// The subcommand named on the command line, with its arguments; [`run`] dispatches on it.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands of `lumen`, each with its parsed arguments (one file of this module each).
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
    /// Merge EXR renders of disjoint sample ranges (shards) into one image.
    Merge(merge::MergeArgs),
    /// Print the WGSL kernel assembled for a scene (only what the scene uses).
    Shader(shader::ShaderArgs),
    /// Measure how error falls with samples and time on each device (table + log-log plot).
    Converge(converge::ConvergeArgs),
    /// Benchmark devices on the example scenes, object-count scaling and kernel specialisation.
    Bench(bench::BenchArgs),
}

impl Command {
    /// Whether a GPU render of this command may run on two llvmpipe devices, which then
    /// split the cores (`software_driver::split_cores_between_devices`): not a render on
    /// one device (`--one-device`, or `--profile`, which times one device's launches).
    fn renders_on_two_devices(&self) -> bool {
        match self {
            Command::Render(args) => !args.gpu.one_device && !args.profile,
            Command::Converge(_) | Command::Bench(_) => true,
            _ => false,
        }
    }
}

/// Runs one parsed command.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Tonemap(args) => tonemap::run(args),
        Command::Devices(args) => devices::run(args),
        Command::Check(args) => check::run(args),
        Command::Render(args) => render::run(args),
        Command::Merge(args) => merge::run(args),
        Command::Shader(args) => shader::run(args),
        Command::Converge(args) => converge::run(args),
        Command::Bench(args) => bench::run(args),
    }
}

/// Entry point of the binary: parse, run, report.
pub fn main() -> ExitCode {
    // First, while the process has one thread: it may set an environment variable.
    #[cfg(unix)]
    let _runtime_dir = headless::ensure_runtime_dir();
    software_driver::prefer_narrow_vectors();
    crate::gpu::on_adapter_chosen(software_driver::relaunch_if_wider_is_faster);
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return clap_exit(&e),
    };
    // Still one thread (parsing starts none): the device split depends on the command.
    if cli.command.renders_on_two_devices() {
        software_driver::split_cores_between_devices();
    }
    // After the environment changes above (this starts a thread).
    #[cfg(unix)]
    crate::stop::exit_cleanly_on_termination();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => report(&e),
    }
}

/// Prints clap's help, version or usage error; `--help` into a closed pipe or a full disk
/// is handled like any other output. A usage error quotes the command line, whose words
/// may come from anywhere (file names through `xargs`), so it goes through `diag!` as
/// plain text (its control characters shown, not obeyed; without clap's colours), not
/// through clap's own printer, which passes escape sequences to a terminal.
fn clap_exit(e: &clap::Error) -> ExitCode {
    let code = ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2));
    if e.use_stderr() {
        crate::diag!("{}", e.render().to_string().trim_end());
        return code;
    }
    match e.print() {
        Err(io) => report(&output::StdoutError(io).into()),
        Ok(()) => code,
    }
}

/// Prints an error as one line plus its causes; a broken pipe on standard output (the
/// reader has gone, as with `| head`) exits quietly.
fn report(e: &anyhow::Error) -> ExitCode {
    if e.chain().any(|c| c.downcast_ref::<output::StdoutError>().is_some_and(output::StdoutError::is_broken_pipe)) {
        return ExitCode::from(output::BROKEN_PIPE_EXIT);
    }
    crate::diag!("error: {e}");
    for cause in e.chain().skip(1) {
        crate::diag!("  caused by: {cause}");
    }
    ExitCode::FAILURE
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Only commands that may render on two llvmpipe devices split the cores between them:
    /// not `--one-device` or `--profile` renders (one device, which keeps every core), nor
    /// commands that render nothing.
    #[test]
    fn which_commands_split_the_cores() {
        let splits = |args: &[&str]| {
            let cli = Cli::try_parse_from(std::iter::once("lumen").chain(args.iter().copied())).unwrap();
            cli.command.renders_on_two_devices()
        };
        assert!(splits(&["render", "scene.sl"]));
        assert!(splits(&["render", "scene.sl", "--device", "gpu"]));
        assert!(!splits(&["render", "scene.sl", "--one-device"]));
        assert!(!splits(&["render", "scene.sl", "--profile"]));
        assert!(splits(&["bench"]));
        assert!(splits(&["converge", "scene.sl"]));
        assert!(!splits(&["check", "scene.sl"]));
        assert!(!splits(&["shader", "scene.sl"]));
        assert!(!splits(&["devices"]));
    }
}
