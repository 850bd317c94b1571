//! `lumen render SCENE.sl`: loads a script, renders it and writes the image(s).
//!
//! Every argument is checked before rendering starts, so a bad argument never costs a
//! render and never leaves an output file behind.

use std::path::{Path, PathBuf};
use std::process::Command as Process;
use std::time::Instant;

use anyhow::{anyhow, bail, Context as _};
use clap::Args;

use super::gpu_args::GpuArgs;
pub use super::script_args::{resize, MAX_SPP};
use super::script_args::{SceneOverrides, ScriptArgs, SppArgs};
use crate::cpu::{self, paths_per_sample, Limits, Progress, RenderOptions};
pub use crate::device::DeviceChoice;
use crate::device::{open_device, OpenDevice};
use crate::gpu::render::{GpuRenderOptions, GpuRenderer, TwinUse};
use crate::gpu::{ctrlc_flag, Gpu, GpuError};
use crate::image::render_metadata::fingerprint;
use crate::image::{HdrImage, ImageFormat, RenderMetadata, ToneMap};
use crate::prepare::SampleRange;
use crate::scene::{Renderer, Scene};
use crate::stop::StopReason;
/// Most frames `--frames` accepts.
pub const MAX_FRAMES: u32 = 100_000;
/// Frame rate of the video assembled from `--frames`.
pub const VIDEO_FPS: u32 = 24;

/// Arguments of `lumen render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    /// The SceneLang script to render.
    pub scene: PathBuf,
    /// Output image; repeat for several. HDR extensions (.pfm .exr .hdr) get linear
    /// radiance, LDR ones (.png .jpg) the tone-mapped image. Default: SCENE's name + .png.
    #[arg(short = 'o', long = "output")]
    pub outputs: Vec<PathBuf>,
    /// Where to render.
    #[arg(long, value_enum, default_value_t = DeviceChoice::Auto)]
    pub device: DeviceChoice,
    /// `--adapter`, `--time-limit`, and the GPU's `--batch-paths`, `--tables`, `--one-device` and
    /// `--queue-shards`.
    #[command(flatten)]
    pub gpu: GpuArgs,
    /// `--width`, `--height` and `--seed`: changes to the loaded scene.
    #[command(flatten)]
    pub overrides: SceneOverrides,
    /// `--spp`: samples per pixel instead of the tracer's own.
    #[command(flatten)]
    pub spp: SppArgs,
    /// `--time` and `--vars` of the script (`--frames` sets TIME per frame instead of `--time`).
    #[command(flatten)]
    pub script: ScriptArgs,
    /// Path tracer: no next-event estimation (light only found by BSDF sampling, as in
    /// Raytracer.jl); the script's `.nee 0` does the same.
    #[arg(long)]
    pub no_nee: bool,
    /// Tone mapping: Raytracer.jl's Reinhard key (implies the Reinhard curve).
    #[arg(long, value_parser = super::tonemap::positive, allow_hyphen_values = true)]
    pub alpha: Option<f32>,
    /// Tone mapping: Reinhard's gamma (implies the Reinhard curve).
    #[arg(long, value_parser = super::tonemap::positive, allow_hyphen_values = true)]
    pub gamma: Option<f32>,
    /// Render TIME from START to END (inclusive) in COUNT frames, into numbered files
    /// (out.png → out_0001.png ...), plus an mp4 when ffmpeg is on PATH. START and END may be
    /// negative (`--frames -1:1:5`).
    #[arg(long, value_name = "START:END:COUNT", allow_hyphen_values = true, value_parser = Frames::parse)]
    pub frames: Option<Frames>,
    /// Render only camera samples [A, B) of the image's sample layout (the `--spp` count, or
    /// the tracer's): a shard that `lumen merge` combines exactly with the others. Write it
    /// as .exr, which records the range.
    #[arg(long, value_name = "A:B", conflicts_with = "shard", value_parser = |s: &str| SampleRange::parse(s))]
    pub samples: Option<SampleRange>,
    /// Render part I (0-based) of N: of the samples per pixel split into N contiguous
    /// ranges, or with --frames, of the frames. For job arrays: SLURM_ARRAY_TASK_ID,
    /// JOB_COMPLETION_INDEX.
    #[arg(long, value_name = "I/N", value_parser = |s: &str| SampleRange::parse_shard(s))]
    pub shard: Option<(u32, u32)>,
    /// On the GPU, time every stage launch with timestamp queries and print, on stderr, each
    /// stage's device time, the device's busy fraction, and the host's time recording launches
    /// and waiting for read-backs; and, for any device, the process's time loading the scene,
    /// starting the device, rendering and writing (the image is the same)
    #[arg(long)]
    pub profile: bool,
}

