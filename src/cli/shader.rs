//! `lumen shader SCENE.sl`: prints the WGSL compute kernel lumen assembles for a scene
//! (only the shader modules and `// #if` blocks the scene's features need).

use std::path::PathBuf;

use anyhow::{anyhow, Context as _};
use clap::Args;

use super::script_args::ScriptArgs;
use crate::gpu::features::FeatureSet;
use crate::gpu::render::{assemble_for, KernelVariant};
use crate::image::write_atomically;

/// Arguments of `lumen shader`.
#[derive(Debug, Args)]
pub struct ShaderArgs {
    /// The SceneLang script whose kernel to print.
    pub scene: PathBuf,
    /// Write the WGSL to this file instead of standard output.
    #[arg(short = 'o', long = "output")]
    pub output: Option<PathBuf>,
    /// Print the resumable variant that `lumen render` uses on drivers with a loop limiter
    /// such as lavapipe (docs/DESIGN.md, "Loop limiter and path-granular passes").
    /// Without it: the kernel for every other GPU.
    #[arg(long)]
    pub loop_limiter: bool,
    #[command(flatten)]
    pub script: ScriptArgs,
}

/// Loads the scene, assembles and validates its kernel (naga), and prints it.
pub fn run(args: ShaderArgs) -> anyhow::Result<()> {
    let scene = args.script.load(&args.scene)?;
    let features = FeatureSet::of(&scene);
    let variant = KernelVariant { loop_limiter: args.loop_limiter, ..KernelVariant::default() };
    let assembled = assemble_for(&features, variant).map_err(|e| anyhow!("cannot assemble the kernel: {e}"))?;
    let mut names = features.names();
    names.extend(variant.names());
    let text = format!(
        "// lumen render kernel for {}\n// features: {}\n{}",
        args.scene.display(),
        names.join(" "),
        assembled.source
    );
    match &args.output {
        Some(path) => {
            write_atomically(path, text.as_bytes()).with_context(|| format!("cannot write {}", path.display()))?;
            eprintln!("wrote {} ({} bytes, {} lines)", path.display(), text.len(), text.lines().count());
        }
        None => super::output::print(&text)?,
    }
    Ok(())
}
