//! Compiled kernels cached for the length of a run.
//!
//! Rendering compiles one kernel per stage; tests, animation frames and progressive
//! re-renders ask for the same ones again, and compiling takes long (seconds on lavapipe),
//! so kernels are kept by their assembled source and entry point: the source holds every
//! feature and generated constant, so equal sources are the same kernel.
//!
//! Across runs, the driver's compiled binaries are kept by wgpu's `PipelineCache` where it
//! is supported (`src/gpu/pipeline_cache.rs`); this map only spares recompiling within a run.

use std::collections::HashMap;
use std::sync::Arc;

use super::compute::ComputeKernel;
use super::device::GpuError;

/// Kernels by (WGSL source, entry point).
#[derive(Debug, Default)]
pub struct KernelCache {
    kernels: HashMap<(String, String), Arc<ComputeKernel>>,
}

impl KernelCache {
    /// An empty cache.
    pub fn new() -> Self {
        Self::default()
    }

    /// The cached kernel of `entry` in `source`, if compiled before.
    pub fn get(&self, source: &str, entry: &str) -> Option<Arc<ComputeKernel>> {
        self.kernels.get(&(source.to_string(), entry.to_string())).cloned()
    }

    /// Keeps a kernel compiled from `source`; returns the shared handle.
    pub fn insert(&mut self, source: &str, entry: &str, kernel: ComputeKernel) -> Arc<ComputeKernel> {
        let kernel = Arc::new(kernel);
        self.kernels.insert((source.to_string(), entry.to_string()), Arc::clone(&kernel));
        kernel
    }

    /// The cached kernel, or the one `build` compiles (errors are returned and not cached,
    /// so a fixed shader can be retried).
    pub fn get_or_build(
        &mut self,
        source: &str,
        entry: &str,
        build: impl FnOnce() -> Result<ComputeKernel, GpuError>,
    ) -> Result<Arc<ComputeKernel>, GpuError> {
        if let Some(k) = self.get(source, entry) {
            return Ok(k);
        }
        Ok(self.insert(source, entry, build()?))
    }

    /// Number of kernels compiled so far.
    pub fn len(&self) -> usize {
        self.kernels.len()
    }

    /// Whether the cache holds no kernel yet.
    pub fn is_empty(&self) -> bool {
        self.kernels.is_empty()
    }
}
