//! The host side of the wavefront renderer: rounds of camera samples over the whole image,
//! each split into batches of whole pixels that fill the device's path slots.
//!
//! - A *round* is camera samples `[j0, j1)` over every pixel. Stopping conditions are
//!   checked between rounds (time limit) or abandon the unfinished round (Ctrl-C, checked
//!   between batches), so every pixel of the result has exactly `spp_done` samples.
//! - A *batch* is a run of whole pixels whose `(j1 − j0)·n` paths each fit the slots; the
//!   device sums each pixel's paths in f32 (film stage), the host adds the batch's sums into
//!   the round in f64 ([`Accumulator`]). Pixel values do not depend on how pixels are split
//!   into batches, so batch size is free to follow the device.
//! - The host keeps the device busy: batch k + 1 is submitted before batch k's sums are
//!   read back (two film and staging buffers), across round ends too unless a time limit
//!   is set, and nothing else is read back. Where
//!   devices share the batches (`wavefront::twin`), one batch per device is submitted
//!   ahead, so that whichever device finishes first finds the next one waiting.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};

use super::contract::BatchUniform;
use crate::gpu::accumulate::Accumulator;
use crate::gpu::device::GpuError;
use crate::image::HdrImage;

/// Most camera samples per pixel in one round: the film sums a round's samples in f32, and 64
/// sums of similar values keep the relative rounding error below 1e-6.
pub const MAX_SPP_PER_ROUND: u32 = 64;

/// Most paths one film invocation sums (a round's samples × paths per sample): a bound on
/// any invocation's loop count, far below the 65,535 iterations after which Mesa 22's
/// llvmpipe silently ends loops (docs/DESIGN.md "Wavefront renderer").
pub const MAX_PATHS_PER_PIXEL_PER_ROUND: u32 = 16_384;

/// How rounds are sized and when rendering stops.
#[derive(Debug, Clone)]
pub struct PassOptions {
    /// Wanted duration of one round; samples per round adapt towards it.
    pub target_pass_seconds: f64,
    /// Samples per pixel in the first round (small: the kernels' cost is unknown).
    pub initial_spp_per_pass: u32,
    /// Upper bound on samples per round (at most [`MAX_SPP_PER_ROUND`]).
    pub max_spp_per_pass: u32,
    /// Stop after the round during which this much time has passed.
    pub time_limit: Option<Duration>,
    /// When set (e.g. by Ctrl-C, see [`ctrlc_flag`]), stop after the current batch and drop
    /// the unfinished round.
    pub cancel: Option<Arc<AtomicBool>>,
    /// Show a progress bar on stderr (hidden anyway when stderr is not a terminal).
    pub progress: bool,
    /// Path slots in flight per batch (0: from the device, see `wavefront::capacity`).
    pub batch_paths: u32,
}

impl Default for PassOptions {
    fn default() -> Self {
        Self {
            target_pass_seconds: 0.25,
            initial_spp_per_pass: 1,
            max_spp_per_pass: MAX_SPP_PER_ROUND,
            time_limit: None,
            cancel: None,
            progress: false,
            batch_paths: 0,
        }
    }
}

// Shared with the CPU renderer.
pub use crate::stop::{ctrlc_flag, StopReason};

/// The result of the rounds.
#[derive(Debug, Clone)]
pub struct Accumulated {
    /// Per-pixel mean over `spp_done` samples (black if `spp_done` is 0).
    pub image: HdrImage,
    /// Samples per pixel, the same for every pixel.
    pub spp_done: u32,
    /// Rounds and batches run, including those of a dropped round.
    pub rounds: u32,
    /// Batches submitted over all rounds.
    pub batches: u64,
    /// Why the rounds ended: every sample taken, the time limit, or cancellation.
    pub stop: StopReason,
    /// Pixel sums dropped as NaN/infinite (should be 0: the film stage already replaces
    /// non-finite estimates by 0).
    pub nonfinite: u64,
}

