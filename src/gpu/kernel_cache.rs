//! Compiled kernels cached by feature set for the length of a run.
//!
//! Rendering compiles one kernel per (feature set, entry point); tests and progressive
//! re-renders ask for the same ones again, and compiling a path tracer takes long (seconds
//! on lavapipe), so kernels are kept in a map.
//!
//! Across runs, the driver's compiled binaries are kept by wgpu's `PipelineCache` where it
//! is supported (`src/gpu/pipeline_cache.rs`); this map only spares recompiling within a run.

use std::collections::HashMap;
use std::sync::Arc;

use super::assemble::FeatureSet;
use super::compute::ComputeKernel;
use super::device::GpuError;

/// Kernels by (feature set, entry point).
#[derive(Debug, Default)]
pub struct KernelCache {
    kernels: HashMap<(FeatureSet, String), Arc<ComputeKernel>>,
}

impl KernelCache {
    pub fn new() -> Self {
        Self::default()
    }

    /// The cached kernel for (`features`, `entry`), or the one `build` compiles (errors are
    /// returned and not cached, so a fixed shader can be retried).
    pub fn get_or_build(
        &mut self,
        features: &FeatureSet,
        entry: &str,
        build: impl FnOnce() -> Result<ComputeKernel, GpuError>,
    ) -> Result<Arc<ComputeKernel>, GpuError> {
        let key = (features.clone(), entry.to_string());
        if let Some(k) = self.kernels.get(&key) {
            return Ok(Arc::clone(k));
        }
        let kernel = Arc::new(build()?);
        self.kernels.insert(key, Arc::clone(&kernel));
        Ok(kernel)
    }

    /// Number of kernels compiled so far.
    pub fn len(&self) -> usize {
        self.kernels.len()
    }

    pub fn is_empty(&self) -> bool {
        self.kernels.is_empty()
    }
}