/// Which part of the work this render does (`--samples`, `--shard`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Part {
    All,
    Samples(SampleRange),
    Shard { index: u32, count: u32 },
}

impl Part {
    fn of(args: &RenderArgs) -> Self {
        match (args.samples, args.shard) {
            (Some(r), _) => Part::Samples(r),
            (None, Some((index, count))) => Part::Shard { index, count },
            (None, None) => Part::All,
        }
    }

    /// The camera samples to take of a layout of `total` per pixel.
    fn samples(self, total: u32) -> anyhow::Result<SampleRange> {
        match self {
            Part::All => Ok(SampleRange::all(total)),
            Part::Samples(r) => Ok(r.within(total).context("--samples")?),
            Part::Shard { index, count } => Ok(SampleRange::shard(index, count, total).context("--shard")?),
        }
    }
}

/// An animation's times.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frames {
    /// The script's TIME in the first frame.
    pub start: f64,
    /// The script's TIME in the last frame (it may be less than `start`).
    pub end: f64,
    /// Number of frames, 1 to [`MAX_FRAMES`]; with one, only `start` is rendered.
    pub count: u32,
}

impl Frames {
    /// Parses `START:END:COUNT` (`--frames`'s value parser: the error is the reason).
    pub fn parse(s: &str) -> Result<Self, String> {
        let parts: Vec<&str> = s.split(':').collect();
        let [a, b, c] = parts[..] else {
            return Err(format!("expected START:END:COUNT, got {s:?}"));
        };
        let num = |x: &str, what: &str| super::number_args::finite(x).map_err(|e| format!("{what}: {e}"));
        let count: u32 = c.trim().parse().map_err(|_| format!("COUNT {c:?} is not a positive integer"))?;
        if count == 0 || count > MAX_FRAMES {
            return Err(format!("COUNT must be 1..={MAX_FRAMES}, got {count}"));
        }
        Ok(Self { start: num(a, "START")?, end: num(b, "END")?, count })
    }

    /// TIME of frame k (0-based): evenly spaced, both ends included.
    pub fn time(&self, k: u32) -> f64 {
        if self.count == 1 {
            self.start
        } else {
            self.start + (self.end - self.start) * f64::from(k) / f64::from(self.count - 1)
        }
    }
}

/// `out.png`, frame k of n → `out_0001.png` (1-based, at least four digits).
pub fn frame_path(path: &Path, k: u32, count: u32) -> PathBuf {
    let digits = count.to_string().len().max(4);
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let ext = path.extension().map(|e| format!(".{}", e.to_string_lossy())).unwrap_or_default();
    path.with_file_name(format!("{stem}_{:0digits$}{ext}", k + 1))
}

/// The tone mapping for LDR outputs: Reinhard when `--alpha` or `--gamma` is given (with
/// Raytracer.jl's values for the other), else the image module's default.
pub fn tone_map(alpha: Option<f32>, gamma: Option<f32>) -> anyhow::Result<ToneMap> {
    let tm = if alpha.is_some() || gamma.is_some() {
        let base = ToneMap::raytracer_jl();
        ToneMap { alpha: alpha.unwrap_or(base.alpha), gamma: gamma.unwrap_or(base.gamma), ..base }
    } else {
        ToneMap::default()
    };
    tm.validate().context("bad tone mapping")?;
    Ok(tm)
}

/// Opens the device `--device` asks for ([`open_device`]).
fn open(args: &RenderArgs) -> anyhow::Result<OpenDevice> {
    let ignored = args.gpu.gpu_only_given();
    if args.device == DeviceChoice::Cpu && !ignored.is_empty() {
        let (verb, them) = if ignored.len() == 1 { ("applies", "it") } else { ("apply", "them") };
        crate::diag!("note: {} only {verb} to GPU renders; --device cpu ignores {them}", ignored.join(", "));
    }
    open_device(args.device, &args.gpu.adapter.choice()).map_err(|e| match args.device {
        DeviceChoice::Gpu => anyhow::Error::from(e).context("--device gpu"),
        _ => e.into(),
    })
}

