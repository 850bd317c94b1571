//! Compiled pipelines kept across runs: wgpu's `PipelineCache` (driver pipeline binaries),
//! loaded from and saved to one file per adapter and driver.
//!
//! Within a run `KernelCache` already avoids recompiling; across runs the driver's own
//! binaries let a second `lumen render` of the same scene skip most of the compilation
//! (seconds for a path tracer on a software adapter). wgpu supports this on Vulkan only
//! (`Features::PIPELINE_CACHE`); elsewhere, or when the cache is disabled, pipelines are
//! simply compiled every run.
//!
//! Where: `$LUMEN_PIPELINE_CACHE` (a directory; `0`, `off` or empty disables it), else
//! `$XDG_CACHE_HOME/lumen`, else `$HOME/.cache/lumen`. The file name is wgpu's
//! `pipeline_cache_key` for the adapter (vendor, device, driver), so a driver update starts
//! a new file instead of feeding old binaries to a new driver. Any failure to read, write
//! or use the file only costs the compile time it would have saved: it is never an error.

use std::path::{Path, PathBuf};

/// Environment variable that chooses (or disables) the cache directory.
pub const PIPELINE_CACHE_ENV: &str = "LUMEN_PIPELINE_CACHE";

/// A device's pipeline cache and the file it persists to.
#[derive(Debug)]
pub struct DiskPipelineCache {
    pub(crate) cache: wgpu::PipelineCache,
    path: PathBuf,
}

/// The cache directory from the environment (see the module documentation), or `None` when
/// disabled or no home directory is known.
pub fn cache_dir_from_env() -> Option<PathBuf> {
    let var = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty());
    match std::env::var_os(PIPELINE_CACHE_ENV) {
        Some(v) if v.is_empty() || v == "0" || v.eq_ignore_ascii_case("off") => None,
        Some(v) => Some(PathBuf::from(v)),
        None => var("XDG_CACHE_HOME")
            .map(|d| PathBuf::from(d).join("lumen"))
            .or_else(|| var("HOME").map(|h| PathBuf::from(h).join(".cache").join("lumen"))),
    }
}

impl DiskPipelineCache {
    /// Opens (or starts) the cache for `device` in `dir`; `None` when the device was not
    /// opened with `Features::PIPELINE_CACHE` or wgpu has no key for this adapter.
    pub fn open(device: &wgpu::Device, info: &wgpu::AdapterInfo, dir: &Path) -> Option<Self> {
        if !device.features().contains(wgpu::Features::PIPELINE_CACHE) {
            return None;
        }
        let path = dir.join(wgpu::util::pipeline_cache_key(info)?);
        let data = std::fs::read(&path).ok();
        // SAFETY: the data is only ever what `PipelineCache::get_data` returned for an
        // adapter with the same `pipeline_cache_key` (the file is named by that key and
        // written atomically by `save`). wgpu checks its header (version, key, size) and,
        // with `fallback`, starts empty when the data does not fit.
        let cache = unsafe {
            device.create_pipeline_cache(&wgpu::PipelineCacheDescriptor {
                label: Some("lumen pipeline cache"),
                data: data.as_deref(),
                fallback: true,
            })
        };
        Some(Self { cache, path })
    }

    /// The file this cache persists to.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes the cache's current contents (atomically); failures are reported to the
    /// caller, who may ignore them (a missing cache only costs compile time).
    pub fn save(&self) -> std::io::Result<()> {
        let Some(data) = self.cache.get_data() else { return Ok(()) };
        if let Some(dir) = self.path.parent() {
            std::fs::create_dir_all(dir)?;
        }
        crate::image::write_atomically(&self.path, &data)
    }
}
