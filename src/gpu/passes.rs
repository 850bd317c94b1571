//! Progressive rendering in short GPU passes, independent of what the kernel computes.
//!
//! A desktop GPU that runs one compute submission for more than a second or two gets reset
//! by the OS watchdog, so an image is rendered as many short *passes*: one dispatch over one
//! tile of pixels for a small range of camera samples `[j0, j1)`. Each pass writes per-pixel
//! f32 sums of its samples; the host reads them back and adds them in f64
//! ([`Accumulator`]), so precision does not plateau however many passes run.
//!
//! Kernel contract (also in `shaders/pass.wgsl` and docs/DESIGN.md, "GPU passes"):
//! - `@group(0) @binding(0) var<uniform> pass_params: PassParams` ([`PassUniform`]);
//! - `@group(0) @binding(1) var<storage, read_write> pass_out: array<vec4<f32>>`;
//! - the caller's bind groups are groups 1, 2, … in order;
//! - invocation `gid.xy` is the tile pixel (column, row); invocations outside the tile
//!   return; the pixel's sum over samples `j0..j1` goes to `pass_out[row * tile_w + col].rgb`,
//!   overwriting (the buffer is reused by every pass);
//! - a sample's value depends only on (pixel, j) and the scene, never on the pass split.
//!
//! Resumable kernels (`shaders/resume.wgsl`, assembled when the driver has a loop limiter)
//! also declare `@group(0) @binding(2) var<storage, read_write> pass_state:
//! array<vec4<u32>>`; a pass over them is repeated on its tile until every pixel reports
//! done, with single-pixel ("solo") dispatches for paths cut by the limiter (docs/DESIGN.md,
//! "Loop limiter and path-granular passes").
//!
//! Uniform sample counts: passes are grouped in *rounds*, one sample range over every tile.
//! Stopping conditions are checked between rounds (time limit) or abandon the unfinished
//! round (Ctrl-C), so every pixel of the result has exactly `spp_done` samples.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use bytemuck::{Pod, Zeroable};
use indicatif::{ProgressBar, ProgressStyle};

use super::accumulate::{Accumulator, Tile};
use super::compute::{BindingKind, ComputeKernel};
use super::device::{Gpu, GpuError};
use crate::image::HdrImage;

/// WGSL declarations of the kernel contract (prepend to, or assemble with, a pass kernel).
pub const PASS_WGSL: &str = include_str!("../../shaders/pass.wgsl");

/// The per-pass uniform: `PassParams` in `shaders/pass.wgsl` (48 bytes, same layout).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Pod, Zeroable)]
pub struct PassUniform {
    pub tile_origin: [u32; 2],
    pub tile_size: [u32; 2],
    pub image_size: [u32; 2],
    pub sample_begin: u32,
    pub sample_end: u32,
    /// Resumable kernels: the only tile pixel to run ([`NO_SOLO`]: all of them).
    pub solo_pixel: u32,
    /// Resumable kernels: at most this many paths per invocation per dispatch (0: no bound).
    pub path_budget: u32,
    pub _pad: [u32; 2],
}

/// Most paths one resumable pass can count (28 bits of `pass_state`'s progress word):
/// samples per pass × paths per sample must stay below it.
pub const MAX_RESUMABLE_PATHS_PER_PASS: u32 = RESUME_PROGRESS;

/// [`PassUniform::solo_pixel`] when every pixel of the tile runs.
pub const NO_SOLO: u32 = u32::MAX;

// Flags in the `.w` word of `pass_state` (`shaders/resume.wgsl`).
const RESUME_DONE: u32 = 0x1000_0000;
const RESUME_NEEDS_SOLO: u32 = 0x2000_0000;
const RESUME_LIMITED: u32 = 0x4000_0000;
const RESUME_PROGRESS: u32 = 0x0FFF_FFFF;

