//! The GPU renderer: pack the scene, assemble the wavefront stages specialised to it, run
//! rounds of batches, and return the mean image.
//!
//! The kernels compute exactly what the CPU reference computes (same random streams, same
//! integrator structure, function by function in `shaders/`), in f32 and relative to the
//! camera; GPU-vs-CPU tests in `tests/gpu_render.rs` hold the two together. The stages,
//! queues and the determinism rule: [`super::wavefront`] and docs/DESIGN.md.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use super::features::{FeatureSet, RendererKind};
use super::kernels::assemble_stages;
use super::pack::{pack_within, PackError, PackedScene, TableLimit};
use super::parallel_jit;
use super::tables::{Table, TableForms, TableLimits, TablePlacement};
use super::wavefront::twin::{self, TwinStart};
use super::wavefront::{self, run_rounds, Plan, Stage, StageKernels, StopReason};
use super::{BindingKind, BoundResource, Gpu, GpuError, KernelCache, Loops, PassOptions};
use crate::image::HdrImage;
use crate::scene::Scene;

/// How to render on the GPU.
#[derive(Debug, Clone, Default)]
pub struct GpuRenderOptions {
    /// `--spp`: overrides the tracer's samples per pixel (a perfect square s² means s×s
    /// strata, any other count jitters over the whole pixel).
    pub spp: Option<u32>,
    /// Only camera samples `[begin, end)` of the layout (`None`: all), as
    /// the CPU renderer's `RenderOptions::samples`.
    pub samples: Option<crate::prepare::SampleRange>,
    /// Round sizing, batch size, time limit, cancellation and progress display.
    pub passes: PassOptions,
    /// The kernels to compile instead of the scene's own (`None`): they must cover the
    /// scene's features ([`FeatureSet::covers`]), e.g. [`FeatureSet::full_for`], else the
    /// render is refused. For benchmarks and tests of specialisation; the image is the same.
    pub features: Option<FeatureSet>,
    /// Time every stage launch on the device (`lumen render --profile`): the output's
    /// [`GpuRenderOutput::profile`]. Needs the adapter's timestamp queries; the image is
    /// the same.
    pub profile: bool,
    /// Which scene tables the kernels read from uniform buffers or textures (`lumen render
    /// --tables`; [`super::tables::TableForms::choose`]). The image is the same.
    pub tables: TablePlacement,
    /// Whether batches may be shared with a twin device on llvmpipe (`wavefront::twin`;
    /// `lumen render --one-device` is [`TwinUse::Never`]). The image is the same.
    pub twin: TwinUse,
    /// Shards per queue of the wavefront renderer (`None`: [`wavefront::queue_shards`] of
    /// the adapter; `wavefront::Control`). The image is the same.
    pub queue_shards: Option<u32>,
    /// Whether the path state and the struct tables are held in 64-bit words (`None`:
    /// [`wavefront::wide_words`] of the device; `Some(true)` where the device lacks 64-bit
    /// integers is ignored). The image is the same.
    pub wide_words: Option<bool>,
}

/// When a render on llvmpipe shares its batches with a twin device (`wavefront::twin`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum TwinUse {
    /// Where it pays: where the two devices split the cores
    /// ([`devices_split_cores`](super::wavefront::devices_split_cores), as `lumen` sets
    /// llvmpipe up), renders of two batches or more from their first round; elsewhere
    /// renders of a few batches or more, the twin started once a round's timing leaves
    /// `wavefront::twin::TWIN_MIN_SECONDS` or more to render.
    #[default]
    Auto,
    /// As `Auto`, and where the devices split the cores the twin is set up (and kept in the
    /// [`GpuRenderer`]) and shares the batches even for a render of one batch: a
    /// benchmark's short render, whose fixed costs must be those of the longer render it is
    /// subtracted from (`analysis::measure`), and animation frames (`lumen render
    /// --frames`), where the first frame's set-up serves every later frame.
    Warm,
    /// Never: this device renders every batch.
    Never,
    /// From the first batch of any render of two batches or more, the host waiting for the
    /// twin to be set up and this device leaving the first batch to it, so that the twin
    /// runs some batches however the threads are scheduled (for tests of the twin itself).
    Always,
}

