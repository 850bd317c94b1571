//! The CPU render loop: tiles on rayon, each pixel the mean of its camera samples (and the
//! path tracer's `n` paths per sample), independent of thread count and tile order.
//!
//! Samples are taken in *rounds*, as on the GPU (`crate::stop`): round k adds samples
//! `[j0, j1)` to every pixel's f64 sum, so a time limit checked between rounds or a Ctrl-C
//! (which drops the unfinished round) still leaves the same number of samples in every
//! pixel. Each pixel's sum is one running sum over its samples in index order, continued
//! from round to round, so the image does not depend on how the samples were split into
//! rounds: a complete render is bit-identical to summing every sample in one go.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;

use crate::color::Color;
use crate::image::HdrImage;
use crate::memory::{check_fits, try_filled, OutOfMemory};
use crate::scene::{Renderer, Scene, CAMERA_RAY_TMIN};
use crate::stop::StopReason;

use super::context::{Context, Counters};
use super::lights::Lights;
use super::path_tracer::path_radiance;
use super::simple_renderers::{flat_radiance, on_off_radiance, point_light_radiance};
use super::{Ray, World};
use crate::prepare::pixel_samples::PixelSamples;
use crate::prepare::SampleRange;

/// Side of the square tiles the image is split into.
const TILE: u32 = 16;

/// Wanted duration of one round: long enough that the per-round cost (copying the sums,
/// waking the threads) stays under about 1%, short enough for a responsive progress bar
/// and a time limit overshot by little.
const TARGET_ROUND_SECONDS: f64 = 0.5;

/// Bytes per pixel a CPU render holds at its peak: the f64 sums of the completed rounds and
/// of the round in progress (24 bytes each), and the f32 image (12 bytes).
pub const CPU_RENDER_BYTES_PER_PIXEL: u64 = 24 + 24 + 12;

/// Options that override or extend what the scene says.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RenderOptions {
    /// Camera samples per pixel instead of the tracer's `samples_per_side²` (a perfect
    /// square s² gives s×s strata; see DESIGN.md).
    pub spp: Option<u32>,
    /// Only camera samples `[begin, end)` of that layout (`None`: all of them): a shard of
    /// the full render, which `lumen merge` combines exactly with the other shards. A range
    /// reaching past the layout's count is cut at it.
    pub samples: Option<SampleRange>,
}

/// When a render may stop before every sample is taken: the GPU renderer's rules
/// (`crate::gpu::PassOptions`), so `--time-limit` and Ctrl-C mean the same on both.
#[derive(Debug, Clone, Default)]
pub struct Limits {
    /// Stop after the round during which this much time has passed.
    pub time_limit: Option<Duration>,
    /// When set (e.g. by Ctrl-C, see [`crate::stop::ctrlc_flag`]), stop soon and drop the
    /// unfinished round.
    pub cancel: Option<Arc<AtomicBool>>,
    /// Camera samples per pixel in every round instead of adaptive rounds (tests use it to
    /// force a split; `None` or 0: adaptive).
    pub round_spp: Option<u32>,
}

impl Limits {
    fn cancelled(&self) -> bool {
        self.cancel.as_ref().is_some_and(|c| c.load(Ordering::Relaxed))
    }
}

/// Whether to draw a progress bar on standard error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Progress {
    /// Draw nothing on standard error.
    Hidden,
    /// A bar with ETA, drawn only when standard error is a terminal.
    Bar,
}

/// What a render measured.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RenderStats {
    /// Radiance samples (camera samples × paths per sample, over all pixels).
    pub samples: u64,
    /// Closest-hit and shadow rays traced (in the rounds kept).
    pub rays: u64,
    /// Samples whose radiance was NaN or infinite; each was counted as 0.
    pub non_finite_samples: u64,
    /// Wall-clock time of the whole call, scene preparation included, in seconds.
    pub seconds: f64,
    /// Camera samples per pixel taken, the same in every pixel.
    pub spp: u64,
    /// Camera samples per pixel asked for.
    pub spp_requested: u64,
    /// Rounds kept.
    pub rounds: u32,
    /// Why the render ended: all samples taken, the time limit or cancellation.
    pub stop: StopReason,
}

/// A rendered image (linear radiance) and its statistics.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderOutput {
    /// Per pixel, the mean radiance of the samples kept (black where none were taken).
    pub image: HdrImage,
    /// Counts, timing and the reason the render stopped.
    pub stats: RenderStats,
}