/// One rendered image and how it went.
struct Rendered {
    image: HdrImage,
    /// Samples per pixel taken (from the range's start) and where.
    spp: u32,
    device: String,
    seconds: f64,
    non_finite_samples: u64,
    /// The render was cut short (time limit, Ctrl-C): later frames are not rendered.
    stopped_early: bool,
}

/// Renders on the open device. With `--device auto`, a scene the GPU refuses (too large
/// for the adapter's limits, say), or a render the GPU fails (device lost, out of memory),
/// is rendered on the CPU instead, from the start, with a warning. A render stopped before
/// its first complete sample per pixel (Ctrl-C, a signal) is an error on either device, and
/// not a reason to try the other: the user asked it to stop.
fn render_on(device: &OpenDevice, args: &RenderArgs, scene: &Scene, range: SampleRange) -> anyhow::Result<Rendered> {
    let rendered = render_with_fallback(device, args, scene, range)?;
    if rendered.spp == 0 {
        bail!("stopped before any sample was complete; nothing to write");
    }
    Ok(rendered)
}

fn render_with_fallback(
    device: &OpenDevice,
    args: &RenderArgs,
    scene: &Scene,
    range: SampleRange,
) -> anyhow::Result<Rendered> {
    let OpenDevice::Gpu { gpu, renderer } = device else {
        return render_on_cpu(scene, args, range);
    };
    match render_on_gpu(gpu, &mut renderer.borrow_mut(), args, scene, range) {
        Err(e) if args.device == DeviceChoice::Auto => {
            match e {
                GpuError::DeviceLost(_) | GpuError::OutOfMemory(_) | GpuError::Readback(_) => {
                    crate::diag!("warning: the GPU failed during the render: {e}")
                }
                _ => crate::diag!("warning: the GPU cannot render this scene: {e}"),
            }
            crate::diag!("warning: rendering on the CPU reference renderer instead, from the first sample");
            render_on_cpu(scene, args, range)
        }
        Err(e @ (GpuError::TooLarge { .. } | GpuError::SampleExceedsBatch { .. } | GpuError::Scene(_))) => {
            Err(anyhow!("GPU render failed: {e}; `--device cpu` (or `auto`) renders the scene on the CPU"))
        }
        other => other.map_err(|e| anyhow!("GPU render failed: {e}")),
    }
}

fn render_on_cpu(scene: &Scene, args: &RenderArgs, range: SampleRange) -> anyhow::Result<Rendered> {
    let limits = Limits { time_limit: args.gpu.time_limit, cancel: Some(ctrlc_flag()), ..Limits::default() };
    let opts = RenderOptions { spp: args.spp.spp, samples: Some(range) };
    let out = cpu::render_limited(scene, &opts, &limits, Progress::Bar)?;
    let s = &out.stats;
    crate::diag!(
        "{}×{} {} on the CPU ({} threads): {} of {} samples per pixel, {} samples, {} rays in {:.2} s ({:.2} Mrays/s)",
        scene.width,
        scene.height,
        scene.renderer.name(),
        rayon::current_num_threads(),
        s.spp,
        s.spp_requested,
        s.samples,
        s.rays,
        s.seconds,
        s.rays as f64 / s.seconds.max(1e-9) / 1e6
    );
    let stopped_early = report_stop(s.stop, s.spp);
    if args.profile {
        crate::diag!("note: --profile times GPU stages; this render ran on the CPU");
    }
    Ok(Rendered {
        image: out.image,
        spp: s.spp as u32,
        device: format!("cpu ({} threads)", rayon::current_num_threads()),
        seconds: s.seconds,
        non_finite_samples: s.non_finite_samples,
        stopped_early,
    })
}

/// What the render's kernels cost: "kernels from cache", or how many were created and in
/// how long (on llvmpipe their JIT compilation included).
fn kernel_note(compiled: usize, seconds: f64) -> String {
    match compiled {
        0 => "kernels from cache".into(),
        1 => format!("1 kernel created in {seconds:.2} s"),
        n => format!("{n} kernels created in {seconds:.2} s"),
    }
}

/// How many batches a twin device ran (`lumen render --one-device`), if any.
fn twin_note(twin: u64, batches: u64) -> String {
    match twin {
        0 => String::new(),
        n => format!("; {n} of {batches} batches on a twin device"),
    }
}