impl GpuRenderOptions {
    /// Options whose rounds always hold `spp_per_pass` samples: the f32 film sums, and so the
    /// image, are then bitwise reproducible (adaptive rounds split samples by timing).
    pub fn fixed_passes(spp: Option<u32>, spp_per_pass: u32) -> Self {
        let passes = PassOptions {
            initial_spp_per_pass: spp_per_pass,
            max_spp_per_pass: spp_per_pass,
            target_pass_seconds: f64::MAX,
            ..PassOptions::default()
        };
        Self { spp, passes, ..Self::default() }
    }
}

/// What a GPU render produced.
#[derive(Debug, Clone)]
pub struct GpuRenderOutput {
    /// Per-pixel mean over `spp_done` camera samples.
    pub image: HdrImage,
    /// Camera samples per pixel taken (fewer than requested after a time limit or Ctrl-C).
    pub spp_done: u32,
    /// Camera samples per pixel asked for: the tracer's or `--spp`'s count, cut to
    /// [`GpuRenderOptions::samples`].
    pub spp_requested: u32,
    /// Wall time, including packing and kernel compilation.
    pub seconds: f64,
    /// Wall time of kernel creation within `seconds`: assembling, validating and creating
    /// the scene's new kernels and, on llvmpipe, their JIT compilation (issue 12's goal 3).
    pub kernel_seconds: f64,
    /// Kernels created for this render (the others came from the renderer's cache).
    pub kernels_compiled: usize,
    /// Path (or camera-sample) estimates that were NaN or infinite, written as 0.
    pub non_finite_samples: u64,
    /// Why the render ended: all samples taken, the time limit, or a cancel.
    pub stop: StopReason,
    /// Features the kernels were compiled for (the scene's, or the override), leaving out
    /// the choices made for the adapter: the table placement, which is [`Self::tables`],
    /// the queue shards, [`Self::queue_shards`], and the words, [`Self::wide_words`].
    pub features: FeatureSet,
    /// The tables the kernels read from uniform buffers and textures (chosen for the
    /// adapter).
    pub tables: TableForms,
    /// Shards per queue ([`GpuRenderOptions::queue_shards`]).
    pub queue_shards: u32,
    /// Whether the path state and the storage and uniform struct tables were held in 64-bit
    /// words ([`GpuRenderOptions::wide_words`]).
    pub wide_words: bool,
    /// Batches run (each a launch of every stage for a run of whole pixels).
    pub batches: u64,
    /// Path slots per batch.
    pub batch_paths: u32,
    /// Batches a twin device ran (llvmpipe: [`GpuRenderOptions::twin`]); the rest ran on
    /// the render's device.
    pub twin_batches: u64,
    /// Closest-hit and shadow rays traced (the same count as the CPU reference's
    /// `RenderStats::rays` for the same samples).
    pub rays: u64,
    /// Device time per stage and the busy fraction, when [`GpuRenderOptions::profile`]
    /// was asked for and the device has timestamp queries.
    pub profile: Option<super::wavefront::profile::StageProfile>,
}

pub(super) fn pack_error(e: super::pack::PackError) -> GpuError {
    match e {
        // The same error as the upload's, only sooner.
        PackError::TooLarge { table, needed, limit } => {
            GpuError::TooLarge { what: table.described(), needed, limit: limit.bytes, limit_name: limit.name }
        }
        e => GpuError::Scene(e),
    }
}

/// The most bytes a table that is a storage buffer may take on `gpu` ([`Gpu::storage_limit`]);
/// no limit where `placement` makes every table a texture in every stage (the upload checks
/// the textures' size).
fn table_limit(gpu: &Gpu, placement: TablePlacement) -> TableLimit {
    if placement == TablePlacement::Texture {
        return TableLimit::NONE;
    }
    let (bytes, name) = gpu.storage_limit();
    TableLimit { bytes, name }
}

