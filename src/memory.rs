//! This process's memory: what it may use, its peak, and fallible allocation of buffers
//! whose size comes from input (image sizes, sample counts).
//!
//! Rust aborts the process when an ordinary allocation fails, so a large `Image(w, h)` or
//! `--width/--height` could end a run with "memory allocation failed" and nothing else.
//! Renderers instead estimate what they need before allocating ([`check_fits`]) and make
//! every input-sized buffer with [`try_filled`], so running out is an error that says how
//! much was needed. The estimate catches known limits at once; the fallible allocations
//! catch the rest (other processes, limits we cannot see).

/// A buffer could not be had.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum OutOfMemory {
    /// The allocator refused (address-space limit, no overcommit, or truly out of memory).
    #[error("cannot allocate {} for {what}; the whole task needs about {}", format_bytes(Some(*.bytes)), format_bytes(Some(*.total)))]
    Refused {
        /// What the buffer was for, as the message names it ("a 640×480 image", "the merge's sums").
        what: String,
        /// Size of the refused buffer, in bytes.
        bytes: u64,
        /// The whole task's estimated peak, in bytes (at least `bytes`).
        total: u64,
    },
    /// The estimate exceeds what this process may use: it can never succeed.
    #[error(
        "{what} needs about {} of memory, more than the {} this process may use ({limit})",
        format_bytes(Some(*.needed)),
        format_bytes(Some(*.available))
    )]
    TooLarge {
        /// The task refused, as the message names it ("a 640×480 CPU render").
        what: String,
        /// The task's estimated peak, in bytes.
        needed: u64,
        /// The most this process may use, in bytes ([`memory_limit`]).
        available: u64,
        /// What sets `available`: "RAM + swap", "the address-space limit" or "the cgroup's
        /// memory.max".
        limit: &'static str,
    },
}

/// `n` copies of `value`, or an error naming `what` and the task's estimated `total` bytes.
///
/// ```
/// let v = lumen::memory::try_filled(3, 0u8, "a test buffer", 3).unwrap();
/// assert_eq!(v, [0, 0, 0]);
/// let e = lumen::memory::try_filled(usize::MAX / 2, 0u64, "a huge buffer", u64::MAX).unwrap_err();
/// assert!(e.to_string().starts_with("cannot allocate"));
/// ```
pub fn try_filled<T: Clone>(n: usize, value: T, what: &str, total: u64) -> Result<Vec<T>, OutOfMemory> {
    let bytes = (n as u64).saturating_mul(std::mem::size_of::<T>() as u64);
    let refused = || OutOfMemory::Refused { what: what.to_string(), bytes, total: total.max(bytes) };
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| refused())?;
    v.resize(n, value);
    Ok(v)
}

/// Refuses a task whose estimated peak (`bytes`) exceeds what the process may use
/// ([`memory_limit`]), before anything is allocated: with overcommit the allocations might
/// succeed and the process be killed later, and under a limit they would fail only after
/// filling memory up to it.
pub fn check_fits(bytes: u64, what: &str) -> Result<(), OutOfMemory> {
    match memory_limit() {
        Some((available, limit)) if bytes > available => {
            Err(OutOfMemory::TooLarge { what: what.to_string(), needed: bytes, available, limit })
        }
        _ => Ok(()),
    }
}

/// The most memory this process may use and what sets it: the smallest of RAM + swap
/// (/proc/meminfo), the address-space limit (`ulimit -v`, /proc/self/limits) and the
/// cgroup's memory.max (containers). `None` where none is known (not Linux).
pub fn memory_limit() -> Option<(u64, &'static str)> {
    let read = |path: &str| std::fs::read_to_string(path).ok();
    let candidates = [
        (read("/proc/meminfo").as_deref().and_then(parse_meminfo), "RAM + swap"),
        (read("/proc/self/limits").as_deref().and_then(parse_address_space_limit), "the address-space limit"),
        (read("/sys/fs/cgroup/memory.max").and_then(|t| t.trim().parse().ok()), "the cgroup's memory.max"),
    ];
    candidates.into_iter().filter_map(|(v, why)| v.map(|v| (v, why))).min_by_key(|&(v, _)| v)
}

