//! A render's batches shared with a *twin*: a second device on the same software adapter.
//!
//! On llvmpipe a queue submission runs its launches on the submitting thread before it
//! returns, one launch after another, and between launches (and in a launch's last few
//! workgroups, and in the small launches of deep bounces) the driver's worker threads wait.
//! On the 2-core machine a render left a quarter of the cores idle that way (skybox.sl:
//! 1.47 cores busy; spheres_10k.sl 1.78). A twin (`Gpu::twin`, a device of its own with
//! its own queue and workers) fills those gaps with another batch: two processes rendering
//! half the samples each finished glass.sl 1.35–1.5× sooner than one process rendering
//! all of them (DESIGN.md "Twin devices", BENCHMARKS.md).
//!
//! Each device runs whole batches on a thread of its own, taking them in order from one
//! list; the host adds each batch's sums into the round as before. When each device has at
//! most half the cores ([`devices_split_cores`]: `lumen` gives llvmpipe `LP_NUM_THREADS` =
//! cores / 2), the two devices together use the cores once, without the waits of one
//! device's threads between launches, and the twin starts with the first round
//! ([`TwinStart::AtOnce`]). Otherwise both devices' threads share the cores, and the twin's
//! start (opening it and creating its kernels, about a quarter of a second of both cores)
//! ate the gain of short renders, so it starts only once a round's timing says at least
//! [`TWIN_MIN_SECONDS`] of batches are left ([`TwinStart::AfterTiming`]). Batches hold whole
//! pixels and both devices run the same kernels on the same driver, so a pixel's value does
//! not depend on which device rendered it: the image is bitwise the one a single device
//! makes.

use std::collections::HashMap;
use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::Mutex;

use super::contract::BatchUniform;
use super::schedule::BatchRunner;
use crate::gpu::device::GpuError;

/// A batch to run: its place in submission order, and the batch.
type Job = (u64, BatchUniform);
/// A run batch's per-pixel sums, with its place in submission order.
type Done = (u64, Result<Vec<[f64; 3]>, GpuError>);

/// Seconds of batches that must be left for the twin to start (its start-up costs about
/// 0.25 s of both cores on the 2-core machine; it then saves up to a third of what is left).
pub const TWIN_MIN_SECONDS: f64 = 1.5;

/// When a render's twin starts (`gpu::render`'s rule, from [`devices_split_cores`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum TwinStart {
    /// With the first round: each device has half the cores or less.
    AtOnce,
    /// Once a round's timing leaves [`TWIN_MIN_SECONDS`] or more to render.
    AfterTiming,
}

/// The variable llvmpipe reads when a device is created: its number of worker threads
/// (unset: one per core; 0: none, the submitting thread runs the launches).
pub const THREADS_ENV: &str = "LP_NUM_THREADS";

/// Whether two llvmpipe devices, each with the threads `threads` ([`THREADS_ENV`]'s value)
/// asks for, fit in `cores` without sharing one: then a twin costs the render no core time
/// its own device would have used, and starts with the first round. On the 2-core Zen 3 VM
/// two single-threaded devices from the first round rendered `lumen bench`'s example scenes
/// 1.0-1.9x as fast as one two-threaded device (BENCHMARKS.md "Two single-threaded
/// devices").
///
/// ```
/// use lumen::gpu::wavefront::devices_split_cores;
/// assert!(devices_split_cores(Some("1"), 2));
/// assert!(!devices_split_cores(None, 2)); // llvmpipe's default: a thread per core
/// assert!(!devices_split_cores(Some("2"), 2));
/// assert!(devices_split_cores(Some("0"), 2)); // no worker: the submitting thread
/// assert!(devices_split_cores(None, 128)); // Mesa's 32 threads at most
/// ```
pub fn devices_split_cores(threads: Option<&str>, cores: usize) -> bool {
    threads_split_cores(super::llvmpipe_threads(threads, cores), cores)
}

/// Whether two devices of `per_device` threads fit in `cores` without sharing one.
fn threads_split_cores(per_device: u32, cores: usize) -> bool {
    cores >= 2 && 2 * per_device as usize <= cores
}