/// "1 sample per pixel", "16 samples per pixel".
fn samples_per_pixel(n: u64) -> String {
    format!("{n} sample{} per pixel", if n == 1 { "" } else { "s" })
}

/// Says why a render stopped early (the same words for both renderers); returns whether it did.
fn report_stop(stop: StopReason, spp_done: u64) -> bool {
    match stop {
        StopReason::Completed => false,
        // `render_on`'s error says it: nothing was kept.
        _ if spp_done == 0 => true,
        StopReason::TimeLimit => {
            crate::diag!("note: stopped at the time limit with {}", samples_per_pixel(spp_done));
            true
        }
        StopReason::Interrupted => {
            crate::diag!("note: interrupted; keeping the {} of the completed rounds", samples_per_pixel(spp_done));
            true
        }
    }
}

fn render_on_gpu(
    gpu: &Gpu,
    renderer: &mut GpuRenderer,
    args: &RenderArgs,
    scene: &Scene,
    range: SampleRange,
) -> Result<Rendered, GpuError> {
    let opts = GpuRenderOptions {
        spp: args.spp.spp,
        samples: Some(range),
        passes: args.gpu.pass_options(),
        profile: args.profile,
        tables: args.gpu.tables,
        queue_shards: args.gpu.queue_shards,
        // Animation frames set the twin up in the first frame even when a frame is one
        // batch, so that every later frame shares its batches.
        twin: match (args.gpu.one_device, args.frames.is_some()) {
            (true, _) => TwinUse::Never,
            (false, true) => TwinUse::Warm,
            (false, false) => TwinUse::Auto,
        },
        ..GpuRenderOptions::default()
    };
    let out = renderer.render(gpu, scene, &opts)?;
    match &out.profile {
        Some(p) => crate::diag!(
            "GPU stages ({}, {} queue shard{}):\n{}",
            gpu.adapter_info.name,
            out.queue_shards,
            if out.queue_shards == 1 { "" } else { "s" },
            p.table()
        ),
        None if args.profile => {
            crate::diag!(
                "note: {} has no timestamp queries inside passes; --profile timed nothing",
                gpu.adapter_info.name
            )
        }
        None => {}
    }
    let samples = u64::from(scene.width) * u64::from(scene.height) * u64::from(out.spp_done) * paths_per_sample(scene);
    crate::diag!(
        "{}×{} {} on the GPU ({}): {} of {} samples per pixel, {} samples in {:.2} s ({:.2} Msamples/s; {}{})",
        scene.width,
        scene.height,
        scene.renderer.name(),
        gpu.adapter_info.name,
        out.spp_done,
        out.spp_requested,
        samples,
        out.seconds,
        samples as f64 / out.seconds.max(1e-9) / 1e6,
        kernel_note(out.kernels_compiled, out.kernel_seconds),
        twin_note(out.twin_batches, out.batches)
    );
    let stopped_early = report_stop(out.stop, u64::from(out.spp_done));
    Ok(Rendered {
        image: out.image,
        spp: out.spp_done,
        device: format!("gpu ({})", gpu.adapter_info.name),
        seconds: out.seconds,
        non_finite_samples: out.non_finite_samples,
        stopped_early,
    })
}

/// Checks everything that can be checked before rendering.
fn validate(args: &RenderArgs, outputs: &[PathBuf]) -> anyhow::Result<(ToneMap, Option<Frames>, Part)> {
    // One file named twice (`-o a.exr -o ./a.exr`) would be written twice, the second
    // write replacing the first.
    let mut seen = std::collections::HashSet::new();
    for o in outputs {
        if !seen.insert(std::path::absolute(o).unwrap_or_else(|_| o.clone())) {
            bail!("output {} is named twice", o.display());
        }
    }
    for o in outputs {
        ImageFormat::from_path(o).with_context(|| format!("output {}", o.display()))?;
        crate::image::check_destination(o).with_context(|| format!("cannot write {}", o.display()))?;
    }
    let part = Part::of(args);
    let exr = outputs.iter().any(|o| ImageFormat::from_path(o).is_ok_and(|f| f == ImageFormat::Exr));
    if matches!(part, Part::Samples(_) | Part::Shard { .. }) && args.frames.is_none() && !exr {
        crate::diag!("note: no .exr output: only EXR files record the sample range that `lumen merge` needs");
    }
    if matches!(part, Part::Samples(_)) && args.frames.is_some() {
        bail!("--samples renders part of one image; with --frames, split the frames with --shard I/N");
    }
    args.spp.checked(MAX_SPP)?;
    let frames = args.frames;
    if let (Some(f), Part::Shard { count, .. }) = (frames, part) {
        if count > f.count {
            bail!("--shard: {count} shards of {} frames leave some empty (use at most {} shards)", f.count, f.count);
        }
    }
    Ok((tone_map(args.alpha, args.gamma)?, frames, part))
}