/// Runs one batch on the device.
pub(crate) trait BatchRunner {
    type Pending;
    /// Submits every launch of `batch`, its film going to double-buffer `slot` (0 or 1;
    /// with one device at most two batches are in flight, so slot k % 2 is free again).
    fn submit(&mut self, batch: &BatchUniform, slot: usize) -> Result<Self::Pending, GpuError>;
    /// Waits for a submitted batch and returns its per-pixel sums (f64: the film's
    /// compensated f32 sum, value plus error).
    fn collect(&mut self, pending: Self::Pending) -> Result<Vec<[f64; 3]>, GpuError>;
    /// Waits for everything submitted (before returning early).
    fn drain(&mut self) -> Result<(), GpuError>;
    /// After each round: about how many seconds of batches are left, at the last round's
    /// rate (where more devices could join: `wavefront::twin`).
    fn seconds_left(&mut self, _seconds: f64) {}
}

/// What one render needs to plan its batches.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Plan {
    pub width: u32,
    pub height: u32,
    /// The first camera sample of the render (a shard's start; 0 for a whole render).
    pub sample_begin: u32,
    /// Camera samples per pixel to take, from `sample_begin`.
    pub total_spp: u32,
    pub paths_per_sample: u32,
    pub capacity: u32,
    pub shadow_rays: u32,
    /// Devices sharing the batches (1, or 2 with a twin: `wavefront::twin`). A round's
    /// batches come in a multiple of this count, of pixel counts equal to within one, so
    /// that the devices finish a round together, and the first round fills a batch on each.
    pub devices: u32,
}

/// Samples of the next round for a plan, `wanted` at most: no more than the slots hold
/// for one pixel, nor the film's loop bound.
fn round_samples(plan: &Plan, wanted: u32) -> u32 {
    let n = plan.paths_per_sample.max(1);
    let by_slots = plan.capacity / n;
    let by_film = MAX_PATHS_PER_PIXEL_PER_ROUND / n;
    wanted.min(by_slots).min(by_film).max(1)
}

/// The batches of one round of `samples` camera samples from `j0`: the fewest that fit the
/// slots, rounded up to a multiple of the devices (while there are pixels enough), with the
/// pixels shared evenly among them (counts differing by one at most). One device takes runs
/// of pixels; where several share the batches, batch k of B takes every B-th pixel from
/// pixel k, so that each holds a like share of every part of the picture and the devices
/// end a round together (runs made batches as unequal as the sky and the ground: a trace
/// of spheres_10k.sl at 33 spp had one device idle through the last 20 % of the render).
pub(crate) fn batches(plan: &Plan, j0: u32, samples: u32) -> Vec<BatchUniform> {
    let n = plan.paths_per_sample.max(1);
    let per_pixel = samples * n;
    let pixels = plan.width * plan.height;
    let fit = (plan.capacity / per_pixel).max(1);
    let batches = pixels.div_ceil(fit).next_multiple_of(plan.devices.max(1)).min(pixels).max(1);
    let interleaved = plan.devices > 1;
    // Runs: batch k starts at pixel ⌊k·pixels / batches⌋, at most ⌈pixels / batches⌉ ≤ fit
    // each. Interleaved: batch k holds the ⌈(pixels − k) / batches⌉ ≤ fit pixels ≡ k.
    let start = |k: u32| (u64::from(k) * u64::from(pixels) / u64::from(batches)) as u32;
    (0..batches)
        .map(|k| {
            let (p0, count, stride) = if interleaved {
                (k, (pixels - k).div_ceil(batches), batches)
            } else {
                (start(k), start(k + 1) - start(k), 1)
            };
            BatchUniform {
                pixel_begin: p0,
                pixel_count: count,
                sample_begin: j0,
                samples,
                paths_per_sample: n,
                path_count: count * per_pixel,
                capacity: plan.capacity,
                shadow_rays: plan.shadow_rays,
                zero: 0,
                // The runner's: it knows its queue layout (Control::shard_slots).
                shard_slots: 0,
                pixel_stride: stride,
                _pad: [0; 1],
            }
        })
        .collect()
}

