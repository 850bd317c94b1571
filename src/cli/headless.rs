//! Quiet GPU start-up on headless machines.
//!
//! wgpu enables every Vulkan surface extension the loader offers, Wayland's included, even
//! for compute-only use (no wgpu option turns them off). Seeing `VK_KHR_wayland_surface`
//! enabled, Mesa's device-select layer asks libwayland for the default display to rank the
//! GPUs, and libwayland prints `error: XDG_RUNTIME_DIR is invalid or not set in the
//! environment.` when that variable is unset or relative, once per Vulkan instance. lumen
//! needs no window, so when the variable is unusable it gets a private, empty directory
//! (mode 0700, as the XDG spec asks) for the life of the process: libwayland then finds no
//! socket there and says nothing, while real driver errors still print. A valid
//! `XDG_RUNTIME_DIR` (a desktop session) is left alone. docs/DESIGN.md, "Headless start-up",
//! weighs the alternatives.

use std::ffi::OsStr;
use std::os::unix::fs::DirBuilderExt as _;
use std::path::{Path, PathBuf};

/// The variable libwayland reads.
pub const RUNTIME_DIR_ENV: &str = "XDG_RUNTIME_DIR";

/// A runtime directory made for this process; removed when dropped.
#[derive(Debug)]
pub struct PrivateRuntimeDir(Option<PathBuf>);

impl PrivateRuntimeDir {
    /// The directory made, if one was.
    pub fn path(&self) -> Option<&Path> {
        self.0.as_deref()
    }
}

impl Drop for PrivateRuntimeDir {
    fn drop(&mut self) {
        if let Some(dir) = &self.0 {
            let _ = std::fs::remove_dir_all(dir);
        }
    }
}

/// Whether libwayland would accept `value` (set, absolute) and it names a directory.
pub fn is_usable(value: Option<&OsStr>) -> bool {
    value.is_some_and(|v| Path::new(v).is_absolute() && Path::new(v).is_dir())
}

/// Gives the process a private `XDG_RUNTIME_DIR` when the inherited one is unusable.
///
/// Must run at the very start of `main`, before any thread exists: it changes the
/// environment, which is only sound while no other thread can read it. Failing to make
/// the directory costs only the noise, so errors are ignored.
pub fn ensure_runtime_dir() -> PrivateRuntimeDir {
    if is_usable(std::env::var_os(RUNTIME_DIR_ENV).as_deref()) {
        return PrivateRuntimeDir(None);
    }
    let base = std::env::temp_dir();
    let pid = std::process::id();
    for attempt in 0..16u32 {
        let dir = base.join(format!("lumen-runtime-{pid}-{attempt}"));
        // `create` fails if the path exists, so a directory planted by someone else is never used.
        if std::fs::DirBuilder::new().mode(0o700).create(&dir).is_ok() {
            std::env::set_var(RUNTIME_DIR_ENV, &dir);
            crate::stop::remove_at_forced_exit(dir.clone());
            return PrivateRuntimeDir(Some(dir));
        }
    }
    PrivateRuntimeDir(None)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn usable_means_an_absolute_directory() {
        assert!(!is_usable(None));
        assert!(!is_usable(Some(OsStr::new(""))));
        assert!(!is_usable(Some(OsStr::new("relative/dir"))));
        assert!(!is_usable(Some(OsStr::new("/nonexistent/lumen/runtime"))));
        let dir = tempfile::tempdir().unwrap();
        assert!(is_usable(Some(dir.path().as_os_str())));
    }
}