/// How passes are sized and when rendering stops.
#[derive(Debug, Clone)]
pub struct PassOptions {
    /// Tiles are at most `tile_size × tile_size` pixels (65,536 invocations at 256: enough to
    /// fill a large GPU, small enough that one sample per pixel is a short pass). Halved
    /// between rounds, down to 32, while one sample per pass still takes over twice the target.
    pub tile_size: u32,
    /// Wanted duration of one pass; samples per pass adapt towards it (well under any
    /// watchdog, long enough that submission overhead is small).
    pub target_pass_seconds: f64,
    /// Samples per pixel in the first round (small: the kernel's cost is unknown).
    pub initial_spp_per_pass: u32,
    /// Upper bound on samples per pass: a pass sums its samples in f32, and 64 sums of
    /// similar values keep the relative rounding error below 1e-6.
    pub max_spp_per_pass: u32,
    /// Stop after the round during which this much time has passed.
    pub time_limit: Option<Duration>,
    /// When set (e.g. by Ctrl-C, see [`ctrlc_flag`]), stop after the current pass and drop
    /// the unfinished round.
    pub cancel: Option<Arc<AtomicBool>>,
    /// Show a progress bar on stderr (hidden anyway when stderr is not a terminal).
    pub progress: bool,
    /// Resumable kernels only: at most this many paths per pixel per dispatch (0: as many
    /// as the driver's loop limiter allows). The sums do not depend on it; tests use small
    /// budgets to force many resumptions.
    pub path_budget: u32,
}

impl Default for PassOptions {
    fn default() -> Self {
        Self {
            tile_size: 256,
            target_pass_seconds: 0.025,
            initial_spp_per_pass: 1,
            max_spp_per_pass: 64,
            time_limit: None,
            cancel: None,
            progress: false,
            path_budget: 0,
        }
    }
}

// Shared with the CPU renderer (moved to `crate::stop`).
pub use crate::stop::StopReason;

/// The result of a progressive render.
#[derive(Debug, Clone)]
pub struct Accumulated {
    /// Per-pixel mean over `spp_done` samples (black if `spp_done` is 0).
    pub image: HdrImage,
    /// Per-pixel f64 sums over the same samples, row-major.
    pub sums: Vec<[f64; 3]>,
    /// Samples per pixel, the same for every pixel.
    pub spp_done: u32,
    /// Passes run (one per tile and round), including those of a dropped round.
    pub passes: u32,
    pub seconds: f64,
    pub stop: StopReason,
    /// Pixel-pass sums dropped as NaN/infinite (should be 0; a kernel bug otherwise).
    pub nonfinite: u64,
    /// Dispatches run: `passes` unless the kernel is resumable and passes were resumed.
    pub dispatches: u64,
    /// Resumable kernels: paths that the driver's loop limiter cut even when run alone
    /// (counted as 0; the image is then not exact, and `lumen render` warns).
    pub loop_limited_paths: u64,
}