/// Renders `plan.total_spp` samples per pixel in rounds of batches run by `runner`.
///
/// Without a time limit, rounds overlap: the next round's first batch is submitted while
/// the last ones of the round before still run, so the device does not idle at a round's
/// end while the host reads back, commits and records. Its size then comes from the last
/// round already finished, one round behind. A time limit keeps rounds apart, so that the
/// decision to start one is taken with the time they really took.
pub(crate) fn run_rounds<R: BatchRunner>(
    runner: &mut R,
    plan: &Plan,
    opts: &PassOptions,
) -> Result<Accumulated, GpuError> {
    let Plan { width, height, total_spp, .. } = *plan;
    if width == 0 || height == 0 || total_spp == 0 {
        return Err(GpuError::Validation(format!(
            "render of {width}×{height} pixels at {total_spp} spp: all must be positive"
        )));
    }
    if plan.paths_per_sample > plan.capacity || plan.paths_per_sample > MAX_PATHS_PER_PIXEL_PER_ROUND {
        // `wavefront::capacity` refuses such plans with their reason first.
        return Err(GpuError::Internal(format!(
            "{} paths per camera sample exceed what one GPU batch sums ({} path slots, at most {} paths per pixel)",
            plan.paths_per_sample, plan.capacity, MAX_PATHS_PER_PIXEL_PER_ROUND
        )));
    }
    let start = Instant::now();
    let max_spp = opts.max_spp_per_pass.clamp(1, MAX_SPP_PER_ROUND);
    let acc = Accumulator::new(width, height).map_err(|e| GpuError::OutOfMemory(format!("host memory: {e}")))?;
    let progress = progress_bar(opts.progress, u64::from(total_spp) * u64::from(width) * u64::from(height));
    let cancelled = || opts.cancel.as_ref().is_some_and(|c| c.load(Ordering::SeqCst));
    // A round never leaves slots idle that more samples could fill: a batch makes the same
    // launches however many slots are in use, and launches have a fixed cost (a 1-spp
    // round of skybox.sl at 160 px kept 17 k of 131 k slots busy; filling them made its
    // 16-spp render 1.5× faster on lavapipe), so rounds start at, and never drop below, the
    // samples that fill one batch. Only a time limit, which must be overshot by at most a
    // one-sample round, keeps the first round at `initial_spp_per_pass` and lets later
    // ones shrink below that.
    let fill = full_batch_samples(plan).min(max_spp);
    let overlap = opts.time_limit.is_none();
    let first = if overlap { opts.initial_spp_per_pass.max(fill) } else { opts.initial_spp_per_pass };
    let mut spp_per_round = first.clamp(1, max_spp);
    let mut flight = InFlight::new(runner, acc, progress, total_spp);
    // Samples per pixel of the rounds submitted so far.
    let mut submitted = 0u32;
    let mut rounds = 0u32;
    let mut stop = StopReason::Completed;
    // Batches submitted ahead of the one collected: one for a device alone (its two film
    // slots alternate); one per device where several share the batches, so that a device
    // finishing before the batch the host waits for finds the next one queued.
    let ahead = plan.devices.max(1) as usize;

    'rounds: while submitted < total_spp {
        let samples = round_samples(plan, spp_per_round.min(total_spp - submitted));
        rounds += 1;
        let list = batches(plan, plan.sample_begin + submitted, samples);
        let begun = Instant::now();
        for (k, batch) in list.iter().enumerate() {
            // The round's last batch carries when the round began: its collection commits it.
            let end = (k + 1 == list.len()).then_some(begun);
            flight.submit(batch, rounds, end)?;
            flight.collect_beyond(ahead)?;
            if cancelled() {
                // Rounds before this one were all submitted: keep them; drop this one.
                flight.collect_rounds_before(rounds)?;
                flight.runner.drain()?;
                flight.acc.discard_round();
                stop = StopReason::Interrupted;
                break 'rounds;
            }
        }
        submitted += samples;
        // Every round submitted is whole: collecting its batches commits it.
        let interrupted = submitted < total_spp && cancelled();
        if !overlap || submitted == total_spp || interrupted {
            flight.collect_beyond(0)?;
        }
        if interrupted {
            stop = StopReason::Interrupted;
            break;
        }
        let remaining = match opts.time_limit {
            Some(limit) => {
                let elapsed = start.elapsed();
                if elapsed >= limit {
                    if submitted < total_spp {
                        stop = StopReason::TimeLimit;
                    }
                    break;
                }
                Some((limit - elapsed).as_secs_f64())
            }
            None => None,
        };
        // Without a finished round yet (overlapping rounds), only the growth cap applies.
        let per_sample = flight.per_sample.unwrap_or(0.0);
        spp_per_round = next_spp_per_pass(
            samples,
            per_sample,
            per_sample,
            remaining,
            opts.target_pass_seconds,
            RoundBounds { floor: fill, max: max_spp },
        );
    }
    let InFlight { acc, progress, batches, .. } = flight;
    progress.finish_and_clear();
    Ok(Accumulated {
        image: acc.mean_image(),
        spp_done: acc.spp() as u32,
        rounds,
        batches,
        stop,
        nonfinite: acc.nonfinite(),
    })
}