/// The value of a `Name:   1234 kB` line of a /proc file, in bytes.
fn kb_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    let mut words = line[name.len()..].split_whitespace();
    let value: u64 = words.next()?.parse().ok()?;
    match words.next() {
        Some("kB") => value.checked_mul(1024),
        _ => None,
    }
}

/// MemTotal + SwapTotal of /proc/meminfo.
fn parse_meminfo(text: &str) -> Option<u64> {
    Some(kb_field(text, "MemTotal:")?.saturating_add(kb_field(text, "SwapTotal:").unwrap_or(0)))
}

/// The process's peak resident set size (VmHWM in /proc/self/status), on Linux; `None`
/// elsewhere or when it cannot be read.
pub fn peak_memory_bytes() -> Option<u64> {
    kb_field(&std::fs::read_to_string("/proc/self/status").ok()?, "VmHWM:")
}

/// Bytes in binary units, or "n/a".
pub fn format_bytes(bytes: Option<u64>) -> String {
    match bytes {
        None => "n/a".to_string(),
        Some(b) if b >= 1 << 30 => format!("{:.2} GiB", b as f64 / (1u64 << 30) as f64),
        Some(b) if b >= 1 << 20 => format!("{:.1} MiB", b as f64 / (1u64 << 20) as f64),
        Some(b) if b >= 1 << 10 => format!("{:.1} KiB", b as f64 / 1024.0),
        Some(b) => format!("{b} B"),
    }
}

/// The soft limit of "Max address space" in /proc/self/limits (`None` if unlimited).
fn parse_address_space_limit(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("Max address space"))?;
    line["Max address space".len()..].split_whitespace().next()?.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_vm_hwm() {
        let s = "Name:\tlumen\nVmPeak:\t  999 kB\nVmHWM:\t    2048 kB\nVmRSS:\t 1 kB\n";
        assert_eq!(kb_field(s, "VmHWM:"), Some(2048 * 1024));
        assert_eq!(kb_field("VmRSS: 5 kB\n", "VmHWM:"), None);
        assert_eq!(kb_field("VmHWM: x kB\n", "VmHWM:"), None);
        assert_eq!(kb_field("VmHWM: 5 MB\n", "VmHWM:"), None);
    }

    #[test]
    fn formats_bytes() {
        assert_eq!(format_bytes(None), "n/a");
        assert_eq!(format_bytes(Some(512)), "512 B");
        assert_eq!(format_bytes(Some(3 << 20)), "3.0 MiB");
        assert_eq!(format_bytes(Some(3 << 30)), "3.00 GiB");
    }

    #[test]
    #[cfg(target_os = "linux")]
    fn this_process_has_a_peak() {
        assert!(peak_memory_bytes().unwrap() > 0);
    }

    #[test]
    fn meminfo_sums_ram_and_swap() {
        let t = "MemTotal:       1000 kB\nMemFree: 5 kB\nSwapTotal:  24 kB\n";
        assert_eq!(parse_meminfo(t), Some(1024 * 1024));
        assert_eq!(parse_meminfo("MemTotal: 2 kB\n"), Some(2048));
        assert_eq!(parse_meminfo("SwapTotal: 2 kB\n"), None);
        let limits = "Limit                     Soft Limit           Hard Limit           Units\n\
                      Max address space         4294967296           unlimited            bytes\n";
        assert_eq!(parse_address_space_limit(limits), Some(1 << 32));
        assert_eq!(parse_address_space_limit("Max address space  unlimited  unlimited  bytes\n"), None);
    }

    #[test]
    fn impossible_sizes_are_errors_not_aborts() {
        let e = try_filled(usize::MAX / 8, 0.0f64, "sums", u64::MAX).unwrap_err();
        assert!(matches!(e, OutOfMemory::Refused { .. }), "{e}");
        assert!(check_fits(u64::MAX, "a render").is_err() || memory_limit().is_none());
        assert!(check_fits(1, "a render").is_ok());
        let msg = OutOfMemory::TooLarge {
            what: "the render".into(),
            needed: 3 << 30,
            available: 1 << 30,
            limit: "RAM + swap",
        };
        assert_eq!(
            msg.to_string(),
            "the render needs about 3.00 GiB of memory, more than the 1.00 GiB this process may use (RAM + swap)"
        );
    }
}
