//! The wavefront path tracer (docs/DESIGN.md "Wavefront renderer").
//!
//! Paths are state in storage buffers, one *slot* per path of a batch; each stage of a path
//! vertex is its own kernel, launched over a queue of slots with indirect dispatches sized
//! on the device, so a kernel holds only its own code and runs only for the paths that
//! need it (the closest-hit query never pays for CSG, glass or NEE code it does not use,
//! which a SIMD software GPU would otherwise execute masked). Per bounce (a ray that hits
//! nothing ends its path in the stage that found so, intersect or csg, with the
//! environment's radiance):
//!
//! ```text
//! intersect ─┬─ (CSG trees met) ─ csg ─┐
//!            └─────────────────────────┴─ shade[diffuse | specular | dielectric] ─ shadow ─┬─ advance
//!                                     (shadow rays that met CSG trees) shadow_csg_args ─ csg ─┘
//! ```
//!
//! Determinism: a path's state is written only by the stage that holds its slot, so no
//! two invocations touch it at once and queue order cannot change any value; the film
//! stage then sums each pixel's paths in a fixed order. Images are bitwise reproducible
//! for fixed samples per round, whatever the batch size or the order queues fill in.

mod contract;
pub mod profile;
mod schedule;
mod stages;
pub(crate) mod twin;

pub use contract::{accessor_modules, queue, wavefront_module, wide_word_modules, BatchUniform, Control, StateBuffer};
pub use schedule::{
    ctrlc_flag, Accumulated, PassOptions, StopReason, MAX_PATHS_PER_PIXEL_PER_ROUND, MAX_SPP_PER_ROUND,
};
pub(crate) use schedule::{run_rounds, Plan};

pub use stages::{csg_queue, has_shadow_rays, Stage};
pub use twin::{devices_split_cores, THREADS_ENV};

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

pub use contract::{csg_pool_entries, CSG_POOL_ENTRY_BYTES, CSG_PRIVATE_POOL_MAX};
use contract::{launch_groups, path_field, word_field};
use schedule::BatchRunner;

use crate::gpu::compute::ComputeKernel;
use crate::gpu::device::{Gpu, GpuError};
use crate::gpu::features::{FeatureSet, RendererKind};

/// The compiled kernel of every stage a scene needs.
#[derive(Debug, Clone)]
pub struct StageKernels {
    /// The kernel each stage of the scene launches, shared with the renderer's kernel cache;
    /// the shading stages whose kinds share a kernel ([`Stage::kernel_kinds`]) map to the
    /// same one.
    pub kernels: BTreeMap<Stage, Arc<ComputeKernel>>,
    /// How many of them were new to the renderer (assembled, validated, created and, on
    /// llvmpipe, JIT-compiled for this render) rather than found in its cache.
    pub compiled: usize,
}

impl StageKernels {
    fn get(&self, stage: Stage) -> Result<&ComputeKernel, GpuError> {
        self.kernels
            .get(&stage)
            .map(|k| k.as_ref())
            .ok_or_else(|| GpuError::Internal(format!("no kernel for the {} stage", stage.label())))
    }
}

/// Path slots per batch: `requested` if non-zero, else a default for the device (a software
/// adapter runs a few SIMD lanes per core, and beyond 2¹⁷ slots gains nothing; a hardware GPU wants
/// millions of paths in flight), never more than the image's paths per round need, and
/// within the device's buffer limits. A batch holds at least one camera sample's paths,
/// which the film sums together: where the limits leave fewer slots (a slot's shadow rays
/// grow with the point lights, its CSG spans with the largest tree), the error says which
/// state, how large and which limit.
pub fn capacity(
    gpu: &Gpu,
    width: u32,
    height: u32,
    paths_per_sample: u32,
    shadow_rays: u32,
    features: &FeatureSet,
    requested: u32,
) -> Result<u32, GpuError> {
    let n = paths_per_sample.max(1);
    check_paths_per_sample(n)?;
    let default = default_slots(gpu);
    let wanted = if requested > 0 { requested } else { default };
    let image = u64::from(width) * u64::from(height) * u64::from(n) * u64::from(MAX_SPP_PER_ROUND);
    let mut slots = u64::from(wanted).min(image.max(1)).max(u64::from(n));
    // The largest per-slot array must fit one binding and one buffer.
    let (limit, limit_name) = gpu.storage_limit();
    let per_slot = |b| state_bytes(b, shadow_rays, features);
    let used = scene_buffers(features);
    let widest = used.iter().copied().max_by_key(|&b| per_slot(b)).unwrap_or(StateBuffer::Paths);
    slots = slots.min(limit / per_slot(widest).max(1)).max(1);
    let mut bound = (widest, limit, format!("this adapter's {limit_name} limit"));
    // CSG leaf spans (per slot, sized by the largest tree) within their budget: a large
    // tree makes batches smaller, never the kernels larger.
    if used.contains(&StateBuffer::CsgPool) {
        let budget = csg_pool_budget(gpu);
        let by_pool = budget / per_slot(StateBuffer::CsgPool);
        if by_pool < slots {
            slots = by_pool.max(1);
            bound = (StateBuffer::CsgPool, budget, "the CSG span pool's budget on this adapter".to_string());
        }
    }
    let slots = slots.min(u64::from(Control::new(features.queue_shards).max_slots()));
    if slots < u64::from(n) {
        let (buffer, limit, limit_name) = bound;
        let what = match buffer {
            StateBuffer::Shadow | StateBuffer::DeferredRefs => {
                let lights = shadow_rays.saturating_sub(features.nee as u32);
                format!(
                    "a vertex's {} shadow ray{} (one per point light{})",
                    shadow_rays,
                    if shadow_rays == 1 { "" } else { "s" },
                    if lights < shadow_rays { ", and one for the area lights and the environment" } else { "" }
                )
            }
            StateBuffer::CsgPool => "the working spans of the scene's largest CSG tree".to_string(),
            other => format!("its {} state", other.declaration_name()),
        };
        return Err(GpuError::SampleExceedsBatch {
            paths: n,
            reason: format!(
                "each path needs {} bytes for {what}, and {limit_name} ({limit} bytes) holds {slots} such paths",
                per_slot(buffer)
            ),
        });
    }
    Ok(slots as u32)
}

