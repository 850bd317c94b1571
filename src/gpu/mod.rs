//! The GPU side of lumen: adapter selection, a general compute runner, the wavefront path
//! tracer (rounds of batches with f64 accumulation), and the assembly of WGSL modules from
//! `shaders/`.
//!
//! Everything returns [`GpuError`] instead of panicking: wgpu's validation errors are
//! captured by [`Gpu`] (see [`Gpu::check`] and [`Gpu::scoped`]).

mod accumulate;
mod assemble;
mod compute;
mod device;
pub mod features;
mod kernel_cache;
pub mod kernels;
pub mod layout;
pub mod pack;
mod parallel_jit;
pub mod pipeline_cache;
pub mod render;
pub mod tables;
mod test_support;
pub mod traversal;
pub mod wavefront;

pub use accumulate::Accumulator;
pub use assemble::{preprocess, AssembleError, Assembled, FeatureNames, Preprocessed, ShaderLibrary, SourceLine};
pub(crate) use compute::Loops;
pub use compute::{validate_wgsl, BindingKind, BoundResource, ComputeKernel, ValidatedModule, MIN_BUFFER_BYTES};
pub use device::{
    driver_name, is_llvmpipe, list_adapters, llvmpipe_prefers_wide_vectors, llvmpipe_vector_bits, mesa_version,
    on_adapter_chosen, probe_loop_limiter, select_adapter, texel_fetches_trusted, AdapterChoice, AdapterDescription,
    Gpu, GpuError, ADAPTER_ENV, LOOP_LIMITER_PROBE_TRIPS, WIDE_VECTORS_FROM_MESA,
};
pub use kernel_cache::KernelCache;
pub use test_support::{gpu_for_tests, gpu_required, REQUIRE_GPU_ENV};
pub use wavefront::{ctrlc_flag, PassOptions, StopReason};
