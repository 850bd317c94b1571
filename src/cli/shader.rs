//! `lumen shader SCENE.sl`: prints the WGSL compute kernels lumen assembles for a scene, one
//! per wavefront stage (only the shader modules and `// #if` blocks each stage needs).

use std::path::PathBuf;

use anyhow::{anyhow, Context as _};
use clap::Args;

use super::script_args::ScriptArgs;
use crate::gpu::kernels::kernel_listing;
use crate::gpu::pack::pack;
use crate::gpu::tables::{TableForms, TableLimits, TablePlacement};
use crate::image::write_atomically;

/// Arguments of `lumen shader`.
#[derive(Debug, Args)]
pub struct ShaderArgs {
    /// The SceneLang script whose kernel to print.
    pub scene: PathBuf,
    /// Write the WGSL to this file instead of standard output.
    #[arg(short = 'o', long = "output")]
    pub output: Option<PathBuf>,
    #[command(flatten)]
    pub script: ScriptArgs,
    /// Which table placement to print the kernels for, as `lumen render --tables` places
    /// them on a software adapter: `storage` (what hardware GPUs run), `auto` (what
    /// software adapters run: each table that fits 64 KiB in a uniform buffer, each larger
    /// one in a texture), `uniform` or `texture`.
    #[arg(long, value_enum, default_value_t = TablePlacement::Storage)]
    pub tables: TablePlacement,
}

/// Loads the scene, assembles and validates its kernel (naga), and prints it.
pub fn run(args: ShaderArgs) -> anyhow::Result<()> {
    // As `render` does: a destination that cannot take the file is said in words, first.
    if let Some(path) = &args.output {
        crate::image::check_destination(path).with_context(|| format!("cannot write {}", path.display()))?;
    }
    let scene = args.script.load(&args.scene)?;
    // The packed scene's features: its lists are known only once it is packed.
    let packed = pack(&scene, None).map_err(|e| anyhow!("{}", crate::gpu::GpuError::Scene(e)))?;
    let mut features = packed.features;
    if args.tables != TablePlacement::Storage {
        let limits = TableLimits::webgpu_default();
        features.tables = TableForms::choose(&packed, args.tables, wgpu::DeviceType::Cpu, limits);
    }
    let kernels = kernel_listing(&features).map_err(|e| anyhow!("cannot assemble the kernels: {e}"))?;
    let text = format!(
        "// lumen render kernels for {}\n// scene features: {}\n{kernels}",
        args.scene.display(),
        features.names().join(" ")
    );
    match &args.output {
        Some(path) => {
            write_atomically(path, text.as_bytes()).with_context(|| format!("cannot write {}", path.display()))?;
            crate::diag!("wrote {} ({} bytes, {} lines)", path.display(), text.len(), text.lines().count());
        }
        None => super::output::print(&text)?,
    }
    Ok(())
}