/// Refuses more paths per camera sample than the film sums per pixel in a batch
/// ([`MAX_PATHS_PER_PIXEL_PER_ROUND`]): a property of the scene alone, so a render checks it
/// before it creates kernels or uploads the scene.
pub fn check_paths_per_sample(n: u32) -> Result<(), GpuError> {
    if n <= MAX_PATHS_PER_PIXEL_PER_ROUND {
        return Ok(());
    }
    Err(GpuError::SampleExceedsBatch {
        paths: n,
        reason: format!(
            "the GPU's film sums at most {MAX_PATHS_PER_PIXEL_PER_ROUND} paths per pixel in a batch; fewer paths per \
             camera sample (Renderer.PathTracer's .n) and more camera samples (Tracer's .samples_per_side, or \
             --spp) estimate the same image"
        ),
    })
}

/// The path slots of a batch on `gpu` unless asked otherwise.
pub fn default_slots(gpu: &Gpu) -> u32 {
    match gpu.adapter_info.device_type {
        // 2¹⁷ measured best on lavapipe (2026-12-02, 160 px, 64 spp, against 2¹⁶: skybox.sl
        // 20 % faster, csg.sl 11 %, mirrors.sl and glass.sl 4-5 %; 2¹⁸ and more no better).
        wgpu::DeviceType::Cpu => 1 << 17,
        _ => 1 << 21,
    }
}

/// Rays one launch may trace per default slot: a batch whose paths each trace more rays in
/// one launch ([`launch_rays_per_slot`]) gets fewer slots, so that no launch outgrows the
/// usual ones by more than this factor.
pub const LAUNCH_RAYS_PER_SLOT: u32 = 8;

/// Fewest slots the launch bound leaves a batch (a few workgroups).
pub const MIN_BOUNDED_SLOTS: u32 = 256;

/// The rays one path of a batch may trace in one launch: the point-light renderer traces
/// each light's shadow ray in the invocation of its camera ray, and the path tracer's
/// shadow stage traces every shadow ray a vertex queued (`shadow_rays`) in one launch.
pub fn launch_rays_per_slot(features: &FeatureSet, point_lights: u32, shadow_rays: u32) -> u32 {
    match features.renderer {
        RendererKind::PointLight => point_lights.saturating_add(1),
        _ => shadow_rays.max(1),
    }
}

/// `slots` bounded so that one launch traces about as many rays as a launch of the
/// device's default batch does with [`LAUNCH_RAYS_PER_SLOT`] rays per path: a scene of
/// 20,000 point lights traced 2.6 billion shadow rays in one launch of lavapipe's 2¹⁷ slots
/// (8 s without a chance to stop; far beyond an OS watchdog's 2 s on a GPU that drives a
/// display). Slots do not change the image (each sample's place and order are fixed), only
/// how the work is cut. Ordinary scenes, up to eight rays per path, keep their batches.
///
/// ```
/// use lumen::gpu::wavefront::bounded_by_launch_rays;
/// assert_eq!(bounded_by_launch_rays(1 << 17, 1 << 17, 3), 1 << 17);
/// assert_eq!(bounded_by_launch_rays(1 << 17, 1 << 17, 20_001), 256);
/// assert_eq!(bounded_by_launch_rays(1 << 21, 1 << 21, 20_001), 838);
/// assert_eq!(bounded_by_launch_rays(100, 1 << 17, 20_001), 100, "never more than asked");
/// ```
pub fn bounded_by_launch_rays(slots: u32, default_slots: u32, rays_per_slot: u32) -> u32 {
    let budget = u64::from(default_slots) * u64::from(LAUNCH_RAYS_PER_SLOT);
    let bound = (budget / u64::from(rays_per_slot.max(1))).max(u64::from(MIN_BOUNDED_SLOTS));
    slots.min(u32::try_from(bound).unwrap_or(u32::MAX))
}