/// Renders `scene` on the CPU, taking every sample. Panics when the memory for the image
/// cannot be had: for sizes that come from input, use [`render_limited`].
///
/// ```
/// use lumen::color::Color;
/// use lumen::cpu::{render, Progress, RenderOptions};
/// use lumen::scene::{Renderer, SceneBuilder, Transform};
/// use glam::DVec3;
///
/// let mut b = SceneBuilder::new(8, 8);
/// let m = b.diffuse(Color::WHITE);
/// b.sphere(Transform::translation(DVec3::new(3.0, 0.0, 0.0)), m)
///     .renderer(Renderer::OnOff { on: Color::WHITE, off: Color::BLACK });
/// let out = render(&b.build().unwrap(), &RenderOptions::default(), Progress::Hidden);
/// assert_eq!(out.image.get(4, 4), Color::WHITE.into()); // the centre sees the sphere
/// assert_eq!(out.image.get(0, 0), Color::BLACK.into()); // the corner does not
/// assert_eq!(out.stats.samples, 64);
/// ```
pub fn render(scene: &Scene, opts: &RenderOptions, progress: Progress) -> RenderOutput {
    render_limited(scene, opts, &Limits::default(), progress).unwrap_or_else(|e| panic!("CPU render: {e}"))
}

/// Bytes a CPU render of `width × height` pixels needs at its peak (what [`render_limited`]
/// checks before allocating).
pub fn memory_estimate(width: u32, height: u32) -> u64 {
    u64::from(width) * u64::from(height) * CPU_RENDER_BYTES_PER_PIXEL
}

/// One tile's running sums, and the round in progress.
struct TileState {
    x0: u32,
    y0: u32,
    width: u32,
    /// Per-pixel sums of the completed rounds, row by row.
    sums: Vec<Color>,
    /// `sums` plus the round in progress; swapped into `sums` when every tile finishes it.
    next: Vec<Color>,
    counters: Counters,
    non_finite: u64,
    round_counters: Counters,
    round_non_finite: u64,
    round_complete: bool,
}

impl TileState {
    /// Adds samples `j0..j1` of every pixel to a copy of the sums; stops early (leaving
    /// `round_complete` false) once `limits` says cancel.
    fn run_round(&mut self, ctx: &Context, layout: PixelSamples, j0: u32, j1: u32, limits: &Limits) {
        self.next.copy_from_slice(&self.sums);
        self.round_counters = Counters::default();
        self.round_non_finite = 0;
        self.round_complete = false;
        for (i, sum) in self.next.iter_mut().enumerate() {
            if limits.cancelled() {
                return;
            }
            let (col, row) = (self.x0 + i as u32 % self.width, self.y0 + i as u32 / self.width);
            add_samples(ctx, layout, col, row, j0..j1, sum, &mut self.round_counters, &mut self.round_non_finite);
        }
        self.round_complete = true;
    }

    fn commit_round(&mut self) {
        std::mem::swap(&mut self.sums, &mut self.next);
        self.counters.rays += self.round_counters.rays;
        self.non_finite += self.round_non_finite;
    }
}

