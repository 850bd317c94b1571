//! A scene's new kernels compiled in parallel on llvmpipe (Mesa's lavapipe).
//!
//! llvmpipe keeps only the NIR when a pipeline is created and compiles a kernel with LLVM at
//! its first launch, on the one thread that runs the device's queue: however many threads
//! create the pipelines, a scene's kernels compile one after another in its first round
//! (DESIGN.md "Parallel kernel compilation"). The code it compiles goes to Mesa's on-disk
//! shader cache, keyed by the kernel's NIR, where every device of the driver looks first.
//! So before the first round each new kernel is launched once over an empty grid, which
//! compiles it and runs nothing, from several devices at once: this device and its *twins*
//! (more devices on the same adapter, each with a queue thread of its own) take kernels
//! from one list, largest first, and what a twin compiles reaches this device through the
//! cache. Twins are dropped before the render starts (their driver instances shut down,
//! which finishes the cache's writes), so the first round finds their code; a kernel not
//! found there is compiled again at its first launch: time lost, never a different result.
//!
//! A twin first waits up to `WARM_PROBE` for this device's first launch: when that ends so
//! soon, the cache was warm and the twin is not opened.
//!
//! Twins only where they can help: llvmpipe through Vulkan, more than one core, at least two
//! new kernels, and Mesa's shader cache not switched off (`MESA_SHADER_CACHE_DISABLE`);
//! `LUMEN_PARALLEL_JIT=0` turns them off. Without twins llvmpipe's kernels are still
//! compiled here, one after another on this device, so that kernel creation ends before the
//! render starts wherever it runs and is timed as such (`GpuRenderOutput::kernel_seconds`).

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use super::compute::{BindingKind, BoundResource, ComputeKernel, MIN_BUFFER_BYTES};
use super::device::{Gpu, GpuError};

/// Most devices compiling at once (this one included): each twin is a driver instance
/// with its own threads and memory.
const MAX_DEVICES: usize = 8;

/// How long a twin waits for this device's first launch before opening: a launch that
/// finds its kernel in the cache takes 1–2 ms, one that compiles 0.05–1 s.
const WARM_PROBE: Duration = Duration::from_millis(20);

/// A kernel to compile ahead: the pipeline, and the WGSL (or, where the caller kept it,
/// its already validated module) and entry point a twin compiles it from.
pub(crate) struct Job<'a> {
    pub kernel: &'a ComputeKernel,
    pub source: &'a str,
    pub module: Option<&'a naga::Module>,
    pub entry: &'a str,
}

/// Whether a Mesa boolean environment variable is set to true (as Mesa reads it).
fn env_true(name: &str) -> bool {
    std::env::var(name).is_ok_and(|v| matches!(v.to_ascii_lowercase().as_str(), "1" | "true" | "yes" | "y"))
}

/// Whether the environment rules twins out: Mesa's shader cache switched off (they could
/// hand nothing over), or `LUMEN_PARALLEL_JIT=0`.
fn switched_off() -> bool {
    env_true("MESA_SHADER_CACHE_DISABLE")
        || env_true("MESA_GLSL_CACHE_DISABLE")
        || std::env::var("LUMEN_PARALLEL_JIT").is_ok_and(|v| v.trim() == "0")
}

/// Whether the device compiles a kernel at its first launch (llvmpipe through Vulkan;
/// wgpu's OpenGL backend also reaches llvmpipe, but through EGL contexts that a second
/// device on another thread would have to share with care).
pub(crate) fn lazy_jit(info: &wgpu::AdapterInfo) -> bool {
    info.backend == wgpu::Backend::Vulkan && info.device_type == wgpu::DeviceType::Cpu && super::is_llvmpipe(info)
}

/// Twins to open for `jobs` new kernels on a device described by `info` with `cores`
/// cores (0: this device compiles them alone).
fn twins_for(info: &wgpu::AdapterInfo, jobs: usize, cores: usize) -> usize {
    if !lazy_jit(info) || switched_off() || jobs < 2 {
        return 0;
    }
    cores.min(jobs).min(MAX_DEVICES).saturating_sub(1)
}

