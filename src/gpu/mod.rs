//! The GPU side of lumen: adapter selection, a general compute runner, progressive passes
//! with f64 accumulation, and the assembly of WGSL modules from `shaders/`.
//!
//! Everything returns [`GpuError`] instead of panicking: wgpu's validation errors are
//! captured by [`Gpu`] (see [`Gpu::check`] and [`Gpu::scoped`]).

mod accumulate;
mod assemble;
mod compute;
mod device;
pub mod features;
mod kernel_cache;
pub mod layout;
pub mod pack;
mod passes;
pub mod pipeline_cache;
pub mod render;
mod test_support;

pub use accumulate::{Accumulator, Tile};
pub use assemble::{preprocess, AssembleError, Assembled, FeatureSet, Preprocessed, ShaderLibrary, SourceLine};
pub use compute::{validate_wgsl, BindingKind, ComputeKernel, ValidatedModule, MIN_BUFFER_BYTES};
pub use device::{
    list_adapters, probe_loop_limiter, select_adapter, AdapterChoice, AdapterDescription, Gpu, GpuError, ADAPTER_ENV,
    LOOP_LIMITER_ENV, LOOP_LIMITER_PROBE_TRIPS,
};
pub use kernel_cache::KernelCache;
pub use passes::{
    ctrlc_flag, run_progressive, Accumulated, PassOptions, PassUniform, StopReason, MAX_RESUMABLE_PATHS_PER_PASS,
    NO_SOLO, PASS_WGSL,
};
pub use test_support::{gpu_for_tests, gpu_required, REQUIRE_GPU_ENV};