/// Renders `total_spp` samples per pixel of a `width × height` image with `kernel`, whose
/// groups 1.. are `scene_groups` (see the module docs for the kernel contract).
///
/// ```
/// use lumen::gpu::{gpu_for_tests, run_progressive, PassOptions, PASS_WGSL};
/// let Some(gpu) = gpu_for_tests("run_progressive_doc") else { return };
/// // Every sample of every pixel is 0.5, so every mean is 0.5.
/// let src = format!("{PASS_WGSL}
/// @compute @workgroup_size(8, 8)
/// fn main(@builtin(global_invocation_id) gid: vec3<u32>) {{
///     if (!pass_in_tile(gid)) {{ return; }}
///     let n = f32(pass_params.sample_end - pass_params.sample_begin);
///     pass_write(gid, vec3<f32>(0.5 * n));
/// }}");
/// let kernel = gpu.compute_kernel("half.wgsl", &src, "main").unwrap();
/// let out = run_progressive(&gpu, &kernel, &[], 5, 3, 10, &PassOptions::default()).unwrap();
/// assert_eq!(out.spp_done, 10);
/// assert!(out.image.pixels().iter().all(|p| p.r == 0.5));
/// ```
pub fn run_progressive(
    gpu: &Gpu,
    kernel: &ComputeKernel,
    scene_groups: &[&wgpu::BindGroup],
    width: u32,
    height: u32,
    total_spp: u32,
    opts: &PassOptions,
) -> Result<Accumulated, GpuError> {
    check_contract(kernel, scene_groups.len())?;
    if width == 0 || height == 0 || total_spp == 0 {
        return Err(GpuError::Validation(format!(
            "progressive render of {width}×{height} pixels at {total_spp} spp: all must be positive"
        )));
    }
    let mut tile_size = opts.tile_size.clamp(1, 4096);
    let max_spp = opts.max_spp_per_pass.max(1);
    let start = Instant::now();

    let mut tiles = Tile::cover(width, height, tile_size);
    let max_tile_pixels = tiles.iter().map(Tile::pixel_count).max().unwrap_or(1) as u64;
    let out_bytes = max_tile_pixels * 16;
    let uniform = gpu.uniform_buffer("pass uniform", &PassUniform::zeroed())?;
    let output = gpu.storage_buffer_zeroed("pass output", out_bytes)?;
    let staging = gpu.scoped(|| {
        gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("pass readback"),
            size: out_bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    })?;
    let resumable = is_resumable(kernel);
    let state = if resumable { Some(gpu.storage_buffer_zeroed("pass state", out_bytes)?) } else { None };
    let group0 = match &state {
        Some(state) => kernel.bind_group(gpu, 0, &[&uniform, &output, state])?,
        None => kernel.bind_group(gpu, 0, &[&uniform, &output])?,
    };
    let mut groups: Vec<&wgpu::BindGroup> = vec![&group0];
    groups.extend_from_slice(scene_groups);
    let mut pass = PassRunner {
        gpu,
        kernel,
        groups,
        uniform: &uniform,
        output: &output,
        state: state.as_ref(),
        staging: &staging,
        cancel: opts.cancel.as_deref(),
        dispatches: 0,
        loop_limited_paths: 0,
    };

    let progress = progress_bar(opts.progress, u64::from(total_spp) * u64::from(width) * u64::from(height));
    let mut acc = Accumulator::new(width, height);
    let mut passes = 0u32;
    let mut spp_per_pass = opts.initial_spp_per_pass.clamp(1, max_spp);
    let mut done = 0u32;
    let mut stop = StopReason::Completed;

    'rounds: while done < total_spp {
        let j0 = done;
        let j1 = j0 + spp_per_pass.min(total_spp - done);
        let mut worst_per_sample = 0.0f64;
        let mut round_per_sample = 0.0f64;
        let limited_before_round = pass.loop_limited_paths;
        for &tile in &tiles {
            let params = PassUniform {
                tile_origin: [tile.x, tile.y],
                tile_size: [tile.width, tile.height],
                image_size: [width, height],
                sample_begin: j0,
                sample_end: j1,
                solo_pixel: NO_SOLO,
                path_budget: opts.path_budget,
                _pad: [0; 2],
            };
            let t = Instant::now();
            let complete = pass.run(&params, tile, &mut acc)?;
            let per_sample = t.elapsed().as_secs_f64() / f64::from(j1 - j0);
            worst_per_sample = worst_per_sample.max(per_sample);
            round_per_sample += per_sample;
            passes += 1;
            progress.inc(u64::from(j1 - j0) * tile.pixel_count() as u64);
            if !complete || opts.cancel.as_ref().is_some_and(|c| c.load(Ordering::SeqCst)) {
                acc.discard_round();
                pass.loop_limited_paths = limited_before_round; // not in the image
                stop = StopReason::Interrupted;
                break 'rounds;
            }
        }
        acc.commit_round(j1 - j0);
        done = j1;
        progress.set_message(format!("{done}/{total_spp} spp, {passes} passes, {} spp/pass", j1 - j0));
        let remaining = match opts.time_limit {
            Some(limit) => {
                let elapsed = start.elapsed();
                if elapsed >= limit {
                    if done < total_spp {
                        stop = StopReason::TimeLimit;
                    }
                    break;
                }
                Some((limit - elapsed).as_secs_f64())
            }
            None => None,
        };
        let shrunk = next_tile_size(tile_size, j1 - j0, worst_per_sample, opts.target_pass_seconds);
        if shrunk != tile_size {
            tile_size = shrunk;
            tiles = Tile::cover(width, height, tile_size);
        }
        spp_per_pass = next_spp_per_pass(
            j1 - j0,
            worst_per_sample,
            round_per_sample,
            remaining,
            opts.target_pass_seconds,
            max_spp,
        );
    }
    progress.finish_and_clear();

    Ok(Accumulated {
        image: acc.mean_image(),
        sums: acc.sums().to_vec(),
        spp_done: acc.spp() as u32,
        passes,
        seconds: start.elapsed().as_secs_f64(),
        stop,
        nonfinite: acc.nonfinite(),
        dispatches: pass.dispatches,
        loop_limited_paths: pass.loop_limited_paths,
    })
}