/// The batches in flight, oldest first, and what their collection feeds: the image, the
/// progress bar, and the rate of the last finished round.
struct InFlight<'r, R: BatchRunner> {
    runner: &'r mut R,
    acc: Accumulator,
    progress: ProgressBar,
    /// Each batch's pending read-back, its uniform, its round (counted from 1) and, on a
    /// round's last batch, when its round's first batch was submitted.
    pending: VecDeque<(R::Pending, BatchUniform, u32, Option<Instant>)>,
    /// Batches submitted (the film slot of the next one alternates with it).
    batches: u64,
    total_spp: u32,
    /// When the last round was committed, or the rounds began.
    last_commit: Instant,
    /// Seconds per sample per pixel of the last finished round.
    per_sample: Option<f64>,
}

impl<'r, R: BatchRunner> InFlight<'r, R> {
    fn new(runner: &'r mut R, acc: Accumulator, progress: ProgressBar, total_spp: u32) -> Self {
        let (pending, last_commit) = (VecDeque::new(), Instant::now());
        Self { runner, acc, progress, pending, batches: 0, total_spp, last_commit, per_sample: None }
    }

    fn submit(&mut self, batch: &BatchUniform, round: u32, end: Option<Instant>) -> Result<(), GpuError> {
        // With one device at most two batches are in flight, so slot k % 2 is free again.
        let pending = self.runner.submit(batch, (self.batches % 2) as usize)?;
        self.batches += 1;
        self.pending.push_back((pending, *batch, round, end));
        Ok(())
    }

    /// Collects the oldest batches until at most `ahead` remain in flight.
    fn collect_beyond(&mut self, ahead: usize) -> Result<(), GpuError> {
        while self.pending.len() > ahead {
            self.collect_oldest()?;
        }
        Ok(())
    }

    /// Collects every batch of the rounds before `round`.
    fn collect_rounds_before(&mut self, round: u32) -> Result<(), GpuError> {
        while self.pending.front().is_some_and(|p| p.2 < round) {
            self.collect_oldest()?;
        }
        Ok(())
    }