/// [`devices_split_cores`] for this process's environment and cores.
pub(crate) fn this_process_splits_cores() -> bool {
    let (per_device, cores) = super::this_process_llvmpipe();
    threads_split_cores(per_device, cores)
}

/// The list of batches both devices take from, and where they put their sums.
pub(crate) struct Feed {
    jobs: Mutex<Receiver<Job>>,
    done: Sender<Done>,
    start: Mutex<Receiver<()>>,
    ready: Sender<bool>,
    /// Told when the twin takes its first batch, or cannot take any.
    twin_took: Sender<()>,
    twin_took_rx: Mutex<Receiver<()>>,
}

impl Feed {
    /// The twin says it is set up and about to take batches (true) or could not be set up
    /// (false).
    pub fn ready(&self, ok: bool) {
        if !ok {
            let _ = self.twin_took.send(());
        }
        let _ = self.ready.send(ok);
    }

    /// Waits until the twin has taken its first batch (or cannot take any): a device that
    /// serves only after this leaves the first batch to the twin, so that a short render
    /// with `TwinUse::Always` (the twin's tests) always gives the twin some batches, however
    /// the threads are scheduled.
    pub fn wait_until_twin_serves(&self) {
        if let Ok(took) = self.twin_took_rx.lock() {
            let _ = took.recv();
        }
    }

    /// Waits until the host starts the twin (true) or ends the render without it (false).
    pub fn started(&self) -> bool {
        self.start.lock().is_ok_and(|start| start.recv().is_ok())
    }

    /// Runs batches from the list on `runner` (each submitted and collected in turn: the
    /// submission runs it anyway) until the list is closed or the host stops listening;
    /// how many it ran.
    pub fn serve<R: BatchRunner>(&self, runner: &mut R) -> u64 {
        self.serve_as(runner, false)
    }

    /// [`Self::serve`] for the twin, which says when it takes its first batch
    /// ([`Self::wait_until_twin_serves`]).
    pub fn serve_as_twin<R: BatchRunner>(&self, runner: &mut R) -> u64 {
        self.serve_as(runner, true)
    }

    fn serve_as<R: BatchRunner>(&self, runner: &mut R, twin: bool) -> u64 {
        let served = self.serve_loop(runner, twin);
        if twin && served == 0 {
            // The list closed before the twin took anything: nobody waits for it any more.
            let _ = self.twin_took.send(());
        }
        served
    }

    fn serve_loop<R: BatchRunner>(&self, runner: &mut R, twin: bool) -> u64 {
        let mut served = 0;
        loop {
            // One device waits on the list, the other on the lock: the same thing.
            let job = match self.jobs.lock() {
                Ok(jobs) => jobs.recv(),
                Err(_) => return served,
            };
            let Ok((index, batch)) = job else { return served };
            if twin && served == 0 {
                let _ = self.twin_took.send(());
            }
            // A panic becomes the batch's error: the host waits for every batch it
            // submitted, so a batch must never go unanswered. The device then stops serving.
            let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                runner.submit(&batch, 0).and_then(|pending| runner.collect(pending))
            }));
            let panicked = run.is_err();
            let sums = run.unwrap_or_else(|_| Err(GpuError::Internal("a device panicked running a batch".into())));
            served += 1;
            if self.done.send((index, sums)).is_err() || panicked {
                return served;
            }
        }
    }
}

/// The host's side: a [`BatchRunner`] whose batches the serving devices run.
pub(crate) struct Shared {
    jobs: Option<Sender<Job>>,
    /// Starts the twin; `None` once sent or closed.
    start: Option<Sender<()>>,
    ready: Receiver<bool>,
    done: Receiver<Done>,
    /// Sums that came back before the host asked for them.
    early: HashMap<u64, Result<Vec<[f64; 3]>, GpuError>>,
    next: u64,
    in_flight: usize,
}