/// Samples per pixel of the scene's layout: `--spp`, else the tracer's.
fn layout_spp(args: &RenderArgs, scene: &Scene) -> u32 {
    u32::try_from(crate::prepare::PixelSamples::new(&scene.tracer, args.spp.spp).count()).unwrap_or(u32::MAX)
}

/// Loads the scene at `time` and applies the command-line overrides.
fn load(args: &RenderArgs, time: f64) -> anyhow::Result<Scene> {
    load_with_output(args, time, &mut std::io::stdout().lock())
}

/// [`load`] with the script's DUMP output written to `out`.
fn load_with_output(args: &RenderArgs, time: f64, out: &mut dyn std::io::Write) -> anyhow::Result<Scene> {
    let mut scene = args.script.load_at_with_output(&args.scene, time, out)?;
    args.overrides.apply(&mut scene)?;
    if args.no_nee {
        if let Renderer::PathTracer(p) = &mut scene.renderer {
            p.nee = false;
        }
    }
    let spp = args.spp.spp.map_or(u64::from(scene.tracer.samples_per_side).pow(2).max(1), u64::from);
    if spp * paths_per_sample(&scene) > u64::from(u32::MAX) {
        bail!("{spp} samples per pixel × {} paths per sample is too many (at most 2³² − 1)", paths_per_sample(&scene));
    }
    Ok(scene)
}

/// Renders one image and writes it to every output; returns whether it stopped early.
/// `loaded` is the scene at `time` when it has been loaded already (big meshes are read once).
fn render_one(
    device: &OpenDevice,
    args: &RenderArgs,
    time: f64,
    outputs: &[PathBuf],
    tm: &ToneMap,
    part: Part,
    loaded: Option<Scene>,
) -> anyhow::Result<bool> {
    let scene = match loaded {
        Some(s) => s,
        None => load(args, time)?,
    };
    let total = layout_spp(args, &scene);
    let range = part.samples(total)?;
    let started = Instant::now();
    let out = render_on(device, args, &scene, range)?;
    let rendered = started.elapsed().as_secs_f64();
    if out.non_finite_samples > 0 {
        crate::diag!("warning: {} NaN or infinite radiance samples were counted as black", out.non_finite_samples);
    }
    // What was taken: the whole range, or its first `spp` samples when stopped early.
    let taken = SampleRange { begin: range.begin, end: range.begin + out.spp };
    let meta = RenderMetadata::new(taken, fingerprint(&scene, total), &out.device, out.seconds);
    let writing = Instant::now();
    super::rescue::write_outputs(outputs, &out.image, tm, &meta, &std::env::temp_dir())?;
    if args.profile {
        // The rest of the process's time: a render's own figure leaves these out.
        crate::diag!("process: render {rendered:.3} s, writing {:.3} s", writing.elapsed().as_secs_f64());
    }
    Ok(out.stopped_early)
}