    /// Adds the oldest batch's sums to the round; its last batch commits the round.
    fn collect_oldest(&mut self) -> Result<(), GpuError> {
        let Some((pending, b, _, end)) = self.pending.pop_front() else { return Ok(()) };
        let sums = self.runner.collect(pending)?;
        self.acc.add_pixels(b.pixel_begin as usize, b.pixel_stride as usize, &sums[..b.pixel_count as usize]);
        self.progress.inc(u64::from(b.pixel_count) * u64::from(b.samples));
        if let Some(begun) = end {
            // Every batch of a round has its samples per pixel.
            let samples = b.samples;
            self.acc.commit_round(samples);
            let now = Instant::now();
            // The round ran from its first submission or the last commit, whichever was
            // later (with overlapping rounds, the device was busy with the one before).
            let per_sample = (now - begun.max(self.last_commit)).as_secs_f64() / f64::from(samples);
            self.last_commit = now;
            self.per_sample = Some(per_sample);
            let done = self.acc.spp() as u32;
            self.progress.set_message(format!("{done}/{} spp, {samples} spp/round", self.total_spp));
            self.runner.seconds_left(per_sample * f64::from(self.total_spp.saturating_sub(done)));
        }
        Ok(())
    }
}

/// Camera samples per pixel that fill one batch's path slots on each device when the whole
/// image shares them (at least 1; images with more pixels than slots need several batches
/// per sample).
fn full_batch_samples(plan: &Plan) -> u32 {
    let paths_per_spp = u64::from(plan.width) * u64::from(plan.height) * u64::from(plan.paths_per_sample.max(1));
    let fill = u64::from(plan.capacity) * u64::from(plan.devices.max(1)) / paths_per_spp.max(1);
    round_samples(plan, u32::try_from(fill).unwrap_or(u32::MAX))
}

/// Limits on a round's samples per pixel: `floor` (one full batch) unless a time limit
/// leaves time for fewer, and `max`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct RoundBounds {
    pub floor: u32,
    pub max: u32,
}