/// Renders `scene` on `gpu`.
///
/// ```
/// use lumen::scene::*;
/// use lumen::color::Color;
/// use lumen::gpu::render::{render, GpuRenderOptions};
/// let Some(gpu) = lumen::gpu::gpu_for_tests("gpu_render_doc") else { return };
/// let mut b = SceneBuilder::new(5, 3);
/// let m = b.diffuse(Color::gray(0.5));
/// b.sphere(Transform::translation(glam::DVec3::new(3.0, 0.0, 0.0)), m)
///     .renderer(Renderer::OnOff { on: Color::WHITE, off: Color::BLACK });
/// let out = render(&gpu, &b.build().unwrap(), &GpuRenderOptions::default()).unwrap();
/// assert_eq!(out.spp_done, 1);
/// assert_eq!(out.image.get(2, 1).r, 1.0); // the sphere covers the centre
/// assert_eq!(out.image.get(0, 0).r, 0.0);
/// ```
pub fn render(gpu: &Gpu, scene: &Scene, opts: &GpuRenderOptions) -> Result<GpuRenderOutput, GpuError> {
    GpuRenderer::new().render(gpu, scene, opts)
}

/// Renders several scenes (animation frames, re-renders) compiling each distinct kernel
/// once: kernels are cached by their assembled source and entry point. It also remembers
/// which feature sets needed the CSG sweeps, so that later renders of them start with the
/// sweeps instead of finding out again.
#[derive(Debug, Default)]
pub struct GpuRenderer {
    kernels: KernelCache,
    swept: std::collections::HashSet<FeatureSet>,
    /// The twin device of the last render that started one, with its kernels, kept for the
    /// next renders (animation frames, benchmarks) on the same adapter.
    twin: Option<Box<TwinCache>>,
}

/// A twin device kept across renders ([`GpuRenderer`]) and the kernels created on it.
#[derive(Debug)]
struct TwinCache {
    gpu: Gpu,
    kernels: KernelCache,
}

impl GpuRenderer {
    /// A renderer with no kernels cached yet (the first render compiles its stages).
    pub fn new() -> Self {
        Self::default()
    }

    /// Kernels compiled so far.
    pub fn kernels_compiled(&self) -> usize {
        self.kernels.len()
    }

    /// Renders `scene` on `gpu`, like [`render`].
    pub fn render(&mut self, gpu: &Gpu, scene: &Scene, opts: &GpuRenderOptions) -> Result<GpuRenderOutput, GpuError> {
        let start = Instant::now();
        let packed = pack_within(scene, opts.spp, table_limit(gpu, opts.tables)).map_err(pack_error)?;
        self.render_from(gpu, scene, &packed, opts, start)
    }

    /// Renders `packed`, which [`pack`](super::pack::pack) made from `scene` with `opts.spp` (and a benchmark may
    /// have altered, e.g. its traversal through [`FeatureSet::object_list`]).
    pub fn render_packed(
        &mut self,
        gpu: &Gpu,
        scene: &Scene,
        packed: &PackedScene,
        opts: &GpuRenderOptions,
    ) -> Result<GpuRenderOutput, GpuError> {
        self.render_from(gpu, scene, packed, opts, Instant::now())
    }

    /// The compiled kernels of every stage for `features` on `gpu`, kept for later renders.
    pub fn stage_kernels(&mut self, gpu: &Gpu, features: &FeatureSet) -> Result<StageKernels, GpuError> {
        stage_kernels(&mut self.kernels, gpu, features)
    }

