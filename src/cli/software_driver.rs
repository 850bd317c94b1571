//! Settings for Mesa's llvmpipe, the software GPU that lavapipe (Vulkan) runs on.
//!
//! llvmpipe JIT-compiles each compute kernel at its first dispatch with LLVM, one kernel
//! after another, and by default vectorises it over the host's widest SIMD registers
//! (256 bits here). lumen's stages are dominated by lane-divergent storage-buffer
//! accesses, which llvmpipe compiles into per-lane code; at 128 bits every such access
//! expands to 4 lanes instead of 8, so a scene's kernels compile 30–40 % faster, and the
//! same renders run as fast (measured side by side: docs/DESIGN.md "Software adapters",
//! BENCHMARKS.md). So `lumen` asks llvmpipe for 128-bit vectors unless the user chose a
//! width. The variable only affects llvmpipe; hardware drivers never read it.
//! `.cargo/config.toml` sets the same value for `cargo test`, `cargo bench` and examples,
//! so the tests exercise the driver configuration the program uses.

use std::ffi::OsStr;

/// The variable llvmpipe reads once, when the driver is first loaded.
pub const VECTOR_WIDTH_ENV: &str = "LP_NATIVE_VECTOR_WIDTH";

/// The width lumen asks for, in bits.
pub const VECTOR_WIDTH_BITS: &str = "128";

/// The value to set given the inherited one: none when the user has set the variable.
pub fn vector_width_to_set(inherited: Option<&OsStr>) -> Option<&'static str> {
    inherited.is_none().then_some(VECTOR_WIDTH_BITS)
}

/// Asks llvmpipe for [`VECTOR_WIDTH_BITS`]-bit vectors unless the variable is set.
///
/// Must run at the very start of `main`, before any thread exists (it changes the
/// environment, which is only sound while no other thread can read it) and before any GPU
/// instance is created (llvmpipe reads the variable once).
pub fn prefer_narrow_vectors() {
    if let Some(bits) = vector_width_to_set(std::env::var_os(VECTOR_WIDTH_ENV).as_deref()) {
        std::env::set_var(VECTOR_WIDTH_ENV, bits);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_width_the_user_chose_is_kept() {
        assert_eq!(vector_width_to_set(None), Some("128"));
        assert_eq!(vector_width_to_set(Some(OsStr::new("256"))), None);
        assert_eq!(vector_width_to_set(Some(OsStr::new(""))), None);
    }
}