/// Samples per pass for the next round, from the last round's timings: the slowest tile's
/// pass should take about `target` seconds, growth is at most ×2 per round (timings of tiny
/// passes are noisy), and with a time limit the whole round should fit in the time left
/// (so the limit is overshot by at most a one-sample round).
fn next_spp_per_pass(
    current: u32,
    worst_seconds_per_sample: f64,
    round_seconds_per_sample: f64,
    remaining_seconds: Option<f64>,
    target: f64,
    max_spp: u32,
) -> u32 {
    let by_target = if worst_seconds_per_sample > 0.0 { target / worst_seconds_per_sample } else { f64::INFINITY };
    let mut spp = by_target.min(f64::from(current.saturating_mul(2)));
    if let Some(rem) = remaining_seconds {
        if round_seconds_per_sample > 0.0 {
            spp = spp.min(rem / round_seconds_per_sample);
        }
    }
    (spp.floor() as u32).clamp(1, max_spp.max(1))
}

/// Tile size for the next round: halved (down to [`MIN_TILE_SIZE`]) while even one sample
/// per pass takes more than twice the target, so a slow kernel on a slow GPU still gets
/// short passes. Never grows back: cheap kernels grow samples per pass instead.
fn next_tile_size(current: u32, spp_used: u32, worst_seconds_per_sample: f64, target: f64) -> u32 {
    if spp_used == 1 && worst_seconds_per_sample > 2.0 * target && current > MIN_TILE_SIZE {
        (current / 2).max(MIN_TILE_SIZE)
    } else {
        current
    }
}

/// Smallest tile [`next_tile_size`] shrinks to (1,024 invocations still fill a small GPU).
const MIN_TILE_SIZE: u32 = 32;

/// Whether `kernel` declares the resume state of `shaders/resume.wgsl` (group 0, binding 2).
fn is_resumable(kernel: &ComputeKernel) -> bool {
    kernel.bindings.first().is_some_and(|g| g.len() == 3)
}

fn check_contract(kernel: &ComputeKernel, scene_groups: usize) -> Result<(), GpuError> {
    let rw = BindingKind::Storage { read_only: false };
    let want = [(0, BindingKind::Uniform), (1, rw), (2, rw)];
    let got = kernel.bindings.first().map(Vec::as_slice).unwrap_or(&[]);
    if got != &want[..2] && got != want {
        return Err(GpuError::Validation(format!(
            "kernel {:?} breaks the pass contract: @group(0) must be exactly binding 0 = var<uniform> PassParams \
             and binding 1 = var<storage, read_write> array<vec4<f32>> (see shaders/pass.wgsl), plus binding 2 = \
             var<storage, read_write> array<vec4<u32>> if resumable (shaders/resume.wgsl); it declares {got:?}",
            kernel.label
        )));
    }
    if kernel.bindings.len() != 1 + scene_groups {
        return Err(GpuError::Validation(format!(
            "kernel {:?} declares bind groups 0..{} but {} scene bind groups were given (groups 1..)",
            kernel.label,
            kernel.bindings.len(),
            scene_groups
        )));
    }
    Ok(())
}

/// Resources of one progressive render, reused by every pass.
struct PassRunner<'a> {
    gpu: &'a Gpu,
    kernel: &'a ComputeKernel,
    groups: Vec<&'a wgpu::BindGroup>,
    uniform: &'a wgpu::Buffer,
    output: &'a wgpu::Buffer,
    /// The resume state, for resumable kernels.
    state: Option<&'a wgpu::Buffer>,
    /// Holds one tile's `output` or `state` (both 16 bytes per pixel).
    staging: &'a wgpu::Buffer,
    cancel: Option<&'a AtomicBool>,
    dispatches: u64,
    loop_limited_paths: u64,
}