    fn render_from(
        &mut self,
        gpu: &Gpu,
        scene: &Scene,
        packed: &PackedScene,
        opts: &GpuRenderOptions,
        start: Instant,
    ) -> Result<GpuRenderOutput, GpuError> {
        let mut f = kernel_features(&packed.features, opts.features.map(|k| k.with_lists_of(&packed.features)))?;
        f.tables = TableForms::choose(
            packed,
            opts.tables,
            gpu.adapter_info.device_type,
            TableLimits::of(&gpu.limits, &gpu.adapter_info),
        );
        f.queue_shards = opts.queue_shards.unwrap_or_else(|| wavefront::queue_shards(&gpu.adapter_info));
        let can_widen = wavefront::wide_words(gpu);
        f.wide_words = can_widen && opts.wide_words.unwrap_or(can_widen);
        let job = RenderJob { scene, packed, opts, start };
        let mut attempts = Attempts::default();
        let walked = f;
        f.csg_sweeps |= self.swept.contains(&walked);
        loop {
            let begun = Instant::now();
            match self.render_with(gpu, &job, f, &mut attempts) {
                // A CSG query passed its walk budget: render again with the sweeps, which
                // classify every crossing as the walks do, so the image is the same (the
                // batches so far are dropped; kernels without sweeps compile faster, and
                // most renders never need them).
                Err(GpuError::CsgSweepsNeeded) if !f.csg_sweeps => {
                    f.csg_sweeps = true;
                    self.swept.insert(walked);
                    attempts.dropped += begun.elapsed();
                }
                result => return result,
            }
        }
    }

    /// [`Self::render_from`] with kernels for features `f`, adding the seconds spent creating
    /// them and their number to `attempts`.
    fn render_with(
        &mut self,
        gpu: &Gpu,
        job: &RenderJob<'_>,
        f: FeatureSet,
        attempts: &mut Attempts,
    ) -> Result<GpuRenderOutput, GpuError> {
        let RenderJob { scene, packed, opts, start } = *job;
        if f.renderer == RendererKind::PathTracer {
            wavefront::check_paths_per_sample(packed.settings.paths_per_sample)?;
        }
        let kernel_start = Instant::now();
        let kernels = self.stage_kernels(gpu, &f)?;
        attempts.kernel_seconds += kernel_start.elapsed().as_secs_f64();
        attempts.kernels += kernels.compiled;
        let (kernel_seconds, kernels_compiled) = (attempts.kernel_seconds, attempts.kernels);
        let buffers = SceneBuffers::upload(gpu, &kernels, packed)?;
        let s = &packed.settings;
        let path_tracer = f.renderer == RendererKind::PathTracer;
        let n = if path_tracer { s.paths_per_sample.max(1) } else { 1 };
        let shadow_rays = if wavefront::has_shadow_rays(&f) { s.point_light_count + s.nee } else { 0 };
        let capacity =
            wavefront::capacity(gpu, scene.width, scene.height, n, shadow_rays, &f, opts.passes.batch_paths)?;
        let rays_per_slot = wavefront::launch_rays_per_slot(&f, s.point_light_count, shadow_rays);
        // Never below one camera sample's paths, which a batch must hold (`capacity` made
        // sure it can): launches grow longer instead.
        let capacity = wavefront::bounded_by_launch_rays(capacity, wavefront::default_slots(gpu), rays_per_slot).max(n);
        let groups = buffers.groups(gpu, &kernels)?;
        let setup = wavefront::RunnerSetup {
            gpu,
            kernels: &kernels,
            groups1: &groups,
            features: f,
            shadow_rays,
            max_depth: s.max_depth,
            profile: opts.profile,
        };
        let mut runner = wavefront::Runner::new(&setup, capacity)?;
        let range = opts.samples.unwrap_or(crate::prepare::SampleRange::all(s.spp));
        let (first, end) = (range.begin.min(s.spp), range.end.min(s.spp));
        let plan = Plan {
            width: scene.width,
            height: scene.height,
            sample_begin: first,
            total_spp: end - first,
            paths_per_sample: n,
            capacity: runner.capacity(),
            shadow_rays,
            devices: 1,
        };
        let rounds = Instant::now();
        // A time limit covers the attempts dropped before this one.
        let mut passes = opts.passes.clone();
        passes.time_limit = passes.time_limit.map(|limit| limit.saturating_sub(attempts.dropped));
        let mut twin_counters = None;
        let twin_start = twin_start(gpu, opts, &plan);
        let plan = Plan { devices: if twin_start.is_some() { 2 } else { 1 }, ..plan };
        let acc = if let Some(twin_start) = twin_start {
            // The batches go to this device and a twin, each serving them on a thread of
            // its own (wavefront::twin); the twin sets itself up meanwhile.
            let (mut host, feed) = twin::shared();
            let feed = &feed;
            let twin_job = TwinJob {
                features: f,
                packed,
                shadow_rays,
                max_depth: s.max_depth,
                capacity: plan.capacity,
                cache: &mut self.twin,
            };
            let twin_first = opts.twin == TwinUse::Always;
            std::thread::scope(|scope| {
                let this = scope.spawn(|| {
                    if twin_first {
                        feed.wait_until_twin_serves();
                    }
                    feed.serve(&mut runner)
                });
                let twin = scope.spawn(move || twin_job.serve(gpu, feed));
                if twin_start == TwinStart::AtOnce {
                    host.start_twin();
                }
                if twin_first {
                    host.wait_for_twin();
                }
                let acc = run_rounds(&mut host, &plan, &passes);
                host.close();
                let served = this.join();
                twin_counters = twin.join().ok().flatten();
                served.map_err(|_| GpuError::Internal("a device serving the batches panicked".into()))?;
                acc
            })?
        } else {
            run_rounds(&mut runner, &plan, &passes)?
        };
        let profile = runner.profile(rounds.elapsed().as_secs_f64());
        let mut counters = runner.counters()?;
        let mut twin_batches = 0;
        if let Some((t, served)) = twin_counters {
            counters.rays += t.rays;
            counters.non_finite += t.non_finite;
            twin_batches = served;
        }
        Ok(GpuRenderOutput {
            image: acc.image,
            spp_done: acc.spp_done,
            spp_requested: end - first,
            seconds: start.elapsed().as_secs_f64(),
            kernel_seconds,
            kernels_compiled,
            non_finite_samples: counters.non_finite + acc.nonfinite,
            stop: acc.stop,
            features: FeatureSet { tables: TableForms::NONE, queue_shards: 0, wide_words: false, ..f },
            queue_shards: f.queue_shards.max(1),
            wide_words: f.wide_words,
            tables: f.tables,
            batches: acc.batches,
            batch_paths: runner.capacity(),
            twin_batches,
            rays: counters.rays,
            profile,
        })
    }
}