/// Compiles `jobs` (kernels of `gpu`) before their first real launch where the device
/// compiles lazily, in parallel over twins of `gpu` where that helps (see the module
/// documentation); does nothing elsewhere. Errors are this device's: a twin that fails
/// only gives its share back.
pub(crate) fn compile_ahead(gpu: &Gpu, jobs: &[Job]) -> Result<(), GpuError> {
    if !lazy_jit(&gpu.adapter_info) {
        return Ok(());
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let twins = twins_for(&gpu.adapter_info, jobs.len(), cores);
    // Largest source first: the last kernel to finish decides when all are done.
    let mut order: Vec<&Job> = jobs.iter().collect();
    order.sort_by_key(|j| std::cmp::Reverse(j.source.len()));
    let next = AtomicUsize::new(0);
    let take = || order.get(next.fetch_add(1, Ordering::Relaxed)).copied();
    let take = &take;
    let first_done = AtomicBool::new(false);
    let first_done = &first_done;
    std::thread::scope(|scope| {
        for _ in 0..twins {
            scope.spawn(move || {
                // A warm cache answers this device's first launch (the largest kernel) in a
                // few milliseconds, and then a twin would only cost its opening (~30 ms).
                let probe = Instant::now();
                while !first_done.load(Ordering::Acquire) && probe.elapsed() < WARM_PROBE {
                    std::thread::sleep(Duration::from_millis(1));
                }
                if first_done.load(Ordering::Acquire) {
                    return;
                }
                let Some(twin) = gpu.twin() else { return };
                while let Some(job) = take() {
                    // Failing here only moves the kernel's compilation to its first launch.
                    let (label, loops) = (&job.kernel.label, job.kernel.loops);
                    let compiled = match job.module {
                        Some(module) => twin.kernel_from_module(label, module.clone(), job.entry, loops),
                        None => twin.kernel_with_loops(label, job.source, job.entry, loops),
                    };
                    if let Ok(kernel) = compiled {
                        let _ = launch_empty(&twin, &kernel);
                    }
                }
            });
        }
        while let Some(job) = take() {
            let result = launch_empty(gpu, job.kernel);
            first_done.store(true, Ordering::Release);
            result?;
        }
        Ok(())
    })
}

/// Launches `kernel` over an empty grid, which makes llvmpipe compile it: every binding
/// gets a buffer of the least size it accepts (or a one-texel texture), which nothing reads.
fn launch_empty(gpu: &Gpu, kernel: &ComputeKernel) -> Result<(), GpuError> {
    let mut resources = Vec::new();
    for (list, bytes) in kernel.bindings.iter().zip(&kernel.binding_bytes) {
        let mut group = Vec::new();
        for (&(_, kind), &size) in list.iter().zip(bytes) {
            let usage = match kind {
                BindingKind::Uniform => wgpu::BufferUsages::UNIFORM,
                BindingKind::Storage { .. } => wgpu::BufferUsages::STORAGE,
                BindingKind::TextureU32 => {
                    group.push(BoundResource::Texture(gpu.u32_texture("empty launch", &[], 1)?));
                    continue;
                }
            };
            group.push(BoundResource::Buffer(gpu.scoped(|| {
                gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("empty launch"),
                    size: size.max(MIN_BUFFER_BYTES).next_multiple_of(16),
                    usage,
                    mapped_at_creation: false,
                })
            })?));
        }
        resources.push(group);
    }
    let groups = resources
        .iter()
        .enumerate()
        .map(|(g, list)| kernel.bind_group_of(gpu, g as u32, list.iter().map(BoundResource::binding).collect()))
        .collect::<Result<Vec<_>, _>>()?;
    gpu.dispatch(kernel, &groups.iter().collect::<Vec<_>>(), [0, 0, 0])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn adapter(name: &str, device_type: wgpu::DeviceType) -> wgpu::AdapterInfo {
        wgpu::AdapterInfo { name: name.into(), ..wgpu::AdapterInfo::new(device_type, wgpu::Backend::Vulkan) }
    }

    /// Kernels compiled ahead (empty launches where this adapter is llvmpipe, and twins
    /// where the first of those launches compiles for longer than `WARM_PROBE`, from a kept
    /// module or from the WGSL) still do their work: a uniform struct, a fixed-size and a
    /// runtime-sized storage array get their least sizes for the empty launches, then real
    /// buffers.
    #[test]
    fn kernels_compiled_ahead_run_as_compiled() {
        let Some(gpu) = crate::gpu::gpu_for_tests("kernels_compiled_ahead_run_as_compiled") else { return };
        let sources = [
            "struct P { k: vec4<u32> }
             @group(0) @binding(0) var<uniform> p: P;
             @group(0) @binding(1) var<storage, read_write> v: array<u32>;
             @compute @workgroup_size(64)
             fn main(@builtin(global_invocation_id) id: vec3<u32>) {
                 if (id.x < arrayLength(&v)) { v[id.x] = v[id.x] * p.k.x; }
             }",
            "@group(0) @binding(0) var<storage, read> table: array<u32, 4>;
             @group(1) @binding(0) var<storage, read_write> v: array<u32>;
             @compute @workgroup_size(64)
             fn main(@builtin(global_invocation_id) id: vec3<u32>) {
                 if (id.x < arrayLength(&v)) { v[id.x] = v[id.x] + table[id.x % 4u]; }
             }",
        ];
        let kernels: Vec<ComputeKernel> = sources.iter().map(|s| gpu.compute_kernel("t", s, "main").unwrap()).collect();
        // A twin compiles the first from its kept module, the second from its WGSL.
        let kept = crate::gpu::validate_wgsl("t", sources[0]).unwrap().module;
        let modules = [Some(&kept), None];
        let jobs: Vec<Job> = kernels
            .iter()
            .zip(&sources)
            .zip(modules)
            .map(|((kernel, source), module)| Job { kernel, source, module, entry: "main" })
            .collect();
        compile_ahead(&gpu, &jobs).unwrap();
        let v = gpu.storage_buffer("v", &[1u32, 2, 3, 4, 5]).unwrap();
        let p = gpu.uniform_buffer("p", &[3u32, 0, 0, 0]).unwrap();
        let table = gpu.storage_buffer("table", &[10u32, 20, 30, 40]).unwrap();
        let g = kernels[0].bind_group(&gpu, 0, &[&p, &v]).unwrap();
        gpu.dispatch(&kernels[0], &[&g], kernels[0].workgroups_for([5, 1, 1])).unwrap();
        let g0 = kernels[1].bind_group(&gpu, 0, &[&table]).unwrap();
        let g1 = kernels[1].bind_group(&gpu, 1, &[&v]).unwrap();
        gpu.dispatch(&kernels[1], &[&g0, &g1], kernels[1].workgroups_for([5, 1, 1])).unwrap();
        assert_eq!(gpu.read_buffer::<u32>(&v, 5).unwrap(), [13, 26, 39, 52, 25]);
        assert_eq!(kernels[1].binding_bytes, [vec![16], vec![4]]);
        assert_eq!(kernels[0].binding_bytes, [vec![16, 4]]);
    }

    /// Twins only for llvmpipe, with cores and kernels to share; never more than the
    /// kernels or MAX_DEVICES allow. (The environment switches are read as Mesa reads them;
    /// the test leaves them as the run has them and checks only the cases they allow.)
    #[test]
    fn twins_only_where_llvmpipe_compiles_serially() {
        let llvmpipe = adapter("llvmpipe (LLVM 15.0.6, 128 bits)", wgpu::DeviceType::Cpu);
        let gpu = adapter("NVIDIA H200", wgpu::DeviceType::DiscreteGpu);
        let swiftshader = adapter("SwiftShader Device", wgpu::DeviceType::Cpu);
        let gl = wgpu::AdapterInfo { backend: wgpu::Backend::Gl, ..llvmpipe.clone() };
        for cores in [1, 2, 16] {
            assert_eq!(twins_for(&gpu, 9, cores), 0);
            assert_eq!(twins_for(&swiftshader, 9, cores), 0);
            assert_eq!(twins_for(&gl, 9, cores), 0);
            assert_eq!(twins_for(&llvmpipe, 1, cores), 0);
        }
        assert_eq!(twins_for(&llvmpipe, 9, 1), 0);
        if !switched_off() {
            assert_eq!(twins_for(&llvmpipe, 9, 2), 1);
            assert_eq!(twins_for(&llvmpipe, 3, 16), 2);
            assert_eq!(twins_for(&llvmpipe, 20, 16), MAX_DEVICES - 1);
        }
    }
}