/// Queue shards for a render on the adapter `info` ([`Control`], `FeatureSet::queue_shards`):
/// on llvmpipe, one per worker thread of the driver, which takes `LP_NUM_THREADS` threads
/// if set, else one per core (Mesa caps them at 32; 0 runs launches on the submitting
/// thread alone); 1 on every other adapter, where a queue's pushes do not come from a few
/// threads each taking a run of the launch.
///
/// ```
/// let mut info = wgpu::AdapterInfo::new(wgpu::DeviceType::DiscreteGpu, wgpu::Backend::Vulkan);
/// info.name = "NVIDIA H100".into();
/// assert_eq!(lumen::gpu::wavefront::queue_shards(&info), 1);
/// info.name = "llvmpipe (LLVM 15.0.6, 128 bits)".into();
/// assert!((1..=32).contains(&lumen::gpu::wavefront::queue_shards(&info)));
/// ```
pub fn queue_shards(info: &wgpu::AdapterInfo) -> u32 {
    if !crate::gpu::is_llvmpipe(info) {
        return 1;
    }
    this_process_llvmpipe().0
}

/// The device features a render's path state in 64-bit words needs
/// (`FeatureSet::wide_words`), requested where they pay: on llvmpipe, which accesses a
/// storage buffer at a lane-dependent index one word of one lane at a time, each with a
/// bounds check and a branch, so 64-bit words halve those accesses (DESIGN.md "Wide
/// words"). A hardware GPU loads a 16-byte element per lane in one instruction either way.
///
/// ```
/// let mut info = wgpu::AdapterInfo::new(wgpu::DeviceType::DiscreteGpu, wgpu::Backend::Vulkan);
/// info.name = "NVIDIA H100".into();
/// assert!(lumen::gpu::wavefront::wide_words_features(&info).is_empty());
/// info.name = "llvmpipe (LLVM 15.0.6, 128 bits)".into();
/// assert_eq!(lumen::gpu::wavefront::wide_words_features(&info), wgpu::Features::SHADER_INT64);
/// ```
pub fn wide_words_features(info: &wgpu::AdapterInfo) -> wgpu::Features {
    if crate::gpu::is_llvmpipe(info) {
        wgpu::Features::SHADER_INT64
    } else {
        wgpu::Features::empty()
    }
}

/// Whether a render on `gpu` holds its path state in 64-bit words: where
/// [`wide_words_features`] asks for 64-bit integers and the device has them.
pub fn wide_words(gpu: &crate::gpu::Gpu) -> bool {
    let wanted = wide_words_features(&gpu.adapter_info);
    !wanted.is_empty() && gpu.device.features().contains(wanted)
}

/// llvmpipe's worker threads per device in this process ([`llvmpipe_threads`] of
/// [`THREADS_ENV`]) and the process's cores: what queue shards and the twin's start
/// (`twin::this_process_splits_cores`) depend on.
pub(crate) fn this_process_llvmpipe() -> (u32, usize) {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    (llvmpipe_threads(std::env::var(THREADS_ENV).ok().as_deref(), cores), cores)
}

/// llvmpipe's worker threads for the `LP_NUM_THREADS` setting and `cores` (as Mesa's
/// `lp_screen` counts them), at least 1: a shard per thread, and what two devices must fit
/// in the cores to split them (`twin::devices_split_cores`).
pub(crate) fn llvmpipe_threads(setting: Option<&str>, cores: usize) -> u32 {
    let threads = match setting.map(str::trim).and_then(|s| s.parse::<u32>().ok()) {
        Some(n) => n,
        None => u32::try_from(cores).unwrap_or(u32::MAX),
    };
    threads.clamp(1, MAX_QUEUE_SHARDS)
}

/// Most shards a queue is split into: as many as llvmpipe's worker threads can be (Mesa caps
/// them at 32), the most [`queue_shards`] gives; `lumen render --queue-shards` takes no more.
pub const MAX_QUEUE_SHARDS: u32 = 32;

/// Where launch-argument buffer `b` is in `StateBuffer::ARGS` (and `Runner::args`).
fn args_index(b: StateBuffer) -> usize {
    let i = StateBuffer::ARGS.iter().position(|a| *a == b);
    debug_assert!(i.is_some(), "{b:?} holds no launch arguments");
    i.unwrap_or(0)
}