/// Runs `lumen render`.
pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    let outputs = if args.outputs.is_empty() {
        let stem = args.scene.file_stem().ok_or_else(|| anyhow!("{} has no file name", args.scene.display()))?;
        vec![PathBuf::from(stem).with_extension("png")]
    } else {
        args.outputs.clone()
    };
    let (tm, frames, part) = validate(&args, &outputs)?;
    // Load before opening a device: a broken script fails fast, without GPU start-up.
    let started = Instant::now();
    // An animation's frames: `--shard I/N` takes contiguous runs of them, as of samples.
    let mine = match (frames, part) {
        (Some(f), Part::Shard { index, count }) => SampleRange::shard(index, count, f.count).context("--shard")?,
        (Some(f), _) => SampleRange::all(f.count),
        (None, _) => SampleRange::all(1),
    };
    // The first frame this run renders (its scene is kept for it).
    let mut first = Some(load(&args, frames.map_or(args.script.time, |f| f.time(mine.begin)))?);
    let animation = match frames {
        Some(frames) => {
            let video = video_output(&outputs, mine.len() == frames.count);
            check_animation(&args, &outputs, frames, mine, video.as_ref())?;
            Some((frames, mine, video))
        }
        None => None,
    };
    if let (None, Some(scene)) = (&animation, &first) {
        // A sample range or shard beyond the scene's samples fails before the device opens.
        part.samples(layout_spp(&args, scene))?;
    }
    let loaded = started.elapsed().as_secs_f64();
    let device = open(&args)?;
    if args.profile {
        crate::diag!("process: scene {loaded:.3} s, device start-up {:.3} s", started.elapsed().as_secs_f64() - loaded);
    }
    let Some((frames, mine, video)) = animation else {
        render_one(&device, &args, args.script.time, &outputs, &tm, part, first)?;
        if args.profile {
            // Closing the device (its queue drained, its buffers freed, a twin's thread
            // joined) is part of the process's time too.
            let closing = Instant::now();
            drop(device);
            crate::diag!("process: closing the device {:.3} s", closing.elapsed().as_secs_f64());
        }
        return Ok(());
    };
    for k in mine.begin..mine.end {
        let paths: Vec<PathBuf> = outputs.iter().map(|o| frame_path(o, k, frames.count)).collect();
        crate::diag!("frame {}/{} (TIME = {})", k + 1, frames.count, frames.time(k));
        // The shard applies to the frames: each frame takes all its samples.
        let loaded = if k == mine.begin { first.take() } else { None };
        if render_one(&device, &args, frames.time(k), &paths, &tm, Part::All, loaded)? {
            crate::diag!("note: stopping the animation after frame {}", k + 1);
            return Ok(());
        }
    }
    if mine.len() < frames.count {
        crate::diag!(
            "note: frames {}..{} of {} rendered (shard); no video assembled",
            mine.begin + 1,
            mine.end,
            frames.count
        );
    } else if let Some(Video { frames: ldr, video }) = &video {
        make_video(ldr, video, frames.count)?;
    }
    Ok(())
}

/// The video an animation assembles: from the numbered frames of `frames` (an LDR output)
/// into `video`.
struct Video {
    frames: PathBuf,
    video: PathBuf,
}

/// The video to assemble after all the frames (`whole`: this run renders every frame),
/// if an output is LDR and ffmpeg is on PATH (else a note says why not).
fn video_output(outputs: &[PathBuf], whole: bool) -> Option<Video> {
    let ldr = outputs.iter().find(|o| ImageFormat::from_path(o).is_ok_and(|f| !f.is_hdr()))?;
    if !whole {
        return None;
    }
    if Process::new("ffmpeg").arg("-version").output().is_err() {
        crate::diag!("note: ffmpeg is not on PATH; no video will be assembled");
        return None;
    }
    Some(Video { frames: ldr.clone(), video: ldr.with_extension("mp4") })
}

/// Checks, before the first frame, what would otherwise fail after some were rendered:
/// every frame's outputs (the first of each in full, as `validate` checks a still image's;
/// the others, in the same directory with names as long, need only not be a directory or
/// a special file), the video's destination, and the script at every frame's TIME
/// (`TIME` may make a value non-finite, or an aspect ratio change the size), each loaded
/// with its DUMP output discarded and dropped again.
fn check_animation(
    args: &RenderArgs,
    outputs: &[PathBuf],
    frames: Frames,
    mine: SampleRange,
    video: Option<&Video>,
) -> anyhow::Result<()> {
    for o in outputs {
        for k in mine.begin..mine.end {
            let path = frame_path(o, k, frames.count);
            if k == mine.begin || path.symlink_metadata().is_ok_and(|m| !m.is_file()) {
                crate::image::check_destination(&path).with_context(|| format!("cannot write {}", path.display()))?;
            }
        }
    }
    if let Some(v) = video {
        crate::image::check_destination(&v.video).with_context(|| format!("cannot write {}", v.video.display()))?;
    }
    for k in mine.begin + 1..mine.end {
        let time = frames.time(k);
        load_with_output(args, time, &mut std::io::sink())
            .with_context(|| format!("frame {} of {} (TIME = {time})", k + 1, frames.count))?;
    }
    Ok(())
}

