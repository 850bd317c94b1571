//! Settings for Mesa's llvmpipe, the software GPU that lavapipe (Vulkan) runs on.
//!
//! llvmpipe JIT-compiles each compute kernel at its first dispatch with LLVM, one kernel
//! after another, and by default vectorises it over 256-bit registers where the host has
//! them (also with AVX-512). Up to Mesa 25, llvmpipe compiles every lane-divergent
//! storage-buffer access into per-lane code; at 128 bits each such access expands to 4
//! lanes instead of 8, so a scene's kernels compile 30–40 % faster, and the same renders
//! run as fast (measured side by side: docs/DESIGN.md "Software adapters", BENCHMARKS.md).
//! So `lumen` asks llvmpipe for 128-bit vectors unless the user chose a width. Mesa 26.1
//! turns those accesses into gathers, and there wider vectors win: on an Intel host 256 bits
//! rendered 1.15–1.7× faster than 128, and 512 bits faster again on most scenes, as on an
//! AMD Zen 4 host. When the adapter turns out to be such an llvmpipe (known only once the
//! driver is loaded, and llvmpipe reads the width only then), `lumen` relaunches itself
//! with the host's width ([`relaunch_if_wider_is_faster`], registered with
//! `gpu::on_adapter_chosen`; [`host_vector_bits`]). The variable only affects llvmpipe;
//! hardware drivers never read it. `.cargo/config.toml` sets 128 for `cargo test`, `cargo
//! bench` and examples, so the tests exercise the configuration CI's Mesa 25 gets.

use std::ffi::OsStr;
use std::sync::atomic::{AtomicBool, Ordering};

/// The variable llvmpipe reads once, when the driver is first loaded.
pub const VECTOR_WIDTH_ENV: &str = "LP_NATIVE_VECTOR_WIDTH";

/// The width lumen asks for, in bits.
pub const VECTOR_WIDTH_BITS: &str = "128";

/// llvmpipe's worker threads per device that split `cores` between two devices (the
/// renderer's and its twin, `gpu::wavefront::devices_split_cores`): `cores / 2`, unless
/// the user has set the variable (`inherited`) or there is only one core.
pub fn threads_to_set(inherited: Option<&OsStr>, cores: usize) -> Option<String> {
    (inherited.is_none() && cores >= 2).then(|| (cores / 2).to_string())
}

/// Gives each llvmpipe device half the cores ([`threads_to_set`]), so that a render's two
/// devices run side by side instead of sharing every core: lavapipe runs one launch at a
/// time, and its threads wait for each other between launches and in each launch's last
/// workgroups, so one device with a thread per core kept 1.4-1.8 of two cores busy, while
/// two single-threaded devices from the first round render `lumen bench`'s example scenes
/// 1.0-1.9x as fast on the 2-core Zen 3 VM (BENCHMARKS.md "Two single-threaded devices").
/// The cost: a render on one device runs on half the cores, so `--one-device` and
/// `--profile` renders skip this (a render of one batch pays it). Hardware drivers never
/// read the variable.
///
/// Must run while the process has one thread (it changes the environment) and before any
/// GPU instance is created (llvmpipe reads the variable when a device is created).
pub fn split_cores_between_devices() {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let threads_env = crate::gpu::wavefront::THREADS_ENV;
    if let Some(threads) = threads_to_set(std::env::var_os(threads_env).as_deref(), cores) {
        std::env::set_var(threads_env, threads);
    }
}

/// The value to set given the inherited one: none when the user has set the variable.
pub fn vector_width_to_set(inherited: Option<&OsStr>) -> Option<&'static str> {
    inherited.is_none().then_some(VECTOR_WIDTH_BITS)
}

/// Whether this process set the width itself ([`prefer_narrow_vectors`]), so that it may
/// choose another once it knows the driver.
static WIDTH_SET_HERE: AtomicBool = AtomicBool::new(false);

/// Asks llvmpipe for [`VECTOR_WIDTH_BITS`]-bit vectors unless the variable is set.
///
/// Must run at the very start of `main`, before any thread exists (it changes the
/// environment, which is only sound while no other thread can read it) and before any GPU
/// instance is created (llvmpipe reads the variable once).
pub fn prefer_narrow_vectors() {
    if let Some(bits) = vector_width_to_set(std::env::var_os(VECTOR_WIDTH_ENV).as_deref()) {
        std::env::set_var(VECTOR_WIDTH_ENV, bits);
        WIDTH_SET_HERE.store(true, Ordering::Relaxed);
    }
}

/// The width to relaunch with on adapter `info`, if any: the host's `host_bits`
/// ([`host_vector_bits`]) where the width was lumen's own 128, the adapter is an llvmpipe
/// that runs faster wide ([`crate::gpu::llvmpipe_prefers_wide_vectors`]), and the host has
/// registers wider than 128 bits.
pub fn wider_width(info: &wgpu::AdapterInfo, set_here: bool, host_bits: u32) -> Option<u32> {
    let gains = set_here
        && crate::gpu::llvmpipe_vector_bits(info) == Some(128)
        && crate::gpu::llvmpipe_prefers_wide_vectors(info)
        && host_bits > 128;
    gains.then_some(host_bits)
}