/// The compiled kernels on `gpu` of every stage for `features`, from `cache` or created
/// there (the new ones in parallel: pipeline creation dominates start-up on software
/// adapters; on llvmpipe also JIT-compiled before the first round, `parallel_jit`).
fn stage_kernels(cache: &mut KernelCache, gpu: &Gpu, features: &FeatureSet) -> Result<StageKernels, GpuError> {
    let mut kernels = BTreeMap::new();
    let mut missing = Vec::new();
    for (stage, assembled) in assemble_stages(features)? {
        let entry = stage.entry().1;
        match cache.get(&assembled.source, entry) {
            Some(k) => {
                kernels.insert(stage, k);
            }
            None => missing.push((stage, assembled)),
        }
    }
    // Pipelines created (and on llvmpipe compiled) in parallel, each WGSL parsed once
    // (gpu::parallel_jit).
    let jobs: Vec<parallel_jit::Job> = missing
        .iter()
        .map(|(stage, assembled)| parallel_jit::Job {
            label: format!("{} stage (assembled)", stage.label()),
            source: &assembled.source,
            entry: stage.entry().1,
            loops: Loops::Unbounded,
        })
        .collect();
    let built = parallel_jit::create_kernels(gpu, &jobs, &|i: usize| missing[i].1.validate().map(|v| v.module))?;
    let compiled = built.len();
    for ((stage, assembled), kernel) in missing.iter().zip(built) {
        kernels.insert(*stage, cache.insert(&assembled.source, stage.entry().1, kernel));
    }
    // The stages that launch another stage's kernel.
    for stage in Stage::for_scene(features) {
        let owner = stage.kernel_stage(features);
        if owner != stage {
            let k =
                kernels.get(&owner).cloned().ok_or_else(|| GpuError::Internal(format!("no kernel for {owner:?}")))?;
            kernels.insert(stage, k);
        }
    }
    Ok(StageKernels { kernels, compiled })
}