/// Assembles the `count` numbered frames of `output` (an LDR image) into `video` with ffmpeg.
fn make_video(output: &Path, video: &Path, count: u32) -> anyhow::Result<()> {
    let digits = count.to_string().len().max(4);
    // ffmpeg reads `%` in the name as a pattern: a literal one is `%%`.
    let literal = |s: &std::ffi::OsStr| s.to_string_lossy().replace('%', "%%");
    let stem = output.file_stem().map(literal).unwrap_or_default();
    let ext = output.extension().map(literal).unwrap_or_default();
    let pattern = output.with_file_name(format!("{stem}_%0{digits}d.{ext}"));
    // ffmpeg writes the temporary file of an atomic write (its name does not end in .mp4,
    // hence `-f mp4`), so a failed or interrupted assembly leaves no partial video.
    crate::image::produce_atomically(video, |_, tmp| {
        let status = Process::new("ffmpeg")
            .args(["-y", "-loglevel", "error", "-framerate", &VIDEO_FPS.to_string(), "-start_number", "1", "-i"])
            .arg(&pattern)
            // Exactly this animation's frames: more numbered files may be left from a
            // longer one before it.
            .args(["-frames:v", &count.to_string()])
            .args(["-pix_fmt", "yuv420p", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-f", "mp4"])
            .arg(tmp)
            .status()?;
        if status.success() {
            Ok(())
        } else {
            Err(std::io::Error::other(format!("ffmpeg failed ({status})")))
        }
    })
    .with_context(|| format!("cannot assemble {}", video.display()))?;
    crate::diag!("wrote {}", video.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernel_notes_say_what_was_created() {
        assert_eq!(kernel_note(0, 0.001), "kernels from cache");
        assert_eq!(kernel_note(1, 0.25), "1 kernel created in 0.25 s");
        assert_eq!(kernel_note(9, 1.234), "9 kernels created in 1.23 s");
        assert_eq!(twin_note(0, 12), "");
        assert_eq!(twin_note(5, 12), "; 5 of 12 batches on a twin device");
    }

    #[test]
    fn frames_parse_and_space_evenly() {
        let f = Frames::parse("0:2:5").unwrap();
        assert_eq!((f.time(0), f.time(2), f.time(4)), (0.0, 1.0, 2.0));
        assert_eq!(Frames::parse("1:9:1").unwrap().time(0), 1.0);
        for bad in ["0:1", "0:1:0", "a:1:2", "0:inf:2", "0:1:-3", "0:1:2:3"] {
            assert!(Frames::parse(bad).is_err(), "{bad}");
        }
        assert_eq!(frame_path(Path::new("dir/out.png"), 0, 10), PathBuf::from("dir/out_0001.png"));
        assert_eq!(frame_path(Path::new("o.pfm"), 41, 12345), PathBuf::from("o_00042.pfm"));
    }

    #[test]
    fn tone_map_choice() {
        assert_eq!(tone_map(None, None).unwrap(), ToneMap::default());
        let t = tone_map(Some(0.3), None).unwrap();
        assert_eq!((t.curve, t.alpha, t.gamma), (ToneMap::raytracer_jl().curve, 0.3, 1.0));
        assert!(tone_map(Some(-1.0), None).is_err());
        assert!(tone_map(None, Some(f32::NAN)).is_err());
    }

    /// `--alpha` and `--gamma` are refused in `lumen tonemap`'s words: `1e39` is past f32's
    /// range (it was "alpha must be a finite number > 0, got inf").
    #[test]
    fn tone_map_options_are_refused_as_tonemap_refuses_them() {
        #[derive(clap::Parser)]
        struct T {
            #[command(flatten)]
            render: RenderArgs,
        }
        use clap::Parser as _;
        let t = T::try_parse_from(["t", "s.sl", "--alpha", "0.5", "--gamma", "1"]).unwrap();
        assert_eq!((t.render.alpha, t.render.gamma), (Some(0.5), Some(1.0)));
        for (option, value, said) in [
            ("--alpha", "1e39", "1e39 is too large; expected a number > 0 and at most 3.4e38 (f32's range)"),
            ("--gamma", "-1", "expected a finite number > 0, got \"-1\""),
            ("--gamma", "1e-50", "1e-50 is too small"),
        ] {
            let e = T::try_parse_from(["t", "s.sl", option, value]).err().unwrap().to_string();
            assert!(e.contains(said), "{option} {value}: {e}");
        }
    }
}
