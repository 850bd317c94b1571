//! Options shared by the subcommands that render (`#[command(flatten)]`): which devices,
//! which adapter, and when to stop a progressive render early.

use std::time::Duration;

use clap::Args;

use super::number_args::whole;

use crate::device::Device;
use crate::gpu::tables::TablePlacement;
use crate::gpu::wavefront::MAX_QUEUE_SHARDS;
use crate::gpu::{ctrlc_flag, AdapterChoice, PassOptions};

/// `--adapter NAME` (default: `$LUMEN_ADAPTER`, else the best adapter).
#[derive(Debug, Clone, Default, Args)]
pub struct AdapterArgs {
    /// GPU adapter to use: a case-insensitive part of its name as `lumen devices` prints it
    /// (default: $LUMEN_ADAPTER, else the best adapter).
    #[arg(long, value_name = "NAME")]
    pub adapter: Option<String>,
}

impl AdapterArgs {
    /// The adapter to open: `--adapter` if given and not blank, else `$LUMEN_ADAPTER`, else
    /// none named (the best adapter).
    pub fn choice(&self) -> AdapterChoice {
        AdapterChoice::new(self.adapter.clone())
    }
}

/// `--device LIST` and `--adapter` of the studies that measure several devices in turn
/// (`lumen converge`, `lumen bench`).
#[derive(Debug, Clone, Args)]
pub struct DeviceListArgs {
    /// Devices to measure, comma-separated; an unavailable GPU is skipped with a warning.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = [Device::Gpu, Device::Cpu])]
    pub device: Vec<Device>,
    /// `--adapter`: the adapter a `gpu` in the list opens.
    #[command(flatten)]
    pub adapter: AdapterArgs,
}

impl DeviceListArgs {
    /// Opens each device ([`crate::device::open_devices`]); an error when none opens.
    pub fn open(&self) -> anyhow::Result<Vec<crate::device::OpenDevice>> {
        let devices = crate::device::open_devices(&self.device, &self.adapter.choice());
        if devices.is_empty() {
            anyhow::bail!("none of the requested devices is available");
        }
        Ok(devices)
    }
}

/// The adapter plus progressive-render controls.
#[derive(Debug, Clone, Default, Args)]
pub struct GpuArgs {
    /// `--adapter`: the adapter a GPU render opens.
    #[command(flatten)]
    pub adapter: AdapterArgs,
    /// Stop after about this many seconds and save what was rendered, on the GPU or the CPU
    /// (every pixel gets the same number of samples; the report says how many).
    #[arg(long, value_name = "SECONDS", value_parser = parse_seconds, allow_negative_numbers = true)]
    pub time_limit: Option<Duration>,
    /// GPU path slots per batch (paths in flight at once; default from the device: 131,072
    /// on a software adapter, 2,097,152 on a hardware GPU; at most 4,194,240, more is
    /// clamped). Images do not depend on it.
    #[arg(long, value_name = "PATHS", value_parser = whole::<u32>(1, 1 << 30), allow_negative_numbers = true)]
    pub batch_paths: Option<u32>,
    /// Where GPU kernels read the scene's tables (shapes, BVH nodes, materials, triangles,
    /// texels, ...) from: `auto` puts each table that fits 64 KiB in a uniform buffer and
    /// each larger one in a texture for the shading stages on a software adapter (both
    /// compile much faster on lavapipe than storage buffers), and every table in a storage
    /// buffer on hardware GPUs; `uniform` (where a table fits, else storage), `texture`
    /// (every stage) and `storage` force a placement (for measurements). Images do not
    /// depend on it.
    #[arg(long, value_enum, default_value_t = TablePlacement::Auto)]
    pub tables: TablePlacement,
    /// On a software adapter (llvmpipe), render on one device only, with every core: by
    /// default each llvmpipe device gets half the cores and a render of several batches
    /// shares them with a second device on the same adapter, so that the two use the cores
    /// side by side. Images do not depend on it.
    #[arg(long)]
    pub one_device: bool,
    /// Shards of every GPU queue, each with a counter of its own (default: one per worker
    /// thread of llvmpipe, 1 on other adapters; at most 32): for measuring how much pushes
    /// to one counter cost a device. Images do not depend on it.
    #[arg(long, value_name = "N", value_parser = whole::<u32>(1, u64::from(MAX_QUEUE_SHARDS)), allow_negative_numbers = true)]
    pub queue_shards: Option<u32>,
}