/// Device counters read at the end of a render.
#[derive(Debug, Clone, Copy, Default)]
pub struct Counters {
    /// Rays traced: the closest-hit queries of every bounce plus the shadow rays.
    pub rays: u64,
    /// Path estimates and camera-sample means the film stage found NaN or infinite and
    /// replaced by 0.
    pub non_finite: u64,
}

/// The state buffers some stage of a scene with features `f` binds (the others are
/// allocated as a token 16 bytes: their bindings exist, nothing reads them).
fn scene_buffers(f: &FeatureSet) -> std::collections::BTreeSet<StateBuffer> {
    Stage::for_scene(f).into_iter().flat_map(|s| s.buffers(f)).collect()
}

/// Bytes of one element of each state buffer, per slot (0: not sized by the slots).
fn state_bytes(buffer: StateBuffer, shadow_rays: u32, features: &FeatureSet) -> u64 {
    match buffer {
        StateBuffer::Batch => 0,
        StateBuffer::Control => 0,
        StateBuffer::Queues => 4 * u64::from(queue::COUNT),
        StateBuffer::Paths => 16 * u64::from(path_field::COUNT),
        StateBuffer::Words => 16 * u64::from(word_field::COUNT),
        StateBuffer::Shadow => 48 * u64::from(shadow_rays.max(1)),
        // A record of the trees one query deferred (a count, then the references): the
        // closest-hit query's, then each shadow ray's.
        StateBuffer::DeferredRefs => 4 * (crate::prepare::CSG_DEFER_MAX as u64 + 1) * (1 + u64::from(shadow_rays)),
        // The compensated sum: value and error (wf_film.wgsl).
        StateBuffer::Film => 32,
        StateBuffer::ArgsRays | StateBuffer::ArgsHits | StateBuffer::ArgsCsg | StateBuffer::ShadeQueue => 0,
        StateBuffer::CsgPool => contract::csg_pool_entries(features) * contract::CSG_POOL_ENTRY_BYTES,
    }
}

/// Device memory the CSG span pool may take (it bounds the slots of a batch): a
/// software adapter's caches favour a small pool, a hardware GPU has memory to spare.
fn csg_pool_budget(gpu: &Gpu) -> u64 {
    match gpu.adapter_info.device_type {
        wgpu::DeviceType::Cpu => 256 << 20,
        _ => 2 << 30,
    }
}

/// The device state of one render and the launches of its batches.
pub(crate) struct Runner<'a> {
    gpu: &'a Gpu,
    kernels: &'a StageKernels,
    /// Group 0 of each stage; the film stage has one per film buffer.
    groups0: BTreeMap<(Stage, usize), wgpu::BindGroup>,
    groups1: &'a BTreeMap<Stage, wgpu::BindGroup>,
    batch: wgpu::Buffer,
    control: wgpu::Buffer,
    /// Launch arguments, in `StateBuffer::ARGS` order (contract::launch_args).
    args: [wgpu::Buffer; 3],
    films: [wgpu::Buffer; 2],
    staging: [wgpu::Buffer; 2],
    probe: wgpu::Buffer,
    capacity: u32,
    /// The control buffer's layout (its queue shards: `FeatureSet::queue_shards`).
    layout: Control,
    path_tracer: bool,
    csg: bool,
    shade: Vec<Stage>,
    shadow: bool,
    /// Shadow rays that meet CSG trees go to the CSG stage (a second launch per bounce).
    shadow_csg: bool,
    max_depth: u32,
    /// Timestamps around every launch (`GpuRenderOptions::profile`, where the device can).
    profiler: Option<profile::Profiler>,
    /// The path fields, whose radiance region each batch clears before its camera stage.
    paths: wgpu::Buffer,
    /// Host time in `submit` and in `collect`'s read-back (for the profile).
    host_submit: Duration,
    host_wait: Duration,
    /// Whether a CSG query may give up after its walk budget (kernels without the sweeps,
    /// a tree with a sweep table): each batch then copies `Control::csg_over` after its
    /// film in the staging buffer, and `collect` checks it.
    watch_csg: bool,
}

/// Bytes after a batch's film in its staging buffer that bring back `Control::csg_over`
/// (one film texel's worth, so the read-back stays whole texels) where `Runner::watch_csg`.
const FLAG_BYTES: u64 = 16;

/// A batch in flight: its film's staging buffer and submission.
pub(crate) struct Pending {
    slot: usize,
    pixels: u32,
    submission: wgpu::SubmissionIndex,
}

/// What a [`Runner`] renders with: the device, the scene's stage kernels and their scene
/// bind groups, and the run-time sizes of the path tracer.
pub(crate) struct RunnerSetup<'a> {
    pub gpu: &'a Gpu,
    pub kernels: &'a StageKernels,
    pub groups1: &'a BTreeMap<Stage, wgpu::BindGroup>,
    pub features: FeatureSet,
    /// Shadow rays a vertex may queue ([`BatchUniform::shadow_rays`]).
    pub shadow_rays: u32,
    pub max_depth: u32,
    /// Time every launch ([`profile`]), if the device has the timestamp features.
    pub profile: bool,
}