/// The vector width lumen gives an llvmpipe that gains from wide vectors on this host: 512
/// bits with the AVX-512 of Intel's Ice Lake and AMD's Zen 4 generations or later (VBMI2
/// marks them), 256 with AVX2, else 128.
///
/// On the Intel host of 2026-12-06 Mesa 26.1 at 512 bits rendered most example scenes
/// 4–21 % faster than at 256 (spheres_10k.sl and skybox.sl most; cornell.sl and mirrors.sl,
/// already 3× the CPU, 5–7 % slower) and created kernels within a second still
/// (BENCHMARKS.md "512-bit vectors on Mesa 26.1"). On an AMD Zen 4 host (2026-12-06),
/// whose cores split 512-bit operations in two 256-bit halves, 512 bits still won: 14 %
/// over 256 in the geometric mean of the example scenes, from 4 % slower (demo.sl) to
/// 37 % faster (cornell.sl, mirrors.sl) (BENCHMARKS.md "An AMD Zen 4 host"); on a Zen 3
/// host (AVX2) 256 bits beat 128 by 25 % (BENCHMARKS.md "An AMD Zen 3 host"). Earlier
/// AVX-512 cores (Skylake-SP, Cascade Lake) lower the whole core's clock while 512-bit code
/// runs, so they keep 256.
///
/// ```
/// let bits = lumen::cli::software_driver::host_vector_bits();
/// assert!([128, 256, 512].contains(&bits));
/// ```
pub fn host_vector_bits() -> u32 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        if has!("avx512f") && has!("avx512bw") && has!("avx512dq") && has!("avx512vl") && has!("avx512vbmi2") {
            return 512;
        }
        if has!("avx2") {
            return 256;
        }
    }
    128
}

/// Relaunches this process with wider llvmpipe vectors where [`wider_width`] says so: the
/// same program, arguments and process id, the variable set (so the new process keeps
/// it). Registered with `gpu::on_adapter_chosen`, so it runs before the device is opened,
/// a render has begun or an output file exists (and before lumen has printed anything, so
/// nothing shows twice). Where the relaunch fails, the render goes on at 128 bits.
pub fn relaunch_if_wider_is_faster(info: &wgpu::AdapterInfo) {
    let Some(bits) = wider_width(info, WIDTH_SET_HERE.load(Ordering::Relaxed), host_vector_bits()) else {
        return;
    };
    #[cfg(target_os = "linux")]
    {
        let err = relaunch(bits);
        crate::diag!("note: could not relaunch with {bits}-bit llvmpipe vectors ({err}); going on at 128 bits");
    }
    // (Elsewhere no relaunch: llvmpipe through lavapipe is a Linux driver.)
    #[cfg(not(target_os = "linux"))]
    let _ = bits;
}

/// `exec` of this program again ([`super::own_process::this_program`]) with its own
/// arguments and `LP_NATIVE_VECTOR_WIDTH` = `bits`; returns only on failure.
#[cfg(target_os = "linux")]
fn relaunch(bits: u32) -> std::io::Error {
    use std::io::Write;
    use std::os::unix::process::CommandExt;
    let mut cmd = match super::own_process::this_program() {
        Ok(c) => c,
        Err(e) => return e,
    };
    let _ = std::io::stdout().flush();
    cmd.args(std::env::args_os().skip(1)).env(VECTOR_WIDTH_ENV, bits.to_string()).exec()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn llvmpipe(bits: u32, mesa: &str) -> wgpu::AdapterInfo {
        let mut info = wgpu::AdapterInfo::new(wgpu::DeviceType::Cpu, wgpu::Backend::Vulkan);
        info.name = format!("llvmpipe (LLVM 19.1.7, {bits} bits)");
        info.driver_info = format!("Mesa {mesa} (LLVM 19.1.7)");
        info
    }

    #[test]
    fn two_devices_get_half_the_cores_unless_the_user_chose() {
        assert_eq!(threads_to_set(None, 2).as_deref(), Some("1"));
        assert_eq!(threads_to_set(None, 16).as_deref(), Some("8"));
        assert_eq!(threads_to_set(None, 3).as_deref(), Some("1"));
        assert_eq!(threads_to_set(None, 1), None);
        assert_eq!(threads_to_set(Some(OsStr::new("4")), 16), None);
        // What is set is what the renderer's rule reads as split.
        for cores in 2..=64 {
            let t = threads_to_set(None, cores).unwrap();
            assert!(crate::gpu::wavefront::devices_split_cores(Some(&t), cores), "{cores} cores");
        }
    }

    #[test]
    fn wider_vectors_only_where_the_driver_gains_and_the_width_was_ours() {
        assert_eq!(wider_width(&llvmpipe(128, "26.1.6-1~bpo13+1"), true, 256), Some(256));
        assert_eq!(wider_width(&llvmpipe(128, "27.0.0"), true, 512), Some(512));
        // The user's (or a parent's) width, already wide, an older Mesa, a narrow host.
        assert_eq!(wider_width(&llvmpipe(128, "26.1.6"), false, 256), None);
        assert_eq!(wider_width(&llvmpipe(256, "26.1.6"), true, 256), None);
        assert_eq!(wider_width(&llvmpipe(128, "26.0.3"), true, 256), None);
        assert_eq!(wider_width(&llvmpipe(128, "25.0.7-2~bpo12+1"), true, 256), None);
        assert_eq!(wider_width(&llvmpipe(128, "26.1.6"), true, 128), None);
        let mut hardware = wgpu::AdapterInfo::new(wgpu::DeviceType::DiscreteGpu, wgpu::Backend::Vulkan);
        hardware.name = "NVIDIA H200".into();
        assert_eq!(wider_width(&hardware, true, 256), None);
    }

    #[test]
    fn a_width_the_user_chose_is_kept() {
        assert_eq!(vector_width_to_set(None), Some("128"));
        assert_eq!(vector_width_to_set(Some(OsStr::new("256"))), None);
        assert_eq!(vector_width_to_set(Some(OsStr::new(""))), None);
    }
}