/// Samples for the next round, from the last round's timings (seconds per sample per pixel
/// of the slowest part and of the whole round; one and the same for whole-image rounds):
/// a round should take about `target` seconds, growth is at most ×2 per round (timings of
/// tiny rounds are noisy) and it fills at least `bounds.floor`, and with a time limit the
/// whole round should fit in the time left (so the limit is overshot by at most a
/// one-sample round).
pub(crate) fn next_spp_per_pass(
    current: u32,
    worst_seconds_per_sample: f64,
    round_seconds_per_sample: f64,
    remaining_seconds: Option<f64>,
    target: f64,
    bounds: RoundBounds,
) -> u32 {
    let by_target = if worst_seconds_per_sample > 0.0 { target / worst_seconds_per_sample } else { f64::INFINITY };
    let mut spp = by_target.min(f64::from(current.saturating_mul(2))).max(f64::from(bounds.floor));
    if let Some(rem) = remaining_seconds {
        if round_seconds_per_sample > 0.0 {
            spp = spp.min(rem / round_seconds_per_sample);
        }
    }
    (spp.floor() as u32).clamp(1, bounds.max.max(1))
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spp_grows_at_most_twice_and_meets_the_target() {
        let b = RoundBounds { floor: 1, max: 64 };
        // A round of 1 spp took 1 ms: 25 would meet 25 ms but growth is capped at ×2.
        assert_eq!(next_spp_per_pass(1, 0.001, 0.004, None, 0.025, b), 2);
        assert_eq!(next_spp_per_pass(16, 0.001, 0.004, None, 0.025, b), 25);
        // Too slow: shrink, but never below 1.
        assert_eq!(next_spp_per_pass(8, 0.010, 0.04, None, 0.025, b), 2);
        assert_eq!(next_spp_per_pass(8, 1.0, 4.0, None, 0.025, b), 1);
        // The f32 bound.
        assert_eq!(next_spp_per_pass(64, 1e-9, 1e-8, None, 0.025, b), 64);
        // Time left for 3 samples per pixel over the whole image.
        assert_eq!(next_spp_per_pass(32, 1e-4, 0.1, Some(0.35), 0.025, b), 3);
    }

    #[test]
    fn rounds_fill_a_batch_unless_the_time_limit_says_fewer() {
        let b = RoundBounds { floor: 7, max: 64 };
        // Too slow for the target, or growth capped below the floor: still a full batch.
        assert_eq!(next_spp_per_pass(8, 1.0, 4.0, None, 0.025, b), 7);
        assert_eq!(next_spp_per_pass(2, 0.001, 0.004, None, 0.025, b), 7);
        // The time left wins over the floor.
        assert_eq!(next_spp_per_pass(8, 1e-4, 0.1, Some(0.35), 0.025, b), 3);
        // The floor of a plan: slots over paths per sample of the whole image, at least 1,
        // within the film's and one pixel's bounds.
        assert_eq!(full_batch_samples(&plan(5, 3, 2, 64)), 2);
        assert_eq!(full_batch_samples(&plan(5, 3, 1, 1 << 17)), 8738);
        assert_eq!(full_batch_samples(&plan(1000, 1000, 1, 1 << 17)), 1);
        assert_eq!(full_batch_samples(&plan(4, 4, 10, 25)), 1);
    }

    #[test]
    fn the_first_round_fills_the_slots_without_a_time_limit() {
        // 15 pixels, 2 paths per sample, 64 slots: 2 samples fill a batch (60 paths).
        let mut fake = Fake::new(None);
        let p = Plan { total_spp: 9, ..plan(5, 3, 2, 64) };
        run_rounds(&mut fake, &p, &PassOptions::default()).unwrap();
        assert_eq!((fake.submitted[0].samples, fake.submitted[0].path_count), (2, 60));
        assert!(fake.submitted.iter().all(|b| b.samples >= 1 && b.path_count <= 64));
        // With a time limit the first round is `initial_spp_per_pass`.
        let mut fake = Fake::new(None);
        let opts = PassOptions { time_limit: Some(Duration::from_secs(3600)), ..PassOptions::default() };
        run_rounds(&mut fake, &p, &opts).unwrap();
        assert_eq!(fake.submitted[0].samples, 1);
    }

    fn plan(width: u32, height: u32, n: u32, capacity: u32) -> Plan {
        Plan {
            width,
            height,
            sample_begin: 0,
            total_spp: 64,
            paths_per_sample: n,
            capacity,
            shadow_rays: 1,
            devices: 1,
        }
    }

    #[test]
    fn batches_hold_whole_pixels_cover_each_once_and_fit_the_slots() {
        for (w, h, n, cap, samples) in [(1, 1, 1, 1, 1), (7, 5, 3, 64, 4), (300, 200, 1, 65_536, 64), (9, 9, 10, 25, 2)]
        {
            for devices in [1, 2, 3] {
                let p = Plan { devices, ..plan(w, h, n, cap) };
                let s = round_samples(&p, samples);
                let mut covered = vec![0u32; (w * h) as usize];
                let all = batches(&p, 5, s);
                for b in &all {
                    for i in 0..b.pixel_count {
                        covered[(b.pixel_begin + i * b.pixel_stride) as usize] += 1;
                    }
                    // One device: runs of pixels; several: batch k of B every B-th from k.
                    let (k, count) = (all.iter().position(|x| x == b).unwrap() as u32, all.len() as u32);
                    if devices == 1 {
                        assert_eq!(b.pixel_stride, 1);
                    } else {
                        assert_eq!((b.pixel_begin, b.pixel_stride), (k, count));
                    }
                    assert!(b.path_count <= cap && b.path_count == b.pixel_count * s * n);
                    assert_eq!((b.sample_begin, b.samples, b.capacity), (5, s, cap));
                }
                assert!(covered.iter().all(|&c| c == 1), "every pixel in one batch");
                // The fewest batches that fit, in a multiple of the devices where the
                // pixels allow, each within one pixel of the others.
                let fewest = (w * h).div_ceil((cap / (s * n)).max(1));
                let count = all.len() as u32;
                assert!(count >= fewest && count < fewest + devices, "{count} batches for {devices} devices");
                assert!(count % devices == 0 || count == w * h, "{count} batches for {devices} devices");
                let sizes = all.iter().map(|b| b.pixel_count);
                assert!(sizes.clone().max().unwrap() - sizes.min().unwrap() <= 1);
            }
        }
        // Fewer slots than a pixel's paths: the round shrinks to what one pixel fits.
        assert_eq!(round_samples(&plan(4, 4, 10, 25), 8), 2);
        assert_eq!(round_samples(&plan(4, 4, 1000, 1 << 20), 64), 16);
    }

    /// A runner that sums known per-path values the way the film stage does, to check the
    /// host's bookkeeping (uniform spp, cancellation, time limit) without a device.
    struct Fake {
        submitted: Vec<BatchUniform>,
        cancel_after: Option<(usize, Arc<AtomicBool>)>,
        /// Batches submitted and not yet collected: now, and the most at once.
        in_flight: (usize, usize),
        /// Submissions (true) and collections, with the batch's first camera sample.
        log: Vec<(bool, u32)>,
    }

    impl Fake {
        fn new(cancel_after: Option<(usize, Arc<AtomicBool>)>) -> Self {
            Self { submitted: vec![], cancel_after, in_flight: (0, 0), log: vec![] }
        }

        /// Whether some round's first batch went in before the round before it was all
        /// collected.
        fn rounds_overlapped(&self) -> bool {
            self.log
                .iter()
                .enumerate()
                .any(|(i, &(submit, j0))| submit && self.log[i..].iter().any(|&(s, j)| !s && j < j0))
        }
    }

    impl BatchRunner for Fake {
        type Pending = BatchUniform;
        fn submit(&mut self, batch: &BatchUniform, _slot: usize) -> Result<BatchUniform, GpuError> {
            self.submitted.push(*batch);
            self.log.push((true, batch.sample_begin));
            self.in_flight.0 += 1;
            self.in_flight.1 = self.in_flight.1.max(self.in_flight.0);
            if let Some((k, flag)) = &self.cancel_after {
                if self.submitted.len() == *k {
                    flag.store(true, Ordering::SeqCst);
                }
            }
            Ok(*batch)
        }
        fn collect(&mut self, b: BatchUniform) -> Result<Vec<[f64; 3]>, GpuError> {
            self.in_flight.0 -= 1;
            self.log.push((false, b.sample_begin));
            // Sample j of pixel p is worth p + j: the round's sum is exact in f32.
            Ok((0..b.pixel_count)
                .map(|i| {
                    let p = f64::from(b.pixel_begin + i * b.pixel_stride);
                    let s: f64 = (b.sample_begin..b.sample_begin + b.samples).map(|j| p + f64::from(j)).sum();
                    [s, 0.0, 0.0]
                })
                .collect())
        }
        fn drain(&mut self) -> Result<(), GpuError> {
            Ok(())
        }
    }

    #[test]
    fn rounds_give_every_pixel_the_mean_of_its_samples() {
        let mut fake = Fake::new(None);
        let p = Plan { total_spp: 10, ..plan(5, 3, 2, 8) };
        let out =
            run_rounds(&mut fake, &p, &PassOptions { target_pass_seconds: f64::MAX, ..Default::default() }).unwrap();
        assert_eq!((out.spp_done, out.stop), (10, StopReason::Completed));
        for (i, px) in out.image.pixels().iter().enumerate() {
            assert_eq!(px.r, i as f32 + 4.5, "pixel {i}: mean of p + j over j < 10");
        }
    }

    /// Without a time limit a round's first batch is submitted before the last batch of
    /// the round before is collected (the device never drains at a round's end), and the
    /// image is still every pixel's mean over whole rounds; with a time limit rounds stay
    /// apart.
    #[test]
    fn rounds_overlap_unless_a_time_limit_is_set() {
        let p = Plan { total_spp: 10, ..plan(5, 3, 2, 8) };
        let opts = PassOptions { target_pass_seconds: f64::MAX, max_spp_per_pass: 3, ..Default::default() };
        let mut fake = Fake::new(None);
        let out = run_rounds(&mut fake, &p, &opts).unwrap();
        assert!(fake.rounds_overlapped());
        // Rounds of 1, 2, 3, 3 and 1 samples (one pixel's 2·3 paths fit the 8 slots).
        assert_eq!((out.spp_done, out.rounds, fake.in_flight), (10, 5, (0, 2)));
        for (i, px) in out.image.pixels().iter().enumerate() {
            assert_eq!(px.r, i as f32 + 4.5, "pixel {i}");
        }
        let mut fake = Fake::new(None);
        let limited = PassOptions { time_limit: Some(Duration::from_secs(3600)), ..opts };
        let out = run_rounds(&mut fake, &p, &limited).unwrap();
        assert!(!fake.rounds_overlapped());
        assert_eq!(out.spp_done, 10);
    }

    /// Ctrl-C during a round keeps the rounds before it, even those whose last batches were
    /// still in flight when it came, and drops the rest.
    #[test]
    fn cancel_keeps_the_rounds_submitted_before_it() {
        let flag = Arc::new(AtomicBool::new(false));
        // Three slots, one sample per round: 15 pixels in 6 batches per round (an even
        // number for two devices); two devices keep two batches ahead, so the cancel at
        // round 2's first batch finds round 1's last batch uncollected.
        let mut fake = Fake::new(Some((7, flag.clone())));
        let p = Plan { devices: 2, ..plan(5, 3, 1, 3) };
        let opts = PassOptions { cancel: Some(flag), max_spp_per_pass: 1, ..PassOptions::default() };
        let out = run_rounds(&mut fake, &p, &opts).unwrap();
        assert_eq!((out.spp_done, out.stop, out.rounds), (1, StopReason::Interrupted, 2));
        assert!(out.image.pixels().iter().enumerate().all(|(i, px)| px.r == i as f32));
    }

    /// Shared by two devices, rounds come in even numbers of batches, one more batch is
    /// kept in flight (three: one running on each device, one waiting), and the image is
    /// the same as with one device (two in flight: its two film slots).
    #[test]
    fn two_devices_keep_three_batches_in_flight_and_the_same_image() {
        let opts = PassOptions { target_pass_seconds: f64::MAX, max_spp_per_pass: 3, ..Default::default() };
        let mut images = Vec::new();
        for devices in [1, 2] {
            let mut fake = Fake::new(None);
            let p = Plan { total_spp: 10, devices, ..plan(5, 3, 2, 8) };
            let out = run_rounds(&mut fake, &p, &opts).unwrap();
            assert_eq!((out.spp_done, fake.in_flight), (10, (0, devices as usize + 1)));
            let per_round = fake.submitted.iter().filter(|b| b.sample_begin == 0).count();
            assert_eq!(per_round % devices as usize, 0, "{per_round} batches per round");
            images.push(out.image.pixels().iter().map(|px| px.r).collect::<Vec<_>>());
        }
        assert_eq!(images[0], images[1]);
    }

    #[test]
    fn cancel_drops_the_unfinished_round() {
        let flag = Arc::new(AtomicBool::new(false));
        // Batches of 4 pixels at 1 spp: the first round has 4 batches; cancel in round 2.
        let mut fake = Fake::new(Some((6, flag.clone())));
        let opts =
            PassOptions { cancel: Some(flag), initial_spp_per_pass: 1, max_spp_per_pass: 1, ..PassOptions::default() };
        let out = run_rounds(&mut fake, &plan(4, 4, 1, 4), &opts).unwrap();
        assert_eq!((out.spp_done, out.stop, out.rounds), (1, StopReason::Interrupted, 2));
        assert!(out.image.pixels().iter().enumerate().all(|(i, px)| px.r == i as f32));
    }

    #[test]
    fn a_time_limit_stops_between_rounds_with_uniform_spp() {
        let mut fake = Fake::new(None);
        let opts = PassOptions { time_limit: Some(Duration::ZERO), ..PassOptions::default() };
        let out = run_rounds(&mut fake, &plan(3, 3, 1, 1024), &opts).unwrap();
        assert_eq!((out.spp_done, out.stop), (1, StopReason::TimeLimit));
    }
}