impl<'a> Runner<'a> {
    /// Allocates the state for `capacity` slots (halving it while the device refuses the
    /// memory, down to 1,024 slots).
    pub fn new(setup: &RunnerSetup<'a>, capacity: u32) -> Result<Self, GpuError> {
        let mut capacity = capacity.max(1);
        loop {
            match Self::allocate(setup, capacity) {
                Ok(mut r) => {
                    if setup.profile {
                        r.profiler = profile::Profiler::new(setup.gpu)?;
                    }
                    return Ok(r);
                }
                Err(GpuError::TooLarge { .. } | GpuError::OutOfMemory(_)) if capacity > 1024 => capacity /= 2,
                Err(e) => return Err(e),
            }
        }
    }

    fn allocate(setup: &RunnerSetup<'a>, capacity: u32) -> Result<Self, GpuError> {
        let RunnerSetup { gpu, kernels, groups1, shadow_rays, max_depth, .. } = *setup;
        let features = &setup.features;
        let cap = u64::from(capacity);
        let storage = |label: &str, buffer: StateBuffer| {
            gpu.storage_buffer_zeroed(label, cap * state_bytes(buffer, shadow_rays, features))
        };
        let used = scene_buffers(features);
        let tiny = |label: &str, b: StateBuffer| -> Result<wgpu::Buffer, GpuError> {
            if used.contains(&b) {
                storage(label, b)
            } else {
                gpu.storage_buffer_zeroed(label, 16)
            }
        };
        let layout = Control::new(features.queue_shards);
        // A region of `shard_slots` entries per queue and shard (Control::shard_slots): the
        // slots, rounded up to whole blocks per shard.
        let queues = if used.contains(&StateBuffer::Queues) {
            let regions = u64::from(queue::COUNT) * u64::from(layout.shards());
            gpu.storage_buffer_zeroed("queues", 4 * regions * u64::from(layout.shard_slots(capacity)))?
        } else {
            gpu.storage_buffer_zeroed("queues", 16)?
        };
        let paths = storage("path state", StateBuffer::Paths)?;
        let words = tiny("path words", StateBuffer::Words)?;
        let shadow = tiny("shadow rays", StateBuffer::Shadow)?;
        let deferred = tiny("deferred CSG trees", StateBuffer::DeferredRefs)?;
        let csg_pool = tiny("CSG span pool", StateBuffer::CsgPool)?;
        let films = [storage("film 0", StateBuffer::Film)?, storage("film 1", StateBuffer::Film)?];
        let staging_buffer = |label: &str, bytes: u64| gpu.readback_buffer(label, bytes);
        let film_bytes = cap * state_bytes(StateBuffer::Film, shadow_rays, features);
        // Where kernels may give up on a CSG query, its flag comes back after the film.
        let watch_csg = stages::csg_sweepable(features) && !features.csg_sweeps;
        let staging_bytes = film_bytes + if watch_csg { FLAG_BYTES } else { 0 };
        let staging =
            [staging_buffer("film readback 0", staging_bytes)?, staging_buffer("film readback 1", staging_bytes)?];
        let probe = staging_buffer("control readback", u64::from(layout.words()) * 4)?;
        let batch = gpu.uniform_buffer("batch", &<BatchUniform as bytemuck::Zeroable>::zeroed())?;
        let control = gpu.scoped(|| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("control"),
                size: u64::from(layout.words()).next_multiple_of(4) * 4,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        })?;
        let args_buffer = |label: &str| {
            gpu.scoped(|| {
                gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size: 12 * u64::from(queue::COUNT),
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            })
        };
        // In `StateBuffer::ARGS` order.
        let args = [
            args_buffer("launch arguments: rays and shadow rays")?,
            args_buffer("launch arguments: hits")?,
            args_buffer("launch arguments: CSG")?,
        ];
        // Each shading stage's queue, in the uniform its launches bind.
        let shade_queues: BTreeMap<Stage, wgpu::Buffer> = kernels
            .kernels
            .keys()
            .filter_map(|&s| s.shade_queue().map(|q| (s, q)))
            .map(|(s, q)| Ok((s, gpu.uniform_buffer("shading queue", &[q, 0, 0, 0])?)))
            .collect::<Result<_, GpuError>>()?;
        let buffer_of = |b: StateBuffer, film: usize, stage: Stage| -> Result<&wgpu::Buffer, GpuError> {
            Ok(match b {
                StateBuffer::Batch => &batch,
                StateBuffer::Control => &control,
                StateBuffer::Queues => &queues,
                StateBuffer::Paths => &paths,
                StateBuffer::Words => &words,
                StateBuffer::Shadow => &shadow,
                StateBuffer::DeferredRefs => &deferred,
                StateBuffer::Film => &films[film],
                StateBuffer::ArgsRays | StateBuffer::ArgsHits | StateBuffer::ArgsCsg => &args[args_index(b)],
                StateBuffer::CsgPool => &csg_pool,
                StateBuffer::ShadeQueue => shade_queues
                    .get(&stage)
                    .ok_or_else(|| GpuError::Internal(format!("no shading queue for {stage:?}")))?,
            })
        };
        let mut groups0 = BTreeMap::new();
        for (&stage, kernel) in &kernels.kernels {
            for film in 0..if stage == Stage::Film { 2 } else { 1 } {
                let refs: Vec<&wgpu::Buffer> =
                    stage.buffers(features).into_iter().map(|b| buffer_of(b, film, stage)).collect::<Result<_, _>>()?;
                groups0.insert((stage, film), kernel.bind_group(gpu, 0, &refs)?);
            }
        }
        let shade = kernels.kernels.keys().copied().filter(|s| matches!(s, Stage::Shade(_))).collect();
        Ok(Self {
            gpu,
            kernels,
            groups0,
            groups1,
            batch,
            control,
            args,
            films,
            staging,
            probe,
            capacity,
            layout,
            path_tracer: features.renderer == RendererKind::PathTracer,
            csg: kernels.kernels.contains_key(&Stage::Csg),
            shade,
            shadow: kernels.kernels.contains_key(&Stage::Shadow),
            shadow_csg: kernels.kernels.contains_key(&Stage::ShadowCsgArgs),
            max_depth,
            profiler: None,
            paths: paths.clone(),
            host_submit: Duration::ZERO,
            host_wait: Duration::ZERO,
            watch_csg,
        })
    }

    pub fn capacity(&self) -> u32 {
        self.capacity
    }

    /// The stage times so far, with the wall time of the rounds (`None` unless profiling).
    pub fn profile(&self, wall_seconds: f64) -> Option<profile::StageProfile> {
        let (submit, wait) = (self.host_submit.as_secs_f64(), self.host_wait.as_secs_f64());
        self.profiler.as_ref().map(|p| p.finish(wall_seconds, submit, wait))
    }

    /// Records `launch` of `stage`, timed when profiling.
    fn launch(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        stage: Stage,
        launch: impl FnOnce(&mut wgpu::ComputePass<'_>) -> Result<(), GpuError>,
    ) -> Result<(), GpuError> {
        match &self.profiler {
            Some(p) => p.timed(pass, stage.label(), launch),
            None => launch(pass),
        }
    }

    /// Binds `stage`'s pipeline and groups in `pass`.
    fn bind(&self, pass: &mut wgpu::ComputePass<'_>, stage: Stage, film: usize) -> Result<(), GpuError> {
        pass.set_pipeline(&self.kernels.get(stage)?.pipeline);
        let g0 =
            self.groups0.get(&(stage, film)).ok_or_else(|| GpuError::Internal(format!("no group 0 for {stage:?}")))?;
        pass.set_bind_group(0, g0, &[]);
        if let Some(g1) = self.groups1.get(&stage) {
            pass.set_bind_group(1, g1, &[]);
        }
        Ok(())
    }

    /// A launch of `stage` of `groups` workgroups, sized on the host (camera, first hits,
    /// film).
    fn direct(&self, pass: &mut wgpu::ComputePass<'_>, stage: Stage, film: usize, groups: u32) -> Result<(), GpuError> {
        self.launch(pass, stage, |pass| {
            self.bind(pass, stage, film)?;
            pass.dispatch_workgroups(groups, 1, 1);
            Ok(())
        })
    }

    /// A launch of `stage` over queue `q`, sized on the device (by the pushes to `q`).
    fn indirect(&self, pass: &mut wgpu::ComputePass<'_>, stage: Stage, q: u32) -> Result<(), GpuError> {
        let args = &self.args[args_index(contract::launch_args(q))];
        self.launch(pass, stage, |pass| {
            self.bind(pass, stage, 0)?;
            pass.dispatch_workgroups_indirect(args, 12 * u64::from(q));
            Ok(())
        })
    }

    fn control_kernel(&self, pass: &mut wgpu::ComputePass<'_>, stage: Stage) -> Result<(), GpuError> {
        self.launch(pass, stage, |pass| {
            self.bind(pass, stage, 0)?;
            pass.dispatch_workgroups(1, 1, 1);
            Ok(())
        })
    }

    /// Records one bounce of every path in flight. Each launch is sized by the pushes to its
    /// queue (wf_push), so only `advance` (and, for shadow rays' CSG trees, one more) runs
    /// between stages.
    fn bounce(&self, pass: &mut wgpu::ComputePass<'_>, bounce: u32) -> Result<(), GpuError> {
        self.indirect(pass, Stage::Intersect, queue::RAY + (bounce & 1))?;
        if self.csg {
            self.indirect(pass, Stage::Csg, queue::CSG)?;
        }
        for &stage in &self.shade {
            if let Stage::Shade(kind) = stage {
                self.indirect(pass, stage, queue::shade(kind))?;
            }
        }
        if self.shadow {
            self.indirect(pass, Stage::Shadow, queue::SHADOW)?;
            if self.shadow_csg {
                // The shadow rays' CSG trees, through the one kernel that holds CSG code.
                self.control_kernel(pass, Stage::ShadowCsgArgs)?;
                self.indirect(pass, Stage::Csg, queue::SHADOW_CSG)?;
            }
        }
        self.control_kernel(pass, Stage::Advance)
    }

    /// Submits `record` as one command buffer.
    fn submit_commands(
        &self,
        record: impl FnOnce(&mut wgpu::CommandEncoder) -> Result<(), GpuError>,
    ) -> Result<wgpu::SubmissionIndex, GpuError> {
        let gpu = self.gpu;
        let mut result = Ok(());
        let index = gpu.scoped(|| {
            let mut encoder =
                gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("batch") });
            result = record(&mut encoder);
            gpu.queue.submit([encoder.finish()])
        })?;
        result.map(|_| index)
    }

    /// Rays still to intersect at `bounce`, over every shard (a read-back: used only to stop
    /// deep renders early).
    fn rays_left(&self, bounce: u32) -> Result<u32, GpuError> {
        let q = queue::RAY + (bounce & 1);
        let (first, last) = (self.layout.count(q, 0), self.layout.count(q, self.layout.shards() - 1));
        let bytes = 4 * u64::from(last - first + 1);
        self.submit_commands(|e| {
            e.copy_buffer_to_buffer(&self.control, 4 * u64::from(first), &self.probe, 0, bytes);
            Ok(())
        })?;
        let words = self.read(&self.probe, bytes)?;
        Ok((0..self.layout.shards()).map(|s| words[(self.layout.count(q, s) - first) as usize]).sum())
    }

    fn read(&self, buffer: &wgpu::Buffer, bytes: u64) -> Result<Vec<u32>, GpuError> {
        map_read(self.gpu, buffer, bytes, None)
    }

    /// The ray and NaN counters (after every batch has been collected).
    pub fn counters(&self) -> Result<Counters, GpuError> {
        self.submit_commands(|e| {
            e.copy_buffer_to_buffer(&self.control, 0, &self.probe, 0, u64::from(self.layout.words()) * 4);
            Ok(())
        })?;
        let w = self.read(&self.probe, u64::from(self.layout.words()) * 4)?;
        let word64 = |i: u32| u64::from(w[i as usize]) | (u64::from(w[i as usize + 1]) << 32);
        let shadow: u64 = (0..self.layout.shards()).map(|s| word64(self.layout.shadow_rays(s))).sum();
        Ok(Counters { rays: word64(self.layout.rays()) + shadow, non_finite: u64::from(w[self.layout.nan() as usize]) })
    }
}

