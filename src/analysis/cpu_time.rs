//! The CPU time this process has used, for `lumen bench`'s "cores busy": a render's CPU
//! seconds over its wall seconds.
//!
//! On a software GPU (lavapipe) the kernels run on the same cores as the CPU renderer, and
//! how many of them a render keeps busy is what separates the two as often as the work per
//! sample does: lavapipe's workers sleep at every launch's end, the CPU renderer's threads
//! never do (BENCHMARKS.md "Where a GPU render's idle time goes on this VM").

/// User and system CPU seconds of every thread of this process so far (`getrusage`), or
/// `None` where that is not available (not Unix, or the call failed).
///
/// ```
/// let before = lumen::analysis::process_cpu_seconds();
/// let mut x = 0u64;
/// for i in 0..20_000_000u64 {
///     x = x.wrapping_mul(6364136223846793005).wrapping_add(i);
/// }
/// std::hint::black_box(x);
/// if let (Some(a), Some(b)) = (before, lumen::analysis::process_cpu_seconds()) {
///     assert!(b >= a);
/// }
/// ```
pub fn process_cpu_seconds() -> Option<f64> {
    #[cfg(unix)]
    {
        let mut usage = std::mem::MaybeUninit::<libc::rusage>::zeroed();
        // SAFETY: getrusage writes a whole `rusage` through the pointer, which points at
        // one, and reads nothing else; its result is used only when the call succeeded.
        let ok = unsafe { libc::getrusage(libc::RUSAGE_SELF, usage.as_mut_ptr()) } == 0;
        if !ok {
            return None;
        }
        // SAFETY: initialised by the successful call above (and zeroed before it).
        let usage = unsafe { usage.assume_init() };
        let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
        Some(seconds(usage.ru_utime) + seconds(usage.ru_stime))
    }
    #[cfg(not(unix))]
    {
        None
    }
}

/// CPU seconds over wall seconds: how many cores were busy on average, `None` without a
/// positive wall time or CPU time.
///
/// ```
/// use lumen::analysis::cores_busy;
/// assert_eq!(cores_busy(Some(3.0), 2.0), Some(1.5));
/// assert_eq!(cores_busy(None, 2.0), None);
/// assert_eq!(cores_busy(Some(1.0), 0.0), None);
/// ```
pub fn cores_busy(cpu_seconds: Option<f64>, wall_seconds: f64) -> Option<f64> {
    cpu_seconds.filter(|c| *c >= 0.0).filter(|_| wall_seconds > 0.0).map(|c| c / wall_seconds)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two threads spinning for 0.3 s use at most twice the wall time (plus a tick), and on
    /// any machine a good part of it (the bounds are loose: other tests share the cores).
    #[test]
    #[cfg(unix)]
    fn counts_the_spinning_threads() {
        let before = process_cpu_seconds().unwrap();
        let start = std::time::Instant::now();
        let spin = || {
            let mut x = 1u64;
            while start.elapsed().as_secs_f64() < 0.3 {
                x = std::hint::black_box(x.wrapping_mul(3).wrapping_add(1));
            }
        };
        std::thread::scope(|s| {
            s.spawn(spin);
            spin();
        });
        let wall = start.elapsed().as_secs_f64();
        let used = process_cpu_seconds().unwrap() - before;
        assert!(used > 0.2 * wall && used < 2.0 * wall + 0.05, "{used} CPU s over {wall} s");
        // The same bounds, as cores: more than a fifth of one, at most two (plus a tick).
        let busy = cores_busy(Some(used), wall).unwrap();
        assert!(busy > 0.2 && busy < 2.0 + 0.05 / wall, "{busy} cores");
    }
}
