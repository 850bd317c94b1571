//! Device time per stage, from timestamps written around every launch, and the device's
//! busy fraction: the launches' summed device time over the wall time of the rounds.
//!
//! Where to look first when a scene is slow, and how well the host keeps the device fed
//! (issue 12 asks for the busy fraction on hardware GPUs). It needs the adapter's
//! `TIMESTAMP_QUERY` and `TIMESTAMP_QUERY_INSIDE_PASSES` (lavapipe and the big desktop
//! drivers have both); without them a profiled render says so and renders unprofiled.
//!
//! No extra waiting: a batch's timestamps go to the query set of its film slot, are resolved
//! in the batch's last submission and read back with its film, which the host waits for
//! anyway; the other slot's set records the next batch meanwhile. Launches beyond
//! [`LAUNCHES_PER_BATCH`] in one batch run untimed and are counted in
//! [`StageProfile::untimed_launches`].

use std::cell::{Cell, RefCell};
use std::collections::BTreeMap;

use crate::gpu::device::{Gpu, GpuError};

/// Launches of one batch that get timestamps (two queries each).
pub const LAUNCHES_PER_BATCH: u32 = 2048;

/// The features a profiled render needs.
pub const FEATURES: wgpu::Features =
    wgpu::Features::TIMESTAMP_QUERY.union(wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES);

/// One stage's launches and their device time.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTime {
    /// Timed launches of the stage (untimed ones are counted in
    /// [`StageProfile::untimed_launches`] only).
    pub launches: u64,
    /// Their summed device time, in seconds (from the timestamps' period).
    pub seconds: f64,
}

/// Where a render's device time went.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StageProfile {
    /// By stage label (`Stage::label`), control kernels included.
    pub stages: BTreeMap<String, StageTime>,
    /// Wall time of the rounds (from the first submission to the last read-back).
    pub wall_seconds: f64,
    /// Launches that ran without timestamps (a batch beyond [`LAUNCHES_PER_BATCH`]).
    pub untimed_launches: u64,
    /// Host time spent recording and submitting batches' launches: when it nears the
    /// device time, the host is what keeps the device waiting.
    pub host_submit_seconds: f64,
    /// Host time blocked on read-backs (the device still busy, then the copy out).
    pub host_wait_seconds: f64,
}

impl StageProfile {
    /// Device time of every timed launch.
    pub fn device_seconds(&self) -> f64 {
        self.stages.values().map(|s| s.seconds).sum()
    }

    /// Device time over wall time: 1 when the device never waits for the host.
    pub fn busy_fraction(&self) -> f64 {
        if self.wall_seconds > 0.0 {
            self.device_seconds() / self.wall_seconds
        } else {
            0.0
        }
    }

    /// A Markdown table, slowest stage first, and the busy fraction.
    pub fn table(&self) -> String {
        let total = self.device_seconds();
        let mut rows: Vec<(&String, &StageTime)> = self.stages.iter().collect();
        rows.sort_by(|a, b| b.1.seconds.total_cmp(&a.1.seconds));
        let mut s = String::from("| stage | launches | device time (s) | share |\n|---|---|---|---|\n");
        for (name, t) in rows {
            let share = if total > 0.0 { 100.0 * t.seconds / total } else { 0.0 };
            s += &format!("| {name} | {} | {:.4} | {share:.1} % |\n", t.launches, t.seconds);
        }
        s += &format!(
            "\ndevice busy {:.1} % of the rounds' {:.3} s wall time ({:.3} s of launches",
            100.0 * self.busy_fraction(),
            self.wall_seconds,
            total
        );
        if self.untimed_launches > 0 {
            s += &format!("; {} launches untimed", self.untimed_launches);
        }
        s + &format!(
            ")\nhost {:.3} s recording and submitting launches, {:.3} s waiting for read-backs\n",
            self.host_submit_seconds, self.host_wait_seconds
        )
    }
}

/// The query sets and read-back buffers of a profiled render, one per film slot.
pub(crate) struct Profiler {
    sets: [wgpu::QuerySet; 2],
    resolve: [wgpu::Buffer; 2],
    staging: [wgpu::Buffer; 2],
    /// The label of each timed launch of the batch recording into / read from each slot.
    labels: RefCell<[Vec<String>; 2]>,
    slot: Cell<usize>,
    period_ns: f64,
    profile: RefCell<StageProfile>,
}