/// The first `bytes` of a mappable `buffer`, once the submission `after` (or all work) is done.
fn map_read<T: bytemuck::Pod>(
    gpu: &Gpu,
    buffer: &wgpu::Buffer,
    bytes: u64,
    after: Option<wgpu::SubmissionIndex>,
) -> Result<Vec<T>, GpuError> {
    let (tx, rx) = std::sync::mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, 0..bytes, move |r| {
        let _ = tx.send(r);
    });
    gpu.device
        .poll(wgpu::PollType::Wait { submission_index: after, timeout: None })
        .map_err(|e| GpuError::DeviceLost(e.to_string()))?;
    gpu.check()?;
    rx.recv()
        .map_err(|_| GpuError::Readback("map callback never ran".into()))?
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    let out = {
        let view = buffer.get_mapped_range(0..bytes).map_err(|e| GpuError::Readback(e.to_string()))?;
        bytemuck::pod_collect_to_vec(&view)
    };
    buffer.unmap();
    Ok(out)
}

impl BatchRunner for Runner<'_> {
    type Pending = Pending;

    fn submit(&mut self, batch: &BatchUniform, slot: usize) -> Result<Pending, GpuError> {
        let t0 = Instant::now();
        let pending = self.record_batch(batch, slot);
        self.host_submit += t0.elapsed();
        pending
    }

    fn collect(&mut self, pending: Pending) -> Result<Vec<[f64; 3]>, GpuError> {
        let bytes = u64::from(pending.pixels) * 32 + if self.watch_csg { FLAG_BYTES } else { 0 };
        let t0 = Instant::now();
        let mut film: Vec<[f32; 4]> =
            map_read(self.gpu, &self.staging[pending.slot], bytes, Some(pending.submission.clone()))?;
        self.host_wait += t0.elapsed();
        if let Some(p) = &self.profiler {
            p.collect(self.gpu, pending.slot, pending.submission)?;
        }
        if self.watch_csg && film.pop().is_some_and(|flag| flag[0].to_bits() != 0) {
            return Err(GpuError::CsgSweepsNeeded);
        }
        // Each pixel's value and rounding error, summed exactly in f64.
        Ok(film.chunks_exact(2).map(|v| std::array::from_fn(|c| f64::from(v[0][c]) + f64::from(v[1][c]))).collect())
    }

    fn drain(&mut self) -> Result<(), GpuError> {
        self.gpu.wait_idle()
    }
}