/// Renders `scene` on the CPU in rounds of samples until every sample is taken, the time
/// limit has passed (checked between rounds) or the cancel flag is set (the unfinished
/// round is dropped). Every pixel of the image has `stats.spp` samples (black if 0).
///
/// The memory is estimated first ([`memory_estimate`]) and every buffer allocated
/// fallibly, so a size this machine cannot hold is an error, never an abort.
///
/// ```
/// use std::sync::{atomic::AtomicBool, Arc};
/// use lumen::cpu::{render_limited, Limits, Progress, RenderOptions};
/// use lumen::scene::SceneBuilder;
/// use lumen::stop::StopReason;
///
/// let scene = SceneBuilder::new(4, 4).build().unwrap();
/// let limits = Limits { cancel: Some(Arc::new(AtomicBool::new(true))), ..Limits::default() };
/// let out = render_limited(&scene, &RenderOptions { spp: Some(9), ..RenderOptions::default() }, &limits, Progress::Hidden).unwrap();
/// assert_eq!((out.stats.stop, out.stats.spp, out.stats.samples), (StopReason::Interrupted, 0, 0));
/// ```
pub fn render_limited(
    scene: &Scene,
    opts: &RenderOptions,
    limits: &Limits,
    progress: Progress,
) -> Result<RenderOutput, OutOfMemory> {
    let start = Instant::now();
    let (w, h) = (scene.width, scene.height);
    let estimate = memory_estimate(w, h);
    check_fits(estimate, &format!("a {w}×{h} CPU render"))?;
    // Sums are allocated tile by tile; a refusal reports them all.
    let what = format!("the sample sums of a {w}×{h} CPU render");
    let refused =
        || OutOfMemory::Refused { what: what.clone(), bytes: u64::from(w) * u64::from(h) * 48, total: estimate };
    let mut tiles = Vec::new();
    tiles.try_reserve_exact(w.div_ceil(TILE) as usize * h.div_ceil(TILE) as usize).map_err(|_| refused())?;
    for y0 in (0..h).step_by(TILE as usize) {
        for x0 in (0..w).step_by(TILE as usize) {
            let (width, height) = (TILE.min(w - x0), TILE.min(h - y0));
            let n = (width * height) as usize;
            tiles.push(TileState {
                x0,
                y0,
                width,
                sums: try_filled(n, Color::BLACK, &what, estimate).map_err(|_| refused())?,
                next: try_filled(n, Color::BLACK, &what, estimate).map_err(|_| refused())?,
                counters: Counters::default(),
                non_finite: 0,
                round_counters: Counters::default(),
                round_non_finite: 0,
                round_complete: false,
            });
        }
    }

    let form = crate::prepare::render_form(scene);
    let scene = &*form;
    let world = World::new(scene);
    let lights = Lights::new(scene);
    let layout = PixelSamples::new(&scene.tracer, opts.spp);
    let ctx = Context::new(scene, &world, &lights, layout);
    // Sample indices are u32, as on the GPU (the CLI refuses counts that would wrap).
    let count = u32::try_from(layout.count()).unwrap_or(u32::MAX);
    let range = opts.samples.unwrap_or(SampleRange::all(count));
    let (first, total) = (range.begin.min(count), range.end.min(count));
    let pixels = u64::from(w) * u64::from(h);
    let bar = progress_bar(progress, u64::from(total - first) * pixels);
    let fixed = limits.round_spp.filter(|&r| r > 0);
    let mut round_spp = fixed.unwrap_or(1);
    let (mut done, mut rounds) = (first, 0u32);
    let mut stop = StopReason::Completed;
    while done < total {
        if limits.cancelled() {
            stop = StopReason::Interrupted;
            break;
        }
        let (j0, j1) = (done, done.saturating_add(round_spp).min(total));
        let t = Instant::now();
        tiles.par_iter_mut().for_each(|tile| {
            tile.run_round(&ctx, layout, j0, j1, limits);
            bar.inc(u64::from(j1 - j0) * tile.sums.len() as u64);
        });
        if !tiles.iter().all(|t| t.round_complete) {
            stop = StopReason::Interrupted;
            break;
        }
        tiles.iter_mut().for_each(TileState::commit_round);
        done = j1;
        rounds += 1;
        bar.set_message(format!("{}/{} spp", done - first, total - first));
        let per_spp = t.elapsed().as_secs_f64() / f64::from(j1 - j0);
        let remaining = match limits.time_limit {
            Some(limit) if start.elapsed() >= limit => {
                if done < total {
                    stop = StopReason::TimeLimit;
                }
                break;
            }
            Some(limit) => Some((limit - start.elapsed()).as_secs_f64()),
            None => None,
        };
        round_spp = fixed.unwrap_or_else(|| next_round_spp(j1 - j0, per_spp, remaining));
    }
    bar.finish_and_clear();

    // The sums of the round in progress are not needed any more: free them before the image.
    for t in &mut tiles {
        t.next = Vec::new();
    }
    let mut image = HdrImage::try_new(w as usize, h as usize)?;
    let mut stats = RenderStats {
        spp: u64::from(done - first),
        spp_requested: u64::from(total - first),
        rounds,
        stop,
        ..RenderStats::default()
    };
    let n = u64::from(done - first) * paths_per_sample(scene);
    for t in &tiles {
        for (i, sum) in t.sums.iter().enumerate() {
            let c = if n == 0 { Color::BLACK } else { *sum / n as f64 };
            image.set((t.x0 + i as u32 % t.width) as usize, (t.y0 + i as u32 / t.width) as usize, c.into());
        }
        stats.rays += t.counters.rays;
        stats.non_finite_samples += t.non_finite;
    }
    stats.samples = pixels * n;
    stats.seconds = start.elapsed().as_secs_f64();
    Ok(RenderOutput { image, stats })
}