impl GpuArgs {
    /// The options given that only the GPU renderer reads, as the command line names them
    /// (a CPU render says it ignores them rather than leaving a user to wonder).
    pub fn gpu_only_given(&self) -> Vec<&'static str> {
        let given = [
            ("--adapter", self.adapter.adapter.is_some()),
            ("--batch-paths", self.batch_paths.is_some()),
            ("--tables", self.tables != TablePlacement::Auto),
            ("--one-device", self.one_device),
            ("--queue-shards", self.queue_shards.is_some()),
        ];
        given.into_iter().filter_map(|(name, set)| set.then_some(name)).collect()
    }

    /// Pass options for an interactive render: progress bar on, Ctrl-C stops early and
    /// keeps the samples of every completed round.
    pub fn pass_options(&self) -> PassOptions {
        PassOptions {
            time_limit: self.time_limit,
            cancel: Some(ctrlc_flag()),
            progress: true,
            batch_paths: self.batch_paths.unwrap_or(0),
            ..PassOptions::default()
        }
    }
}

/// Seconds as a non-negative, finite decimal number, at most what a `Duration` holds (about
/// 1.8e19 s, 585 billion years).
fn parse_seconds(s: &str) -> Result<Duration, String> {
    let v: f64 = s.trim().parse().map_err(|_| format!("{s:?} is not a number of seconds"))?;
    Duration::try_from_secs_f64(v).map_err(|_| {
        if v.is_finite() && v > 0.0 {
            format!("{s:?}: the time limit must be at most {:e} seconds", Duration::MAX.as_secs_f64())
        } else {
            format!("{s:?}: the time limit must be a finite number of seconds ≥ 0")
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct T {
        #[command(flatten)]
        gpu: GpuArgs,
    }

    #[test]
    fn names_the_gpu_only_options_given() {
        assert!(T::try_parse_from(["t", "--time-limit", "3"]).unwrap().gpu.gpu_only_given().is_empty());
        let t = T::try_parse_from(["t", "--queue-shards", "2", "--adapter", "x", "--tables", "storage"]).unwrap();
        assert_eq!(t.gpu.gpu_only_given(), ["--adapter", "--tables", "--queue-shards"]);
    }

    #[test]
    fn parses_adapter_and_time_limit() {
        let t = T::try_parse_from(["t", "--adapter", "llvm", "--time-limit", "2.5"]).unwrap();
        assert_eq!(t.gpu.adapter.adapter.as_deref(), Some("llvm"));
        assert_eq!(t.gpu.time_limit, Some(Duration::from_millis(2500)));
        let t = T::try_parse_from(["t"]).unwrap();
        assert_eq!((t.gpu.time_limit, t.gpu.pass_options().batch_paths), (None, 0));
        // Each refusal says what is wrong with that value: 1e30 is finite, only too long.
        for (bad, why) in
            [("-1", "finite number of seconds ≥ 0"), ("inf", "finite"), ("1e30", "at most 1.8446744073709552e19")]
        {
            let e = T::try_parse_from(["t", "--time-limit", bad]).err().unwrap().to_string();
            assert!(e.contains(why), "{bad}: {e}");
        }
        let t = T::try_parse_from(["t", "--batch-paths", "4096"]).unwrap();
        assert_eq!(t.gpu.pass_options().batch_paths, 4096);
        assert!(T::try_parse_from(["t", "--batch-paths", "0"]).is_err());
        let t = T::try_parse_from(["t", "--queue-shards", "8"]).unwrap();
        assert_eq!(t.gpu.queue_shards, Some(8));
        assert_eq!(T::try_parse_from(["t"]).unwrap().gpu.queue_shards, None);
        for bad in ["0", "33", "-1", "x"] {
            assert!(T::try_parse_from(["t", "--queue-shards", bad]).is_err(), "{bad}");
        }
    }

    #[test]
    fn bad_time_limits_are_usage_errors() {
        for bad in ["-1", "abc", "inf", "NaN"] {
            let arg = format!("--time-limit={bad}");
            let err = T::try_parse_from(["t", arg.as_str()]).err().expect(bad);
            assert!(err.to_string().contains("time-limit"), "{err}");
        }
    }
}
