//! Options shared by every subcommand that loads a SceneLang script (`#[command(flatten)]`).

use std::path::Path;

use anyhow::anyhow;
use clap::Args;

use crate::scene::Scene;
use crate::scenelang::{load_file, LoadOptions};

/// `--time` and `--vars`.
#[derive(Debug, Clone, Default, Args)]
pub struct ScriptArgs {
    /// Value of TIME in the script.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub time: f64,
    /// Variables defined before the script runs, as "name value, name value" (values in SET
    /// syntax); they win over the script's own SET of the same name. May repeat.
    #[arg(long)]
    pub vars: Vec<String>,
}

impl ScriptArgs {
    /// Loads `path` with these variables at `time`; the error is the script's full diagnostic
    /// on its own line, so that `file:line:col:` starts a line (where editors look for it).
    pub fn load_at(&self, path: &Path, time: f64) -> anyhow::Result<Scene> {
        let opts = LoadOptions { time, vars: self.vars.clone() };
        load_file(path, &opts).map_err(|e| anyhow!("the scene does not load\n{e}"))
    }

    /// Loads `path` at `--time`.
    pub fn load(&self, path: &Path) -> anyhow::Result<Scene> {
        self.load_at(path, self.time)
    }
}