/// Least batches a render takes for a twin device that starts only once enough time is
/// left ([`TwinStart::AfterTiming`]) to be ready to share them.
const TWIN_MIN_BATCHES: u64 = 4;

/// Whether and when a render shares its batches with a twin device (`wavefront::twin`):
/// only on llvmpipe through Vulkan (where a submission runs on the submitting thread, so the
/// driver's workers wait between launches), with two cores or more, unprofiled (a profile
/// times one device's launches), unless [`TwinUse::Never`]. Where the two devices split
/// the cores (`wavefront::devices_split_cores`) the twin starts with the first round of any
/// render of two batches or more (of any render with [`TwinUse::Warm`]); elsewhere only
/// renders of [`TWIN_MIN_BATCHES`] batches or more may start it, once enough time is left
/// (two batches and at once with [`TwinUse::Always`]).
fn twin_start(gpu: &Gpu, opts: &GpuRenderOptions, plan: &Plan) -> Option<TwinStart> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    twin_start_on(&gpu.adapter_info, opts, plan, cores, twin::this_process_splits_cores())
}

/// [`twin_start`] on an adapter described by `info`, with `cores` cores, the devices
/// splitting them or not (`split`).
fn twin_start_on(
    info: &wgpu::AdapterInfo,
    opts: &GpuRenderOptions,
    plan: &Plan,
    cores: usize,
    split: bool,
) -> Option<TwinStart> {
    let paths = u64::from(plan.width)
        * u64::from(plan.height)
        * u64::from(plan.total_spp)
        * u64::from(plan.paths_per_sample.max(1));
    let (least, start) = match opts.twin {
        TwinUse::Never => return None,
        TwinUse::Warm if split => (0, TwinStart::AtOnce),
        TwinUse::Auto if split => (2, TwinStart::AtOnce),
        TwinUse::Auto | TwinUse::Warm => (TWIN_MIN_BATCHES, TwinStart::AfterTiming),
        TwinUse::Always => (2, TwinStart::AtOnce),
    };
    let shares =
        !opts.profile && cores >= 2 && parallel_jit::lazy_jit(info) && paths >= least * u64::from(plan.capacity);
    shares.then_some(start)
}

/// What a twin device needs to render a scene's batches as this device does.
struct TwinJob<'a> {
    features: FeatureSet,
    packed: &'a PackedScene,
    shadow_rays: u32,
    max_depth: u32,
    capacity: u32,
    /// The renderer's twin from an earlier render, if any; the one set up here stays there.
    cache: &'a mut Option<Box<TwinCache>>,
}

impl TwinJob<'_> {
    /// Once the host starts it, opens a twin of `gpu` (or takes the renderer's), creates the
    /// scene's kernels there as this device did (llvmpipe finds their code in Mesa's shader
    /// cache, where this device's compilation put it), uploads the scene and serves `feed` with as many path
    /// slots as this device has. Its counters and the batches it ran; `None` when it was
    /// not started or any of that failed, which leaves every batch to this device.
    fn serve(mut self, gpu: &Gpu, feed: &twin::Feed) -> Option<(wavefront::Counters, u64)> {
        if !feed.started() {
            return None;
        }
        // The host may be waiting for this answer (TwinUse::Always), and with it this device:
        // give it even on a panic, once the twin is about to take batches.
        let set_up = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| self.set_up(gpu))).ok().flatten();
        let (Some(scene), Some(twin)) = (set_up, self.cache.as_ref()) else {
            feed.ready(false);
            return None;
        };
        let setup = wavefront::RunnerSetup {
            gpu: &twin.gpu,
            kernels: &scene.kernels,
            groups1: &scene.groups,
            features: self.features,
            shadow_rays: self.shadow_rays,
            max_depth: self.max_depth,
            profile: false,
        };
        let capacity = self.capacity;
        let runner =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| wavefront::Runner::new(&setup, capacity)))
                .ok()
                .and_then(Result::ok)
                .filter(|r| r.capacity() == capacity);
        feed.ready(runner.is_some());
        let mut runner = runner?;
        let served = feed.serve_as_twin(&mut runner);
        Some((runner.counters().ok()?, served))
    }

    /// The scene's kernels, buffers and bind groups on the twin, which is opened here
    /// unless the renderer kept one of the same adapter.
    fn set_up(&mut self, gpu: &Gpu) -> Option<TwinScene> {
        if self.cache.as_ref().is_some_and(|t| t.gpu.adapter_info != gpu.adapter_info) {
            *self.cache = None;
        }
        if self.cache.is_none() {
            *self.cache = Some(Box::new(TwinCache { gpu: gpu.twin()?, kernels: KernelCache::new() }));
        }
        let TwinCache { gpu: twin, kernels: cache } = self.cache.as_deref_mut()?;
        let kernels = stage_kernels(cache, twin, &self.features).ok()?;
        let buffers = SceneBuffers::upload(twin, &kernels, self.packed).ok()?;
        let groups = buffers.groups(twin, &kernels).ok()?;
        Some(TwinScene { kernels, _buffers: buffers, groups })
    }
}

