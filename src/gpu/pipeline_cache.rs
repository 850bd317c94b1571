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
//!
//! The file wraps wgpu's data in an envelope of lumen's ([`wrap`]: a magic word, the
//! length and a CRC-32). wgpu checks only its header, not the driver's binaries after it
//! ("wgpu does not protect against malicious writes", its documentation says), and hands
//! those to the driver as they are; a file damaged on disk is therefore dropped here,
//! before any driver sees it, and the cache starts empty.

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
        let file = crate::regular_file::read(&path).ok();
        let data = file.as_deref().and_then(unwrap);
        let create = |data: Option<&[u8]>| {
            // SAFETY: the data is only ever what `PipelineCache::get_data` returned for an
            // adapter with the same `pipeline_cache_key` (the file is named by that key,
            // written atomically by `save`, and its checksum holds). wgpu checks its header
            // (version, key, size) and, with `fallback`, starts empty when the data does not
            // fit, except where the header names another device (below).
            let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
            let cache = unsafe {
                device.create_pipeline_cache(&wgpu::PipelineCacheDescriptor {
                    label: Some("lumen pipeline cache"),
                    data,
                    fallback: true,
                })
            };
            (cache, pollster::block_on(scope.pop()))
        };
        let (mut cache, error) = create(data);
        if error.is_some() {
            // wgpu refuses, even with `fallback`, a header that names another adapter, which
            // only a damaged file under this adapter's name can hold; every pipeline created
            // with that cache would fail. Start empty instead (the next save replaces it).
            cache = create(None).0;
        }
        Some(Self { cache, path })
    }

    /// Writes the cache's current contents (atomically); failures are reported to the
    /// caller, who may ignore them (a missing cache only costs compile time).
    pub fn save(&self) -> std::io::Result<()> {
        let Some(data) = self.cache.get_data() else { return Ok(()) };
        if let Some(dir) = self.path.parent() {
            std::fs::create_dir_all(dir)?;
        }
        crate::image::write_atomically(&self.path, &wrap(&data))
    }
}

/// The first bytes of a cache file lumen wrote (a version of the envelope's layout).
const MAGIC: &[u8; 8] = b"LUMENPC1";
/// Bytes before wgpu's data: the magic word, the data's length (u64) and CRC-32 (u32).
const ENVELOPE: usize = 8 + 8 + 4;

/// wgpu's cache data in lumen's envelope, as [`DiskPipelineCache::save`] writes it.
///
/// ```
/// use lumen::gpu::pipeline_cache::{unwrap, wrap};
/// let file = wrap(b"driver binaries");
/// assert_eq!(unwrap(&file), Some(&b"driver binaries"[..]));
/// let mut damaged = file.clone();
/// damaged[25] ^= 1;
/// assert_eq!(unwrap(&damaged), None);
/// ```
pub fn wrap(data: &[u8]) -> Vec<u8> {
    let mut file = Vec::with_capacity(ENVELOPE + data.len());
    file.extend_from_slice(MAGIC);
    file.extend_from_slice(&(data.len() as u64).to_le_bytes());
    file.extend_from_slice(&crc32fast::hash(data).to_le_bytes());
    file.extend_from_slice(data);
    file
}

/// The data of a cache file [`wrap`] wrote, or `None` when the file is not one, or was cut
/// short, extended or damaged since.
pub fn unwrap(file: &[u8]) -> Option<&[u8]> {
    let (head, data) = file.split_at_checked(ENVELOPE)?;
    let len = u64::from_le_bytes(head[8..16].try_into().ok()?);
    let crc = u32::from_le_bytes(head[16..20].try_into().ok()?);
    (head[..8] == *MAGIC && len == data.len() as u64 && crc == crc32fast::hash(data)).then_some(data)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every single-bit flip, every cut and an extension of a wrapped file are refused.
    #[test]
    fn damaged_files_are_refused() {
        let data: Vec<u8> = (0..200u32).map(|i| (i * 37 % 251) as u8).collect();
        let file = wrap(&data);
        assert_eq!(unwrap(&file), Some(&data[..]));
        assert_eq!(unwrap(&wrap(&[])), Some(&[][..]));
        for bit in 0..file.len() * 8 {
            let mut f = file.clone();
            f[bit / 8] ^= 1 << (bit % 8);
            assert_eq!(unwrap(&f), None, "bit {bit}");
        }
        for cut in 0..file.len() {
            assert_eq!(unwrap(&file[..cut]), None, "cut at {cut}");
        }
        let mut longer = file.clone();
        longer.push(0);
        assert_eq!(unwrap(&longer), None);
        // A file of wgpu's own format (before the envelope) starts the cache empty.
        assert_eq!(unwrap(b"WGPUPLCH\0\0\0\x01\0\0\0\x08 and the rest of an old file"), None);
    }
}
