//! `lumen shader SCENE.sl`: prints the WGSL compute kernels lumen assembles for a scene, one
//! per wavefront stage (only the shader modules and `// #if` blocks each stage needs).

use std::path::PathBuf;

use anyhow::{anyhow, Context as _};
use clap::Args;

use super::script_args::ScriptArgs;
use crate::gpu::features::FeatureSet;
use crate::gpu::pack::pack;
use crate::gpu::render::assemble_stages;
use crate::gpu::tables::{TablePlacement, UniformTables, UNIFORM_TABLE_BYTES};
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
    /// Which table placement to print the kernels for: `storage` (what hardware GPUs run)
    /// or `uniform` (what software adapters run: each table that fits 64 KiB in a uniform
    /// buffer; `lumen render --tables`).
    #[arg(long, value_enum, default_value_t = ShaderTables::Storage)]
    pub tables: ShaderTables,
}

/// `lumen shader --tables`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ShaderTables {
    Uniform,
    Storage,
}

/// Loads the scene, assembles and validates its kernel (naga), and prints it.
pub fn run(args: ShaderArgs) -> anyhow::Result<()> {
    let scene = args.script.load(&args.scene)?;
    let mut features = FeatureSet::of(&scene);
    if args.tables == ShaderTables::Uniform {
        let packed = pack(&scene, None).map_err(|e| anyhow!("cannot pack the scene for the GPU: {e}"))?;
        let max = UNIFORM_TABLE_BYTES as u64;
        features.uniform_tables = UniformTables::choose(&packed, TablePlacement::Uniform, wgpu::DeviceType::Cpu, max);
    }
    let stages = assemble_stages(&features).map_err(|e| anyhow!("cannot assemble the kernels: {e}"))?;
    let mut text = format!(
        "// lumen render kernels for {}\n// scene features: {}\n",
        args.scene.display(),
        features.names().join(" ")
    );
    for (stage, a) in &stages {
        text.push_str(&format!(
            "\n// ===== stage {} (entry point {}; features: {}) =====\n{}",
            stage.label(),
            stage.entry().1,
            stage.names(&features).join(" "),
            a.source
        ));
    }
    match &args.output {
        Some(path) => {
            write_atomically(path, text.as_bytes()).with_context(|| format!("cannot write {}", path.display()))?;
            eprintln!("wrote {} ({} bytes, {} lines)", path.display(), text.len(), text.lines().count());
        }
        None => super::output::print(&text)?,
    }
    Ok(())
}