impl Profiler {
    /// `None` when the device was opened without [`FEATURES`].
    pub fn new(gpu: &Gpu) -> Result<Option<Self>, GpuError> {
        if !gpu.device.features().contains(FEATURES) {
            return Ok(None);
        }
        let queries = 2 * LAUNCHES_PER_BATCH;
        let bytes = u64::from(queries) * 8;
        let set = |label: &str| {
            gpu.scoped(|| {
                gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some(label),
                    ty: wgpu::QueryType::Timestamp,
                    count: queries,
                })
            })
        };
        let resolve = |label: &str| {
            gpu.scoped(|| {
                gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size: bytes,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                })
            })
        };
        Ok(Some(Self {
            sets: [set("timestamps 0")?, set("timestamps 1")?],
            resolve: [resolve("timestamp resolve 0")?, resolve("timestamp resolve 1")?],
            staging: [
                gpu.readback_buffer("timestamp readback 0", bytes)?,
                gpu.readback_buffer("timestamp readback 1", bytes)?,
            ],
            labels: RefCell::new([Vec::new(), Vec::new()]),
            slot: Cell::new(0),
            period_ns: f64::from(gpu.queue.get_timestamp_period()),
            profile: RefCell::new(StageProfile::default()),
        }))
    }

    /// The batch about to be recorded uses film slot `slot`.
    pub fn begin_batch(&self, slot: usize) {
        self.slot.set(slot);
        self.labels.borrow_mut()[slot].clear();
    }

    /// Records `launch` into `pass` between two timestamps labelled `label`.
    pub fn timed(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        label: String,
        launch: impl FnOnce(&mut wgpu::ComputePass<'_>) -> Result<(), GpuError>,
    ) -> Result<(), GpuError> {
        let slot = self.slot.get();
        let k = self.labels.borrow()[slot].len() as u32;
        if k >= LAUNCHES_PER_BATCH {
            self.profile.borrow_mut().untimed_launches += 1;
            return launch(pass);
        }
        pass.write_timestamp(&self.sets[slot], 2 * k);
        launch(pass)?;
        pass.write_timestamp(&self.sets[slot], 2 * k + 1);
        self.labels.borrow_mut()[slot].push(label);
        Ok(())
    }

    /// Resolves the batch's timestamps into its read-back buffer (in its last submission).
    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        let slot = self.slot.get();
        let n = 2 * self.labels.borrow()[slot].len() as u32;
        if n > 0 {
            encoder.resolve_query_set(&self.sets[slot], 0..n, &self.resolve[slot], 0);
            encoder.copy_buffer_to_buffer(&self.resolve[slot], 0, &self.staging[slot], 0, u64::from(n) * 8);
        }
    }

    /// Adds the durations of the batch of `slot`, once `submission` (its last) is done.
    pub fn collect(&self, gpu: &Gpu, slot: usize, submission: wgpu::SubmissionIndex) -> Result<(), GpuError> {
        let labels = std::mem::take(&mut self.labels.borrow_mut()[slot]);
        if labels.is_empty() {
            return Ok(());
        }
        let stamps: Vec<u64> = super::map_read(gpu, &self.staging[slot], labels.len() as u64 * 16, Some(submission))?;
        let mut profile = self.profile.borrow_mut();
        for (label, pair) in labels.into_iter().zip(stamps.chunks_exact(2)) {
            let t = profile.stages.entry(label).or_default();
            t.launches += 1;
            t.seconds += pair[1].saturating_sub(pair[0]) as f64 * self.period_ns * 1e-9;
        }
        Ok(())
    }

    /// The profile so far, with the rounds' wall time and the host's times.
    pub fn finish(&self, wall_seconds: f64, host_submit_seconds: f64, host_wait_seconds: f64) -> StageProfile {
        StageProfile { wall_seconds, host_submit_seconds, host_wait_seconds, ..self.profile.borrow().clone() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn busy_fraction_and_table() {
        let mut p = StageProfile { wall_seconds: 2.0, host_submit_seconds: 0.25, ..Default::default() };
        p.stages.insert("intersect".into(), StageTime { launches: 10, seconds: 0.75 });
        p.stages.insert("film".into(), StageTime { launches: 2, seconds: 0.25 });
        assert_eq!((p.device_seconds(), p.busy_fraction()), (1.0, 0.5));
        let t = p.table();
        assert!(t.find("| intersect | 10 | 0.7500 | 75.0 % |").unwrap() < t.find("| film |").unwrap(), "{t}");
        assert!(t.contains("device busy 50.0 % of the rounds' 2.000 s"), "{t}");
        assert!(t.contains("host 0.250 s recording and submitting launches, 0.000 s waiting"), "{t}");
        assert_eq!(StageProfile::default().busy_fraction(), 0.0);
    }
}