/// A scene set up on the twin device ([`TwinJob::set_up`]).
struct TwinScene {
    kernels: StageKernels,
    /// Kept for as long as the bind groups use them.
    _buffers: SceneBuffers,
    groups: BTreeMap<Stage, wgpu::BindGroup>,
}

/// A render's attempts so far: kernels created (seconds, count) and the time of attempts
/// dropped to start again with other kernels.
#[derive(Default)]
struct Attempts {
    kernel_seconds: f64,
    kernels: usize,
    dropped: Duration,
}

/// What one render draws: the scene, its packed form, the options and when it started.
#[derive(Clone, Copy)]
struct RenderJob<'a> {
    scene: &'a Scene,
    packed: &'a PackedScene,
    opts: &'a GpuRenderOptions,
    start: Instant,
}

/// The scene's features, or the override when it covers them (a clear error otherwise:
/// a kernel lacking a feature would silently render the scene wrong).
fn kernel_features(scene: &FeatureSet, kernel: Option<FeatureSet>) -> Result<FeatureSet, GpuError> {
    let Some(kernel) = kernel else { return Ok(*scene) };
    let missing = kernel.missing_for(scene);
    if !missing.is_empty() {
        return Err(GpuError::Validation(format!(
            "the kernel feature override does not cover this scene; it lacks: {}",
            missing.join(", ")
        )));
    }
    Ok(kernel)
}

/// The uploaded scene: a buffer for each group-1 binding some stage declares (buffers no
/// stage reads, such as texels in an OnOff render, are never uploaded). A full-featured
/// kernel declares buffers the scene leaves empty: those get one zeroed element, since a
/// binding must hold at least one element of its array type (it is never read: counts are 0).
struct SceneBuffers {
    /// By binding and kind: a table may be a texture in some stages and a storage buffer
    /// in others (`TableForms::for_stage`).
    buffers: BTreeMap<(u32, BindingKind), BoundResource>,
}

impl SceneBuffers {
    fn upload(gpu: &Gpu, kernels: &StageKernels, p: &PackedScene) -> Result<Self, GpuError> {
        let mut buffers = BTreeMap::new();
        for kernel in kernels.kernels.values() {
            for &(binding, kind) in kernel.bindings.get(1).map(Vec::as_slice).unwrap_or(&[]) {
                if buffers.contains_key(&(binding, kind)) {
                    continue;
                }
                if let Some(table) = Table::from_binding(binding) {
                    // Each named for its errors ("the floats table (...) needs N bytes but ...").
                    let resource = match kind {
                        BindingKind::Uniform => {
                            let contents = super::tables::uniform_contents(table, p).ok_or_else(|| {
                                GpuError::Internal(format!(
                                    "the {table:?} table does not fit the uniform buffer it was given"
                                ))
                            })?;
                            BoundResource::Buffer(gpu.uniform_buffer_bytes(table.feature(), &contents)?)
                        }
                        BindingKind::TextureU32 => {
                            let row = super::tables::TEXTURE_ROW_TEXELS as u32;
                            BoundResource::Texture(gpu.u32_texture(&table.described(), table.bytes(p), row)?)
                        }
                        BindingKind::Storage { .. } => BoundResource::Buffer(
                            gpu.storage_buffer(&table.described(), &super::tables::storage_contents(table, p))?,
                        ),
                    };
                    buffers.insert((binding, kind), resource);
                    continue;
                }
                let buffer = match binding {
                    0 => gpu.uniform_buffer("settings", &p.settings)?,
                    1 => gpu.uniform_buffer("camera", &p.camera)?,
                    9 => gpu.uniform_buffer("environment", &p.environment)?,
                    b => {
                        return Err(GpuError::Validation(format!(
                            "a stage kernel declares unknown @group(1) @binding({b})"
                        )))
                    }
                };
                buffers.insert((binding, kind), BoundResource::Buffer(buffer));
            }
        }
        Ok(Self { buffers })
    }