impl PassRunner<'_> {
    /// One pass over `tile`: its sums are added to `acc` (one dispatch, or for a resumable
    /// kernel as many as it takes). Returns whether the pass completed: a resumable pass
    /// stops early, adding nothing, when the cancel flag is set between its dispatches.
    fn run(&mut self, params: &PassUniform, tile: Tile, acc: &mut Accumulator) -> Result<bool, GpuError> {
        let pixels = tile.pixel_count();
        if let Some(state) = self.state {
            self.gpu.scoped(|| {
                let mut encoder =
                    self.gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("reset") });
                encoder.clear_buffer(state, 0, Some(pixels as u64 * 16));
                self.gpu.queue.submit([encoder.finish()]);
            })?;
            if !self.resume_until_done(params, tile, state)? {
                return Ok(false);
            }
            let sums: Vec<[f32; 4]> = self.submit(None, tile, self.output, 0..pixels)?;
            acc.add_tile(tile, &sums);
        } else {
            let sums: Vec<[f32; 4]> = self.submit(Some(params), tile, self.output, 0..pixels)?;
            acc.add_tile(tile, &sums);
        }
        Ok(true)
    }

    /// Dispatches a resumable pass over `tile` until every pixel reports done, running
    /// each path that was cut with a fresh limiter alone ("solo") in a dispatch of its own.
    /// Returns false if cancelled first.
    fn resume_until_done(&mut self, params: &PassUniform, tile: Tile, state: &wgpu::Buffer) -> Result<bool, GpuError> {
        let pixels = tile.pixel_count();
        let mut last: Option<Vec<[u32; 4]>> = None;
        loop {
            let all = PassUniform { solo_pixel: NO_SOLO, ..*params };
            let words: Vec<[u32; 4]> = self.submit(Some(&all), tile, state, 0..pixels)?;
            if words.iter().all(|w| w[3] & RESUME_DONE != 0) {
                return Ok(true);
            }
            // Every dispatch sums at least one more path or asks for a solo run; anything
            // else would loop forever.
            let progressed = last.as_ref().is_none_or(|l| l.iter().zip(&words).any(|(a, b)| a[3] != b[3]));
            if !progressed {
                return Err(GpuError::Internal(format!(
                    "resumable pass over tile {tile:?} made no progress (kernel {:?})",
                    self.kernel.label
                )));
            }
            for (k, w) in words.iter().enumerate() {
                if w[3] & RESUME_NEEDS_SOLO != 0 {
                    let solo = PassUniform { solo_pixel: k as u32, ..*params };
                    let after: Vec<[u32; 4]> = self.submit(Some(&solo), tile, state, k..k + 1)?;
                    debug_assert_eq!(after[0][3] & RESUME_PROGRESS, (w[3] & RESUME_PROGRESS) + 1);
                    if after[0][3] & RESUME_LIMITED != 0 {
                        self.loop_limited_paths += 1;
                    }
                }
            }
            if self.cancel.is_some_and(|c| c.load(Ordering::SeqCst)) {
                return Ok(false);
            }
            last = Some(words);
        }
    }

    /// One submission: a dispatch over `tile` with `params` (none: only the copy), then the
    /// 16-byte elements `range` of `source` copied out and read back.
    fn submit<T: Pod>(
        &mut self,
        params: Option<&PassUniform>,
        tile: Tile,
        source: &wgpu::Buffer,
        range: std::ops::Range<usize>,
    ) -> Result<Vec<T>, GpuError> {
        let gpu = self.gpu;
        let offset = range.start as u64 * 16;
        let bytes = range.len() as u64 * 16;
        let workgroups = self.kernel.workgroups_for([tile.width, tile.height, 1]);
        gpu.scoped(|| {
            let mut encoder =
                gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("pass") });
            if let Some(params) = params {
                gpu.queue.write_buffer(self.uniform, 0, bytemuck::bytes_of(params));
                self.kernel.encode(&mut encoder, &self.groups, workgroups);
            }
            encoder.copy_buffer_to_buffer(source, offset, self.staging, 0, bytes);
            gpu.queue.submit([encoder.finish()]);
        })?;
        if params.is_some() {
            self.dispatches += 1;
        }
        let (tx, rx) = std::sync::mpsc::channel();
        self.staging.map_async(wgpu::MapMode::Read, 0..bytes, move |r| {
            let _ = tx.send(r);
        });
        gpu.wait_idle()?;
        rx.recv()
            .map_err(|_| GpuError::Readback("map callback never ran".into()))?
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        let out = {
            let view = self.staging.get_mapped_range(0..bytes).map_err(|e| GpuError::Readback(e.to_string()))?;
            bytemuck::pod_collect_to_vec(&view)
        };
        self.staging.unmap();
        Ok(out)
    }
}