/// Camera samples per pixel for the next round: about [`TARGET_ROUND_SECONDS`] at the last
/// round's speed, at most twice the last round (its timing may be noise), and with a time
/// limit no more than fits in the time left (so the limit is overshot by at most a round of
/// one sample); at least 1.
fn next_round_spp(last: u32, seconds_per_spp: f64, remaining: Option<f64>) -> u32 {
    let mut spp = f64::from(last.saturating_mul(2));
    if seconds_per_spp > 0.0 {
        spp = spp.min(TARGET_ROUND_SECONDS / seconds_per_spp);
        if let Some(rem) = remaining {
            spp = spp.min(rem / seconds_per_spp);
        }
    }
    (spp.floor() as u32).max(1)
}

fn progress_bar(progress: Progress, total: u64) -> ProgressBar {
    match progress {
        Progress::Hidden => ProgressBar::hidden(),
        Progress::Bar => {
            let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
            if let Ok(style) =
                ProgressStyle::with_template("{bar:40} {percent:>3}% {elapsed_precise} ETA {eta_precise} {msg}")
            {
                bar.set_style(style);
            }
            bar
        }
    }
}

/// Paths traced per camera sample: the path tracer's `n`, 1 for the other renderers.
pub fn paths_per_sample(scene: &Scene) -> u64 {
    match &scene.renderer {
        Renderer::PathTracer(s) => u64::from(s.n),
        _ => 1,
    }
}

/// Mean radiance of pixel (col, row) over all its samples; non-finite samples count as 0
/// and are tallied.
pub fn render_pixel(
    ctx: &Context,
    layout: PixelSamples,
    col: u32,
    row: u32,
    counters: &mut Counters,
    non_finite: &mut u64,
) -> Color {
    let mut sum = Color::BLACK;
    let count = u32::try_from(layout.count()).unwrap_or(u32::MAX);
    add_samples(ctx, layout, col, row, 0..count, &mut sum, counters, non_finite);
    let n = layout.count() * paths_per_sample(ctx.scene);
    if n == 0 {
        Color::BLACK
    } else {
        sum / n as f64
    }
}

/// Adds camera samples `js` of pixel (col, row), each the sum of its paths, to `sum`, one
/// radiance sample at a time in index order (what makes rounds bit-identical to one pass);
/// non-finite samples count as 0 and are tallied. Sample indices j·n + i are taken modulo
/// 2³² (the stream rule's u32).
#[allow(clippy::too_many_arguments)]
pub fn add_samples(
    ctx: &Context,
    layout: PixelSamples,
    col: u32,
    row: u32,
    js: std::ops::Range<u32>,
    sum: &mut Color,
    counters: &mut Counters,
    non_finite: &mut u64,
) {
    let scene = ctx.scene;
    let pixel = row * scene.width + col;
    let paths = paths_per_sample(scene) as u32;
    for j in js {
        let (upx, vpx) = layout.position(scene.tracer.rng, pixel, j);
        let u = (f64::from(col) + upx) / f64::from(scene.width);
        let v = 1.0 - (f64::from(row) + vpx) / f64::from(scene.height);
        let cam = scene.camera.ray(u, v);
        let ray = Ray::new(cam.origin, cam.dir, CAMERA_RAY_TMIN, f64::INFINITY);
        for i in 0..paths {
            let sample = j.wrapping_mul(paths).wrapping_add(i);
            let c = sample_radiance(ctx, &ray, pixel, sample, counters);
            if c.is_finite() {
                *sum += c;
            } else {
                *non_finite += 1;
            }
        }
    }
}

/// One radiance sample by the scene's integrator.
fn sample_radiance(ctx: &Context, ray: &Ray, pixel: u32, sample: u32, counters: &mut Counters) -> Color {
    match &ctx.scene.renderer {
        Renderer::OnOff { on, off } => on_off_radiance(ctx, ray, *on, *off, counters),
        Renderer::Flat { .. } => flat_radiance(ctx, ray, counters),
        Renderer::PointLight { ambient, .. } => point_light_radiance(ctx, ray, *ambient, counters),
        Renderer::PathTracer(s) => path_radiance(ctx, s, *ray, pixel, sample, counters),
    }
}
