//! `lumen check SCENE.sl`: loads a script and prints what it describes, or the diagnostic.

use std::path::PathBuf;

use clap::Args;

use super::output::Lines;
use super::script_args::ScriptArgs;
use crate::gpu::features::FeatureSet;
use crate::scenelang::SceneSummary;

/// Arguments of `lumen check`.
#[derive(Debug, Args)]
pub struct CheckArgs {
    /// The SceneLang script to check.
    pub scene: PathBuf,
    #[command(flatten)]
    pub script: ScriptArgs,
}

/// Loads the scene and prints its summary; the error is the full diagnostic.
pub fn run(args: CheckArgs) -> anyhow::Result<()> {
    let scene = args.script.load(&args.scene)?;
    let mut out = Lines::default();
    out.line(format_args!("{}: ok", args.scene.display())).line(SceneSummary::of(&scene));
    // What the GPU kernel is specialised for (`lumen shader` prints the kernel itself).
    let features = FeatureSet::of(&scene);
    out.line(format_args!("GPU kernel features: {}", features.names().join(" ")));
    if features.csg {
        out.line(format_args!(
            "CSG trees: at most {} leaves, {} deep",
            features.csg_max_leaves, features.csg_max_depth
        ));
    }
    // What the GPU renderer refuses on any adapter (a shape beyond f32's range, a CSG tree
    // beyond its span pool), said before a render finds it, without building what a render
    // packs; an adapter's own size limits show only when a render opens it.
    if let Err(e) = crate::gpu::pack::check_packable(&scene) {
        out.line(format_args!("GPU renderer: cannot take this scene: {e}; `--device auto` renders it on the CPU"));
    }
    Ok(out.print()?)
}