fn progress_bar(enabled: bool, len: u64) -> ProgressBar {
    if !enabled {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(len);
    if let Ok(style) = ProgressStyle::with_template("{elapsed_precise} [{wide_bar}] {percent:>3}% {msg}") {
        bar.set_style(style.progress_chars("=> "));
    }
    bar
}

// Shared with the CPU renderer (moved to `crate::stop`).
pub use crate::stop::ctrlc_flag;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_layout_matches_wgsl() {
        assert_eq!(std::mem::size_of::<PassUniform>(), 48);
        let v = validate_pass_wgsl();
        let ty = v.module.types.iter().find(|(_, t)| t.name.as_deref() == Some("PassParams")).unwrap().1;
        let naga::TypeInner::Struct { members, span } = &ty.inner else { panic!("PassParams is not a struct") };
        assert_eq!(*span, 48);
        let offsets: Vec<(String, u32)> = members.iter().map(|m| (m.name.clone().unwrap(), m.offset)).collect();
        let names =
            ["tile_origin", "tile_size", "image_size", "sample_begin", "sample_end", "solo_pixel", "path_budget"];
        let rust = [0, 8, 16, 24, 28, 32, 36];
        for ((name, off), (want_name, want_off)) in offsets.iter().zip(names.iter().zip(rust)) {
            assert_eq!((name.as_str(), *off), (*want_name, want_off));
        }
    }

    fn validate_pass_wgsl() -> super::super::compute::ValidatedModule {
        super::super::compute::validate_wgsl("pass.wgsl", PASS_WGSL).unwrap()
    }

    #[test]
    fn tiles_shrink_only_when_one_sample_is_too_slow() {
        assert_eq!(next_tile_size(256, 1, 0.2, 0.025), 128);
        assert_eq!(next_tile_size(256, 1, 0.04, 0.025), 256);
        assert_eq!(next_tile_size(256, 2, 0.2, 0.025), 256);
        assert_eq!(next_tile_size(40, 1, 9.0, 0.025), MIN_TILE_SIZE);
        assert_eq!(next_tile_size(MIN_TILE_SIZE, 1, 9.0, 0.025), MIN_TILE_SIZE);
        assert_eq!(next_tile_size(8, 1, 9.0, 0.025), 8);
    }

    #[test]
    fn spp_grows_at_most_twice_and_meets_the_target() {
        // A pass of 1 spp took 1 ms: 25 would meet 25 ms but growth is capped at ×2.
        assert_eq!(next_spp_per_pass(1, 0.001, 0.004, None, 0.025, 64), 2);
        assert_eq!(next_spp_per_pass(16, 0.001, 0.004, None, 0.025, 64), 25);
        // Too slow: shrink, but never below 1.
        assert_eq!(next_spp_per_pass(8, 0.010, 0.04, None, 0.025, 64), 2);
        assert_eq!(next_spp_per_pass(8, 1.0, 4.0, None, 0.025, 64), 1);
        // The f32 bound.
        assert_eq!(next_spp_per_pass(64, 1e-9, 1e-8, None, 0.025, 64), 64);
        // Time left for 3 samples per pixel over the whole image.
        assert_eq!(next_spp_per_pass(32, 1e-4, 0.1, Some(0.35), 0.025, 64), 3);
    }
}
