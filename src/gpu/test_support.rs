//! Shared helper for GPU tests in every area of the crate.
//!
//! Machines without any adapter (some CI runners, sandboxes) should still run the rest of
//! the suite, so a GPU test skips itself there. CI sets `LUMEN_REQUIRE_GPU=1`, where a
//! missing adapter must fail loudly instead of silently skipping every GPU check.

use super::device::{AdapterChoice, Gpu, GpuError};

/// Environment variable that turns "no adapter, skip" into a test failure.
pub const REQUIRE_GPU_ENV: &str = "LUMEN_REQUIRE_GPU";

/// Opens the adapter chosen by `LUMEN_ADAPTER` (else the best one) for test `test_name`.
///
/// Returns `None` after printing `skipped <test_name>: no GPU adapter` when the machine has
/// no adapter, unless `LUMEN_REQUIRE_GPU=1`, in which case it panics. Any other failure
/// (an unknown `LUMEN_ADAPTER`, a device that will not open) panics: that is a broken
/// setup, not a missing GPU.
///
/// ```
/// use lumen::gpu::gpu_for_tests;
/// let Some(gpu) = gpu_for_tests("doc_example") else { return };
/// assert!(gpu.limits.max_storage_buffer_binding_size > 0);
/// ```
pub fn gpu_for_tests(test_name: &str) -> Option<Gpu> {
    match Gpu::new(&AdapterChoice::from_env()) {
        Ok(gpu) => Some(gpu),
        Err(GpuError::NoAdapter) if !gpu_required() => {
            println!("skipped {test_name}: no GPU adapter");
            None
        }
        Err(GpuError::NoAdapter) => {
            panic!("{test_name}: no GPU adapter, and {REQUIRE_GPU_ENV}=1 requires one (install mesa-vulkan-drivers for lavapipe)")
        }
        Err(e) => panic!("{test_name}: cannot open the GPU: {e}"),
    }
}

/// Whether `LUMEN_REQUIRE_GPU` asks for GPU tests to fail rather than skip.
pub fn gpu_required() -> bool {
    std::env::var(REQUIRE_GPU_ENV).is_ok_and(|v| matches!(v.trim(), "1" | "true" | "yes"))
}