/// A new list of batches: the host's end and the devices' end.
pub(crate) fn shared() -> (Shared, Feed) {
    let (jobs_tx, jobs_rx) = channel();
    let (done_tx, done_rx) = channel();
    let (start_tx, start_rx) = channel();
    let (ready_tx, ready_rx) = channel();
    let (took_tx, took_rx) = channel();
    let host = Shared {
        jobs: Some(jobs_tx),
        start: Some(start_tx),
        ready: ready_rx,
        done: done_rx,
        early: HashMap::new(),
        next: 0,
        in_flight: 0,
    };
    let feed = Feed {
        jobs: Mutex::new(jobs_rx),
        done: done_tx,
        start: Mutex::new(start_rx),
        ready: ready_tx,
        twin_took: took_tx,
        twin_took_rx: Mutex::new(took_rx),
    };
    (host, feed)
}

impl Shared {
    /// Ends the list: each device finishes the batch it runs, then returns from `serve`; a
    /// twin not started by then never starts.
    pub fn close(&mut self) {
        self.jobs = None;
        self.start = None;
    }

    /// Waits until a started twin is set up or has failed to be (whether it is set up).
    pub fn wait_for_twin(&self) -> bool {
        self.ready.recv().unwrap_or(false)
    }

    /// Starts the twin now (it begins taking batches once set up).
    pub fn start_twin(&mut self) {
        if let Some(start) = self.start.take() {
            let _ = start.send(());
        }
    }

    fn lost() -> GpuError {
        GpuError::Internal("every device serving the render's batches has stopped".into())
    }
}

impl BatchRunner for Shared {
    type Pending = u64;

    fn submit(&mut self, batch: &BatchUniform, _slot: usize) -> Result<u64, GpuError> {
        let index = self.next;
        self.jobs.as_ref().ok_or_else(Self::lost)?.send((index, *batch)).map_err(|_| Self::lost())?;
        self.next += 1;
        self.in_flight += 1;
        Ok(index)
    }

    fn collect(&mut self, index: u64) -> Result<Vec<[f64; 3]>, GpuError> {
        loop {
            if let Some(sums) = self.early.remove(&index) {
                self.in_flight -= 1;
                return sums;
            }
            let (k, sums) = self.done.recv().map_err(|_| Self::lost())?;
            self.early.insert(k, sums);
        }
    }

    fn drain(&mut self) -> Result<(), GpuError> {
        while self.early.len() < self.in_flight {
            let (k, sums) = self.done.recv().map_err(|_| Self::lost())?;
            self.early.insert(k, sums);
        }
        Ok(())
    }

