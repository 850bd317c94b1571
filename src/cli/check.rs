//! `lumen check SCENE.sl`: loads a script and prints what it describes, or the diagnostic.

use std::path::PathBuf;

use anyhow::anyhow;
use clap::Args;

use crate::gpu::features::FeatureSet;
use crate::scenelang::{load_file, LoadOptions, SceneSummary};

/// Arguments of `lumen check`.
#[derive(Debug, Args)]
pub struct CheckArgs {
    /// The SceneLang script to check.
    pub scene: PathBuf,
    /// Value of TIME in the script.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub time: f64,
    /// Variables defined before the script runs, as "name value, name value" (values in SET
    /// syntax); they win over the script's own SET of the same name. May repeat.
    #[arg(long)]
    pub vars: Vec<String>,
}

/// Loads the scene and prints its summary; the error is the full diagnostic.
pub fn run(args: CheckArgs) -> anyhow::Result<()> {
    let opts = LoadOptions { time: args.time, vars: args.vars };
    // The diagnostic starts its own line, so that `file:line:col:` is where editors look.
    let scene = load_file(&args.scene, &opts).map_err(|e| anyhow!("the scene does not load\n{e}"))?;
    println!("{}: ok", args.scene.display());
    println!("{}", SceneSummary::of(&scene));
    // What the GPU kernel is specialised for (`lumen shader` prints the kernel itself).
    let features = FeatureSet::of(&scene);
    println!("GPU kernel features: {}", features.names().join(" "));
    if features.csg {
        println!(
            "CSG interval lists: at most {} intervals, trees {} deep",
            features.csg_max_intervals, features.csg_max_depth
        );
    }
    Ok(())
}