impl Runner<'_> {
    /// Records and submits every launch of `batch` ([`BatchRunner::submit`]).
    fn record_batch(&self, batch: &BatchUniform, slot: usize) -> Result<Pending, GpuError> {
        let gpu = self.gpu;
        if let Some(p) = &self.profiler {
            p.begin_batch(slot);
        }
        let batch = &BatchUniform { shard_slots: self.layout.shard_slots(self.capacity), ..*batch };
        gpu.queue.write_buffer(&self.batch, 0, bytemuck::bytes_of(batch));
        let last = if self.path_tracer {
            // Bounce 0, every slot queued for the closest-hit stage (implicitly: bounce 0's
            // queue is the slots in order, and only its length's sum over the shards is read,
            // by `advance`), every other queue empty; the counters stay.
            let mut words = vec![0u32; self.layout.batch_words() as usize];
            words[self.layout.count(queue::RAY, 0) as usize] = batch.path_count;
            gpu.queue.write_buffer(&self.control, 0, bytemuck::cast_slice(&words));
            // Every launch empty but bounce 0's closest-hit one.
            for (buffer, kind) in self.args.iter().zip(StateBuffer::ARGS) {
                let mut args = [[0u32, 1, 1]; queue::COUNT as usize];
                if kind == contract::launch_args(queue::RAY) {
                    args[queue::RAY as usize][0] = self.layout.slot_groups(batch.path_count);
                }
                gpu.queue.write_buffer(buffer, 0, bytemuck::cast_slice(&args));
            }
            self.submit_commands(|e| {
                // Every path starts with no radiance: a copy-engine clear (a memset on
                // lavapipe) rather than a store per invocation in the camera stage.
                let radiance = u64::from(path_field::RADIANCE) * u64::from(self.capacity) * 16;
                e.clear_buffer(&self.paths, radiance, Some(u64::from(batch.path_count) * 16));
                let mut pass = e
                    .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("camera"), timestamp_writes: None });
                self.direct(&mut pass, Stage::Camera, 0, self.layout.slot_groups(batch.path_count))
            })?;
            // One submission per bounce keeps every submission short (OS GPU watchdogs).
            // Deep renders check every 8 bounces whether any path is left.
            for b in 0..self.max_depth {
                self.submit_commands(|e| {
                    let mut pass = e.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("bounce"),
                        timestamp_writes: None,
                    });
                    self.bounce(&mut pass, b)
                })?;
                if self.max_depth > 16 && b % 8 == 7 && self.rays_left(b + 1)? == 0 {
                    break;
                }
            }
            Some(self.max_depth)
        } else {
            None
        };
        let pixels = batch.pixel_count;
        let submission = self.submit_commands(|e| {
            {
                let mut pass =
                    e.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("film"), timestamp_writes: None });
                match last {
                    // The last bounce (emission and escapes only), then the film.
                    Some(b) => self.bounce(&mut pass, b)?,
                    None => self.direct(&mut pass, Stage::FirstHit, 0, self.layout.slot_groups(batch.path_count))?,
                }
                self.direct(&mut pass, Stage::Film, slot, launch_groups(pixels))?;
            }
            let film_bytes = u64::from(pixels) * 32;
            e.copy_buffer_to_buffer(&self.films[slot], 0, &self.staging[slot], 0, film_bytes);
            if self.watch_csg {
                let flag = 4 * u64::from(self.layout.csg_over());
                e.copy_buffer_to_buffer(&self.control, flag, &self.staging[slot], film_bytes, 4);
            }
            if let Some(p) = &self.profiler {
                p.resolve(e);
            }
            Ok(())
        })?;
        Ok(Pending { slot, pixels, submission })
    }
}

#[cfg(test)]
mod tests {
    use super::llvmpipe_threads;

    #[test]
    fn a_shard_per_llvmpipe_thread() {
        assert_eq!(llvmpipe_threads(None, 2), 2);
        assert_eq!(llvmpipe_threads(None, 128), 32);
        assert_eq!(llvmpipe_threads(Some("6"), 2), 6);
        assert_eq!(llvmpipe_threads(Some(" 3 "), 64), 3);
        // No worker threads: the submitting thread runs every workgroup, one shard.
        assert_eq!(llvmpipe_threads(Some("0"), 8), 1);
        // Unreadable settings are Mesa's default.
        assert_eq!(llvmpipe_threads(Some("lots"), 4), 4);
    }
}