    /// Each stage's group-1 bind group (none for stages that read no scene buffer).
    fn groups(&self, gpu: &Gpu, kernels: &StageKernels) -> Result<BTreeMap<Stage, wgpu::BindGroup>, GpuError> {
        let mut groups = BTreeMap::new();
        for (&stage, kernel) in &kernels.kernels {
            let Some(declared) = kernel.bindings.get(1) else { continue };
            let resources = declared.iter().map(|&(b, kind)| self.buffers[&(b, kind)].binding()).collect();
            groups.insert(stage, kernel.bind_group_of(gpu, 1, resources)?);
        }
        Ok(groups)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The twin's rule: on llvmpipe through Vulkan only, never profiled or with one core;
    /// where the devices split the cores from the first round of two batches (of one with
    /// `Warm`), elsewhere from four batches once timing allows; `Always` at once.
    #[test]
    fn when_a_render_starts_a_twin() {
        let llvmpipe = wgpu::AdapterInfo {
            name: "llvmpipe (LLVM 15.0.6, 128 bits)".into(),
            ..wgpu::AdapterInfo::new(wgpu::DeviceType::Cpu, wgpu::Backend::Vulkan)
        };
        let hardware = wgpu::AdapterInfo {
            name: "NVIDIA H200".into(),
            ..wgpu::AdapterInfo::new(wgpu::DeviceType::DiscreteGpu, wgpu::Backend::Vulkan)
        };
        let capacity = 1000;
        // `batches` batches' worth of paths.
        let plan = |batches: u32| Plan {
            width: 10,
            height: 10,
            sample_begin: 0,
            total_spp: batches * 10,
            paths_per_sample: 1,
            capacity,
            shadow_rays: 1,
            devices: 1,
        };
        let with = |twin: TwinUse| GpuRenderOptions { twin, ..GpuRenderOptions::default() };
        let (auto, warm, always, never) =
            (with(TwinUse::Auto), with(TwinUse::Warm), with(TwinUse::Always), with(TwinUse::Never));
        use TwinStart::{AfterTiming, AtOnce};
        let on = |opts: &GpuRenderOptions, batches: u32, split: bool| {
            twin_start_on(&llvmpipe, opts, &plan(batches), 2, split)
        };
        // Split cores: from the first round.
        assert_eq!(on(&auto, 1, true), None);
        assert_eq!(on(&auto, 2, true), Some(AtOnce));
        assert_eq!(on(&warm, 1, true), Some(AtOnce));
        // Shared cores: long renders only, once timing allows.
        assert_eq!(on(&auto, 3, false), None);
        assert_eq!(on(&auto, 4, false), Some(AfterTiming));
        assert_eq!(on(&warm, 1, false), None);
        assert_eq!(on(&warm, 4, false), Some(AfterTiming));
        for split in [false, true] {
            assert_eq!(on(&always, 2, split), Some(AtOnce));
            assert_eq!(on(&never, 100, split), None);
            let profiled = GpuRenderOptions { profile: true, ..auto.clone() };
            assert_eq!(on(&profiled, 100, split), None);
            assert_eq!(twin_start_on(&llvmpipe, &auto, &plan(100), 1, split), None);
            assert_eq!(twin_start_on(&hardware, &warm, &plan(100), 16, split), None);
        }
    }
}
