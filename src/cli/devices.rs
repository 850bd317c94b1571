//! `lumen devices`: the GPU adapters wgpu can see, best first (the one used by default
//! comes first; `--adapter NAME` or `LUMEN_ADAPTER` picks another by name).

use clap::Args;

use super::gpu_args::AdapterArgs;
use super::output::Lines;
use crate::gpu::{list_adapters, select_adapter};

/// Arguments of `lumen devices`.
#[derive(Debug, Args)]
pub struct DevicesArgs {
    /// `--adapter`: the adapter marked `(selected)`; a name that matches none is an error.
    #[command(flatten)]
    pub adapter: AdapterArgs,
}

/// Prints one line per adapter; with none, says so and how to get one (not an error:
/// the CPU renderer still works).
pub fn run(args: DevicesArgs) -> anyhow::Result<()> {
    let adapters = list_adapters();
    let mut out = Lines::default();
    if adapters.is_empty() {
        out.line("no GPU adapters found: GPU rendering is unavailable (the CPU renderer still works).")
            .line("On Linux, Mesa's software Vulkan driver works anywhere: apt-get install mesa-vulkan-drivers");
        return Ok(out.print()?);
    }
    let choice = args.adapter.choice();
    let selected = select_adapter(&adapters, &choice);
    // As a render would (gpu::on_adapter_chosen): list the adapters as it will open them.
    if let Some(a) = selected.as_ref().ok().and_then(|&i| adapters.get(i)) {
        super::software_driver::relaunch_if_wider_is_faster(&a.info());
    }
    for (i, a) in adapters.iter().enumerate() {
        let mark = if selected.as_ref().ok() == Some(&i) { "  (selected)" } else { "" };
        out.line(format_args!("{i}: {}{mark}", a.name)).line(format_args!(
            "   backend: {}, type: {}",
            a.backend,
            a.device_type_name()
        ));
        let driver = a.driver_name();
        if !driver.is_empty() {
            out.line(format_args!("   driver: {driver}"));
        }
    }
    out.print()?;
    // An adapter name that matches nothing is an error wherever it is used: say so here too.
    selected?;
    Ok(())
}