    fn seconds_left(&mut self, seconds: f64) {
        if seconds >= TWIN_MIN_SECONDS {
            self.start_twin();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A runner that "renders" a batch as its first pixel index, after a delay that makes
    /// later batches finish first.
    struct Fake {
        delay_ms: u64,
    }

    impl BatchRunner for Fake {
        type Pending = BatchUniform;
        fn submit(&mut self, batch: &BatchUniform, _slot: usize) -> Result<BatchUniform, GpuError> {
            Ok(*batch)
        }
        fn collect(&mut self, b: BatchUniform) -> Result<Vec<[f64; 3]>, GpuError> {
            std::thread::sleep(std::time::Duration::from_millis(self.delay_ms));
            Ok(vec![[f64::from(b.pixel_begin); 3]; b.pixel_count as usize])
        }
        fn drain(&mut self) -> Result<(), GpuError> {
            Ok(())
        }
    }

    fn batch(p0: u32) -> BatchUniform {
        BatchUniform { pixel_begin: p0, pixel_count: 2, ..bytemuck::Zeroable::zeroed() }
    }

    /// Sums come back to the batch they belong to, whichever device ran it and in whatever
    /// order the devices finish; a closed list ends both devices' service.
    #[test]
    fn sums_return_to_their_batch_whichever_device_ran_it() {
        let (mut host, feed) = shared();
        std::thread::scope(|s| {
            let feed = &feed;
            let slow = s.spawn(move || feed.serve(&mut Fake { delay_ms: 30 }));
            let twin = s.spawn(move || if feed.started() { feed.serve(&mut Fake { delay_ms: 1 }) } else { 0 });
            // Not enough left: the twin waits; then enough.
            host.seconds_left(TWIN_MIN_SECONDS / 2.0);
            host.seconds_left(TWIN_MIN_SECONDS);
            let pending: Vec<u64> = (0..6).map(|k| host.submit(&batch(10 * k), 0).unwrap()).collect();
            // Collected in reverse: the early ones wait in `early`.
            for (k, p) in pending.into_iter().enumerate().rev() {
                assert_eq!(host.collect(p).unwrap(), vec![[10.0 * k as f64; 3]; 2]);
            }
            let p = host.submit(&batch(70), 0).unwrap();
            host.drain().unwrap();
            assert_eq!(host.collect(p).unwrap()[0][0], 70.0);
            host.close();
            let (slow, twin) = (slow.join().unwrap(), twin.join().unwrap());
            assert_eq!(slow + twin, 7);
            assert!(twin > 0, "the fast twin took none of 7 batches");
        });
    }

    /// A device that waits until the twin serves leaves it the first batch, however late
    /// the twin comes; one whose twin could not be set up serves everything.
    #[test]
    fn waiting_for_the_twin_gives_it_the_first_batch() {
        for twin_ok in [true, false] {
            let (mut host, feed) = shared();
            std::thread::scope(|s| {
                let feed = &feed;
                let this = s.spawn(move || {
                    feed.wait_until_twin_serves();
                    feed.serve(&mut Fake { delay_ms: 0 })
                });
                let twin = s.spawn(move || {
                    std::thread::sleep(std::time::Duration::from_millis(50));
                    feed.ready(twin_ok);
                    if twin_ok {
                        feed.serve_as_twin(&mut Fake { delay_ms: 0 })
                    } else {
                        0
                    }
                });
                let pending: Vec<u64> = (0..5).map(|k| host.submit(&batch(k), 0).unwrap()).collect();
                for p in pending {
                    host.collect(p).unwrap();
                }
                host.close();
                let (this, twin) = (this.join().unwrap(), twin.join().unwrap());
                assert_eq!(this + twin, 5);
                assert_eq!(twin > 0, twin_ok, "{this} {twin}");
            });
        }
    }

    /// A twin never started returns when the host closes the list, having run nothing.
    #[test]
    fn a_twin_not_started_never_serves() {
        let (mut host, feed) = shared();
        std::thread::scope(|s| {
            let feed = &feed;
            let this = s.spawn(move || feed.serve(&mut Fake { delay_ms: 1 }));
            let twin = s.spawn(move || feed.started());
            host.seconds_left(TWIN_MIN_SECONDS / 2.0);
            let p = host.submit(&batch(0), 0).unwrap();
            host.collect(p).unwrap();
            host.close();
            assert_eq!((this.join().unwrap(), twin.join().unwrap()), (1, false));
        });
    }

    /// A device that panics on a batch answers it with an error (the host would otherwise
    /// wait for it for ever) and stops serving.
    #[test]
    fn a_panic_answers_the_batch_with_an_error() {
        struct Panics;
        impl BatchRunner for Panics {
            type Pending = ();
            fn submit(&mut self, _: &BatchUniform, _: usize) -> Result<(), GpuError> {
                panic!("injected");
            }
            fn collect(&mut self, _: ()) -> Result<Vec<[f64; 3]>, GpuError> {
                Ok(vec![])
            }
            fn drain(&mut self) -> Result<(), GpuError> {
                Ok(())
            }
        }
        let (mut host, feed) = shared();
        std::thread::scope(|s| {
            let feed = &feed;
            let device = s.spawn(move || feed.serve(&mut Panics));
            let p = host.submit(&batch(0), 0).unwrap();
            assert!(host.collect(p).is_err());
            assert_eq!(device.join().unwrap(), 1);
            host.close();
        });
    }

    /// With nobody serving, the host gets an error instead of waiting for ever.
    #[test]
    fn a_list_nobody_serves_is_an_error() {
        let (mut host, feed) = shared();
        drop(feed);
        let p = host.submit(&batch(0), 0);
        assert!(p.is_err() || host.collect(p.unwrap()).is_err());
    }
}
