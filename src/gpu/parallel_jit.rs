//! A scene's new kernels created, and on llvmpipe (Mesa's lavapipe) compiled, in parallel.
//!
//! llvmpipe keeps only the NIR when a pipeline is created and compiles a kernel with LLVM at
//! its first launch, on the one thread that runs the device's queue: however many threads
//! create the pipelines, a scene's kernels compile one after another in its first round
//! (DESIGN.md "Parallel kernel compilation"). The code it compiles goes to Mesa's on-disk
//! shader cache, keyed by the kernel's NIR, where every device of the driver looks first.
//! So each new kernel is launched once over an empty grid before the first round, which
//! compiles it and runs nothing, from several devices at once: this device and its *twins*
//! (more devices on the same adapter, each with a queue thread of its own) take kernels
//! from one list, largest first, and what a twin compiles reaches this device through the
//! cache. Twins are dropped before the render starts (their driver instances shut down,
//! which finishes the cache's writes), so the first round finds their code; a kernel not
//! found there is compiled again at its first launch: time lost, never a different result.
//!
//! Pipelines first, then compilation: creating a pipeline on a device waits while that
//! device compiles a kernel (a pipeline begun during a 0.34-s compilation ended with it), so
//! this thread and one helper per further core first create all of this device's
//! pipelines, largest first, from one list; a pool as large as the cores, rather than a
//! thread per kernel, ends them sooner (the largest is not left to finish alone) and makes
//! a warm start 20 % shorter. Then this thread launches them, largest first, and each
//! helper, once this device's first launch has run for `WARM_PROBE` (a launch that finds
//! its kernel in a warm cache ends sooner, and then a twin would only cost its opening),
//! opens a twin and takes kernels from the same list. On other adapters, which compile
//! when a pipeline is created, only the first phase runs.
//!
//! Twins only where they can help: llvmpipe through Vulkan, more than one core, at least two
//! new kernels, and Mesa's shader cache not switched off (`MESA_SHADER_CACHE_DISABLE`);
//! `LUMEN_PARALLEL_JIT=0` turns them off. Without twins llvmpipe's kernels are still
//! compiled here, one after another on this device, so that kernel creation ends before the
//! render starts wherever it runs and is timed as such (`GpuRenderOutput::kernel_seconds`).

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

use super::compute::{BindingKind, BoundResource, ComputeKernel, Loops, MIN_BUFFER_BYTES};
use super::device::{Gpu, GpuError};

/// Most devices compiling at once (this one included): each twin is a driver instance
/// with its own threads and memory.
const MAX_DEVICES: usize = 8;

/// How long this device's first launch must run before helpers open twins: a launch that
/// finds its kernel in the cache takes 1–8 ms (the largest kernel, read from the cache
/// first), one that compiles 0.05–1 s.
const WARM_PROBE: Duration = Duration::from_millis(20);

/// A kernel to create: its label, WGSL (its length orders the list), entry point and loops.
/// The module comes from the `validate` function given with the list, called once per
/// kernel whoever creates it first.
pub(crate) struct Job<'a> {
    pub label: String,
    pub source: &'a str,
    pub entry: &'a str,
    pub loops: Loops,
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

/// One kernel's progress: its pipeline on this device once created, and the validated
/// module kept for twins.
#[derive(Default)]
struct Slot {
    kernel: Option<ComputeKernel>,
    module: Option<naga::Module>,
}

/// The state the threads of [`create_kernels`] share.
struct Schedule<'a, V> {
    gpu: &'a Gpu,
    jobs: &'a [Job<'a>],
    validate: &'a V,
    /// Job indices, largest source first.
    order: Vec<usize>,
    slots: Vec<Mutex<Slot>>,
    /// Positions in `order` of the next pipeline to create and of the next kernel to
    /// compile (on this device or a twin).
    next_pipeline: AtomicUsize,
    next: AtomicUsize,
    /// Whether twins may open (and so whether modules are kept for them).
    twins: bool,
    /// When this device's first launch started, and whether it has ended.
    first_started: OnceLock<Instant>,
    first_done: AtomicBool,
    /// Set when this thread's part ends, however it ends: helpers waiting for the probe, or
    /// serving on a twin, stop.
    finished: AtomicBool,
}

