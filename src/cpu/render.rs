//! The CPU render loop: tiles on rayon, each pixel the mean of its camera samples (and the
//! path tracer's `n` paths per sample), independent of thread count and tile order.

use std::time::Instant;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;

use crate::color::{Color, Rgb32};
use crate::image::HdrImage;
use crate::scene::{Renderer, Scene, CAMERA_RAY_TMIN};

use super::context::{Context, Counters};
use super::lights::Lights;
use super::path_tracer::path_radiance;
use super::pixel_samples::PixelSamples;
use super::simple_renderers::{flat_radiance, on_off_radiance, point_light_radiance};
use super::{Ray, World};

/// Side of the square tiles the image is split into.
const TILE: u32 = 16;

/// Options that override or extend what the scene says.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RenderOptions {
    /// Camera samples per pixel instead of the tracer's `samples_per_side²` (a perfect
    /// square s² gives s×s strata; see DESIGN.md).
    pub spp: Option<u32>,
}

/// Whether to draw a progress bar on standard error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Progress {
    Hidden,
    /// A bar with ETA, drawn only when standard error is a terminal.
    Bar,
}

/// What a render measured.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RenderStats {
    /// Radiance samples (camera samples × paths per sample, over all pixels).
    pub samples: u64,
    /// Closest-hit and shadow rays traced.
    pub rays: u64,
    /// Samples whose radiance was NaN or infinite; each was counted as 0.
    pub non_finite_samples: u64,
    pub seconds: f64,
}

/// A rendered image (linear radiance) and its statistics.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderOutput {
    pub image: HdrImage,
    pub stats: RenderStats,
}

/// Renders `scene` on the CPU.
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
    let start = Instant::now();
    let world = World::new(scene);
    let lights = Lights::new(scene);
    let ctx = Context { scene, world: &world, lights: &lights };
    let layout = PixelSamples::new(&scene.tracer, opts.spp);
    let (w, h) = (scene.width, scene.height);
    let tiles: Vec<(u32, u32)> =
        (0..h.div_ceil(TILE)).flat_map(|ty| (0..w.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE))).collect();
    let bar = progress_bar(progress, u64::from(w) * u64::from(h));
    let done: Vec<(Vec<Rgb32>, Counters, u64)> = tiles
        .par_iter()
        .map(|&(x0, y0)| {
            let r = render_tile(&ctx, layout, x0, y0);
            bar.inc(r.0.len() as u64);
            r
        })
        .collect();
    bar.finish_and_clear();
    let mut image = HdrImage::new(w as usize, h as usize);
    let mut stats = RenderStats::default();
    for (&(x0, y0), (pixels, counters, bad)) in tiles.iter().zip(&done) {
        let tw = TILE.min(w - x0);
        for (i, p) in pixels.iter().enumerate() {
            image.set((x0 + i as u32 % tw) as usize, (y0 + i as u32 / tw) as usize, *p);
        }
        stats.rays += counters.rays;
        stats.non_finite_samples += bad;
    }
    stats.samples = u64::from(w) * u64::from(h) * layout.count() * paths_per_sample(scene);
    stats.seconds = start.elapsed().as_secs_f64();
    RenderOutput { image, stats }
}

fn progress_bar(progress: Progress, total: u64) -> ProgressBar {
    match progress {
        Progress::Hidden => ProgressBar::hidden(),
        Progress::Bar => {
            let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
            if let Ok(style) =
                ProgressStyle::with_template("{bar:40} {percent:>3}% {elapsed_precise} ETA {eta_precise}")
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

/// The pixels of the tile at (x0, y0), row by row, with its counters and the number of
/// non-finite samples.
fn render_tile(ctx: &Context, layout: PixelSamples, x0: u32, y0: u32) -> (Vec<Rgb32>, Counters, u64) {
    let (w, h) = (ctx.scene.width, ctx.scene.height);
    let mut counters = Counters::default();
    let mut bad = 0;
    let mut pixels = Vec::with_capacity((TILE * TILE) as usize);
    for row in y0..(y0 + TILE).min(h) {
        for col in x0..(x0 + TILE).min(w) {
            pixels.push(render_pixel(ctx, layout, col, row, &mut counters, &mut bad).into());
        }
    }
    (pixels, counters, bad)
}

/// Mean radiance of pixel (col, row); non-finite samples count as 0 and are tallied.
/// Sample indices j·n + i are taken modulo 2³² (the stream rule's u32).
pub fn render_pixel(
    ctx: &Context,
    layout: PixelSamples,
    col: u32,
    row: u32,
    counters: &mut Counters,
    non_finite: &mut u64,
) -> Color {
    let scene = ctx.scene;
    let pixel = row * scene.width + col;
    let paths = paths_per_sample(scene) as u32;
    let mut sum = Color::BLACK;
    // Stream indices are u32 as on the GPU: counts whose sample indices j·n + i would wrap
    // are refused by the CLI.
    for j in 0..layout.count() {
        let j = j as u32;
        let (upx, vpx) = layout.position(scene.tracer.rng, pixel, j);
        let u = (f64::from(col) + upx) / f64::from(scene.width);
        let v = 1.0 - (f64::from(row) + vpx) / f64::from(scene.height);
        let cam = scene.camera.ray(u, v);
        let ray = Ray::new(cam.origin, cam.dir, CAMERA_RAY_TMIN, f64::INFINITY);
        for i in 0..paths {
            let sample = j.wrapping_mul(paths).wrapping_add(i);
            let c = sample_radiance(ctx, &ray, pixel, sample, counters);
            if c.is_finite() {
                sum += c;
            } else {
                *non_finite += 1;
            }
        }
    }
    let n = layout.count() * u64::from(paths);
    if n == 0 {
        Color::BLACK
    } else {
        sum / n as f64
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