impl<V: Fn(usize) -> Result<naga::Module, GpuError> + Sync> Schedule<'_, V> {
    /// Job `i`'s pipeline on this device, created unless someone already has; the module
    /// is kept for twins. A failure leaves the slot empty (the caller that needs the kernel
    /// reports it).
    fn ensure(&self, i: usize) -> Result<(), GpuError> {
        let mut slot = self.slots[i].lock().unwrap_or_else(|e| e.into_inner());
        self.fill(i, &mut slot)
    }

    fn fill(&self, i: usize, slot: &mut Slot) -> Result<(), GpuError> {
        if slot.kernel.is_none() {
            let job = &self.jobs[i];
            let module = match slot.module.take() {
                Some(m) => m,
                None => (self.validate)(i)?,
            };
            let kept = self.twins.then(|| module.clone());
            slot.kernel = Some(self.gpu.kernel_from_module(&job.label, module, job.entry, job.loops)?);
            slot.module = kept;
        }
        Ok(())
    }

    /// Creates this device's pipelines, largest first, with the other threads: a device
    /// cannot create a pipeline while it compiles a kernel (lavapipe holds the device for
    /// the launch), so every pipeline is made before the first launch. A failure leaves its
    /// slot empty, for the final sweep to report.
    fn create_pipelines(&self) {
        loop {
            let k = self.next_pipeline.fetch_add(1, Ordering::Relaxed);
            let Some(&i) = self.order.get(k) else { return };
            let _ = self.ensure(i);
        }
    }

    /// This thread, once every pipeline is made: launches the kernels from the front of the
    /// list where the device compiles lazily.
    fn compile_here(&self) -> Result<(), GpuError> {
        loop {
            let k = self.next.fetch_add(1, Ordering::Relaxed);
            let Some(&i) = self.order.get(k) else { return Ok(()) };
            let slot = self.slots[i].lock().unwrap_or_else(|e| e.into_inner());
            let Some(kernel) = slot.kernel.as_ref() else { continue };
            let _ = self.first_started.set(Instant::now());
            let result = launch_empty(self.gpu, kernel);
            self.first_done.store(true, Ordering::Release);
            result?;
        }
    }

    /// A helper, once every pipeline is made: waits for this device's first launch to show
    /// the cache cold, then serves as a twin, taking kernels from the same list as this
    /// thread; failing there only moves a kernel's compilation to its first launch.
    fn compile_on_twin(&self) {
        while !self.cold() {
            if self.finished.load(Ordering::Acquire) || self.first_done.load(Ordering::Acquire) {
                return;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        let Some(twin) = self.gpu.twin() else { return };
        // Once this thread is done every kernel is taken, or it failed and the rest is moot.
        while !self.finished.load(Ordering::Acquire) {
            let k = self.next.fetch_add(1, Ordering::Relaxed);
            let Some(&i) = self.order.get(k) else { return };
            let module = self.slots[i].lock().unwrap_or_else(|e| e.into_inner()).module.clone();
            let job = &self.jobs[i];
            let Some(module) = module else { continue };
            if let Ok(kernel) = twin.kernel_from_module(&job.label, module, job.entry, job.loops) {
                let _ = launch_empty(&twin, &kernel);
            }
        }
    }

    /// Whether this device's first launch has run long enough to be compiling.
    fn cold(&self) -> bool {
        self.twins
            && !self.first_done.load(Ordering::Acquire)
            && self.first_started.get().is_some_and(|t| t.elapsed() >= WARM_PROBE)
    }
}

/// Sets its flag when dropped: the end of this thread's part, however it ends.
struct Finish<'a>(&'a AtomicBool);

impl Drop for Finish<'_> {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Release);
    }
}

/// Creates the kernels of `jobs` on `gpu` (job i's module from `validate(i)`) and, where the
/// device compiles lazily, compiles them before their first real launch, in parallel over
/// twins of `gpu` where that helps (see the module documentation). The kernels come back in
/// the order of `jobs`; errors are this device's, each job's own (a twin that fails only
/// gives its share back).
pub(crate) fn create_kernels<V>(gpu: &Gpu, jobs: &[Job], validate: &V) -> Result<Vec<ComputeKernel>, GpuError>
where
    V: Fn(usize) -> Result<naga::Module, GpuError> + Sync,
{
    let lazy = lazy_jit(&gpu.adapter_info);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let twins = twins_for(&gpu.adapter_info, jobs.len(), cores);
    let helpers = if twins > 0 { twins } else { cores.min(jobs.len()).saturating_sub(1) };
    // Largest source first: the last kernel to finish decides when all are done.
    let mut order: Vec<usize> = (0..jobs.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(jobs[i].source.len()));
    let schedule = Schedule {
        gpu,
        jobs,
        validate,
        order,
        slots: jobs.iter().map(|_| Mutex::default()).collect(),
        next_pipeline: AtomicUsize::new(0),
        next: AtomicUsize::new(0),
        twins: twins > 0,
        first_started: OnceLock::new(),
        first_done: AtomicBool::new(false),
        finished: AtomicBool::new(false),
    };
    let schedule = &schedule;
    // Helpers that have made their last pipeline: this thread launches nothing before all
    // have (a helper's panic is caught first, its kernel left for the final sweep).
    let helpers_done = &AtomicUsize::new(0);
    std::thread::scope(|scope| {
        // However this thread leaves (an error, a panic), helpers waiting for its first
        // launch, or taking kernels on a twin, stop.
        let _finish = Finish(&schedule.finished);
        let mut spawned = 0;
        for _ in 0..helpers {
            let helper = move || {
                let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| schedule.create_pipelines()));
                helpers_done.fetch_add(1, Ordering::Release);
                if schedule.twins {
                    schedule.compile_on_twin();
                }
            };
            // A thread the system refuses is one helper fewer.
            spawned += usize::from(std::thread::Builder::new().spawn_scoped(scope, helper).is_ok());
        }
        schedule.create_pipelines();
        while helpers_done.load(Ordering::Acquire) < spawned {
            std::thread::sleep(Duration::from_micros(200));
        }
        if lazy {
            schedule.compile_here()
        } else {
            Ok(())
        }
    })?;
    // Every kernel a twin took has its pipeline here unless creating it failed: then this
    // thread tries again, which reports the error.
    let mut kernels = Vec::with_capacity(jobs.len());
    for (i, slot) in schedule.slots.iter().enumerate() {
        let mut slot = slot.lock().unwrap_or_else(|e| e.into_inner());
        schedule.fill(i, &mut slot)?;
        kernels.push(slot.kernel.take().ok_or_else(|| GpuError::Internal("kernel not created".into()))?);
    }
    Ok(kernels)
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

    /// Kernels created in parallel (and, on llvmpipe, compiled ahead: empty launches here,
    /// and twins where the first of those compiles for longer than `WARM_PROBE`) come back
    /// in the order of their jobs, whichever thread made them, and do their work: a uniform
    /// struct, a fixed-size and a runtime-sized storage array get their least sizes for the
    /// empty launches, then real buffers.
    #[test]
    fn kernels_created_in_parallel_run_as_compiled() {
        let Some(gpu) = crate::gpu::gpu_for_tests("kernels_created_in_parallel_run_as_compiled") else { return };
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
            "@group(0) @binding(0) var<storage, read_write> v: array<u32>;
             @compute @workgroup_size(64)
             fn main(@builtin(global_invocation_id) id: vec3<u32>) {
                 if (id.x < arrayLength(&v)) { v[id.x] = v[id.x] + 1u; }
             }",
        ];
        let jobs: Vec<Job> = sources
            .iter()
            .enumerate()
            .map(|(i, source)| Job { label: format!("t{i}"), source, entry: "main", loops: Loops::Bounded })
            .collect();
        let validations = AtomicUsize::new(0);
        let kernels = create_kernels(&gpu, &jobs, &|i: usize| {
            validations.fetch_add(1, Ordering::Relaxed);
            crate::gpu::validate_wgsl("t", sources[i]).map(|v| v.module)
        })
        .unwrap();
        assert_eq!(validations.into_inner(), 3, "each WGSL is validated once");
        assert_eq!(kernels.iter().map(|k| k.label.as_str()).collect::<Vec<_>>(), ["t0", "t1", "t2"]);
        let v = gpu.storage_buffer("v", &[1u32, 2, 3, 4, 5]).unwrap();
        let p = gpu.uniform_buffer("p", &[3u32, 0, 0, 0]).unwrap();
        let table = gpu.storage_buffer("table", &[10u32, 20, 30, 40]).unwrap();
        let g = kernels[0].bind_group(&gpu, 0, &[&p, &v]).unwrap();
        gpu.dispatch(&kernels[0], &[&g], kernels[0].workgroups_for([5, 1, 1])).unwrap();
        let g0 = kernels[1].bind_group(&gpu, 0, &[&table]).unwrap();
        let g1 = kernels[1].bind_group(&gpu, 1, &[&v]).unwrap();
        gpu.dispatch(&kernels[1], &[&g0, &g1], kernels[1].workgroups_for([5, 1, 1])).unwrap();
        let g = kernels[2].bind_group(&gpu, 0, &[&v]).unwrap();
        gpu.dispatch(&kernels[2], &[&g], kernels[2].workgroups_for([5, 1, 1])).unwrap();
        assert_eq!(gpu.read_buffer::<u32>(&v, 5).unwrap(), [14, 27, 40, 53, 26]);
        assert_eq!(kernels[1].binding_bytes, [vec![16], vec![4]]);
        assert_eq!(kernels[0].binding_bytes, [vec![16, 4]]);
    }

    /// A kernel that fails is this device's error, whichever thread met it first, and no
    /// thread waits for a launch that never comes: the largest kernel (the first this
    /// thread takes) failing, a smaller one failing, and a list of one.
    #[test]
    fn a_failing_kernel_is_reported() {
        let Some(gpu) = crate::gpu::gpu_for_tests("a_failing_kernel_is_reported") else { return };
        let good = "@group(0) @binding(0) var<storage, read_write> v: array<u32>;
             @compute @workgroup_size(64)
             fn main(@builtin(global_invocation_id) id: vec3<u32>) {
                 if (id.x < arrayLength(&v)) { v[id.x] = 2u * v[id.x]; }
             }";
        let long_bad = "@compute @workgroup_size(64) fn main() { let x: u32 = undefined_name_of_some_length; }";
        let bad = "fn main() { nonsense }";
        for sources in [vec![good, long_bad, good], vec![good, bad, good, good], vec![bad]] {
            let jobs: Vec<Job> = sources
                .iter()
                .map(|source| Job { label: "t".into(), source, entry: "main", loops: Loops::Bounded })
                .collect();
            let result =
                create_kernels(&gpu, &jobs, &|i: usize| crate::gpu::validate_wgsl("t", sources[i]).map(|v| v.module));
            assert!(matches!(result, Err(GpuError::Shader { .. })), "{:?}", result.map(|k| k.len()));
        }
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
