//! GPU infrastructure tests: device, compute runner, error capture. Every test skips
//! without an adapter unless LUMEN_REQUIRE_GPU=1 (see `lumen::gpu::gpu_for_tests`).

use bytemuck::{Pod, Zeroable};
use lumen::gpu::{gpu_for_tests, GpuError};

const SMOKE: &str = include_str!("../shaders/smoke.wgsl");

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct SmokeParams {
    count: u32,
    scale: f32,
}

#[test]
fn smoke_shader_matches_rust() {
    let Some(gpu) = gpu_for_tests("smoke_shader_matches_rust") else { return };
    // Not a multiple of the workgroup size, so the bounds check is exercised too.
    let n = 1000usize;
    let kernel = gpu.compute_kernel("smoke.wgsl", SMOKE, "main").unwrap();
    assert_eq!(kernel.workgroup_size, [64, 1, 1]);
    let params = gpu.uniform_buffer("params", &SmokeParams { count: n as u32, scale: 0.25 }).unwrap();
    let input: Vec<f32> = (0..n).map(|i| (i % 7) as f32 - 3.0).collect();
    let input_buf = gpu.storage_buffer("input", &input).unwrap();
    // One sentinel element past `count` must stay untouched.
    let out_u = gpu.storage_buffer("out_u", &vec![0xdead_beef_u32; n + 1]).unwrap();
    let out_f = gpu.storage_buffer("out_f", &vec![-7.0f32; n + 1]).unwrap();
    let group = kernel.bind_group(&gpu, 0, &[&params, &input_buf, &out_u, &out_f]).unwrap();
    gpu.dispatch(&kernel, &[&group], kernel.workgroups_for([n as u32, 1, 1])).unwrap();

    let got_u: Vec<u32> = gpu.read_buffer(&out_u, n + 1).unwrap();
    let got_f: Vec<f32> = gpu.read_buffer(&out_f, n + 1).unwrap();
    for i in 0..n {
        let iu = i as u32;
        assert_eq!(got_u[i], iu.wrapping_mul(iu) ^ 0x5bd1_e995, "u32 at {i}");
        assert_eq!(got_f[i], i as f32 * 0.25 + input[i], "f32 at {i}");
    }
    assert_eq!(got_u[n], 0xdead_beef);
    assert_eq!(got_f[n], -7.0);
    // Wrapping really happened for large i (65536² overflows u32).
    assert!(n * n > u16::MAX as usize);
}

#[test]
fn adapter_is_reported_and_opened_with_its_own_limits() {
    let Some(gpu) = gpu_for_tests("adapter_is_reported_and_opened_with_its_own_limits") else { return };
    assert!(!gpu.adapter_info.name.is_empty());
    assert!(lumen::gpu::list_adapters().iter().any(|a| a.name == gpu.adapter_info.name));
    // The device got the adapter's limits, which are never below WebGPU's defaults.
    assert_eq!(gpu.device.limits().max_storage_buffer_binding_size, gpu.limits.max_storage_buffer_binding_size);
    assert!(gpu.limits.max_storage_buffer_binding_size >= wgpu::Limits::default().max_storage_buffer_binding_size);
}

#[test]
fn shader_errors_are_values_with_locations() {
    let Some(gpu) = gpu_for_tests("shader_errors_are_values_with_locations") else { return };
    let src = "@compute @workgroup_size(1)\nfn main() {\n    let x: u32 = 1.5;\n}\n";
    let err = gpu.compute_kernel("bad.wgsl", src, "main").unwrap_err();
    assert!(matches!(err, GpuError::Shader { .. }), "{err}");
    assert!(err.to_string().contains("bad.wgsl:3"), "{err}");
    let err = gpu.compute_kernel("smoke.wgsl", SMOKE, "nope").unwrap_err();
    assert!(matches!(err, GpuError::NoEntryPoint { .. }), "{err}");
}

#[test]
fn wgpu_validation_errors_become_gpu_errors_not_panics() {
    let Some(gpu) = gpu_for_tests("wgpu_validation_errors_become_gpu_errors_not_panics") else { return };
    let kernel = gpu.compute_kernel("smoke.wgsl", SMOKE, "main").unwrap();
    let a = gpu.storage_buffer("a", &[0u32; 4]).unwrap();
    // Wrong count of buffers: caught by the runner itself.
    assert!(matches!(kernel.bind_group(&gpu, 0, &[&a]), Err(GpuError::Validation(_))));
    // A storage buffer where the layout wants a uniform: caught by wgpu, returned as a value.
    let err = kernel.bind_group(&gpu, 0, &[&a, &a, &a, &a]).unwrap_err();
    assert!(matches!(err, GpuError::Validation(_)), "{err}");
    // The device still works afterwards.
    gpu.check().unwrap();
    let params = gpu.uniform_buffer("params", &SmokeParams { count: 1, scale: 1.0 }).unwrap();
    let group = kernel.bind_group(&gpu, 0, &[&params, &a, &a, &a]);
    // Same buffer bound as read-only and read-write in one dispatch is a usage conflict.
    let dispatched = group.and_then(|g| gpu.dispatch(&kernel, &[&g], [1, 1, 1]));
    assert!(matches!(dispatched, Err(GpuError::Validation(_))), "{dispatched:?}");
}

#[test]
fn oversized_buffers_are_refused_with_the_limit() {
    let Some(gpu) = gpu_for_tests("oversized_buffers_are_refused_with_the_limit") else { return };
    let too_big = gpu.limits.max_storage_buffer_binding_size + 4;
    let err = gpu.storage_buffer_zeroed("huge", too_big).unwrap_err();
    assert!(matches!(err, GpuError::TooLarge { .. }), "{err}");
    assert!(err.to_string().contains("huge"));
}

// ---- progressive passes -------------------------------------------------------------

use lumen::gpu::{run_progressive, Gpu, PassOptions, StopReason, PASS_WGSL};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

/// A pass kernel whose per-sample value is `body` (WGSL expression of `pixel: u32`, `j: u32`,
/// giving vec3<f32>), summed over the pass's samples.
fn pass_kernel(gpu: &Gpu, name: &str, extra: &str, body: &str) -> lumen::gpu::ComputeKernel {
    let src = format!(
        "{PASS_WGSL}\n{extra}\n\
         @compute @workgroup_size(4, 4)\n\
         fn main(@builtin(global_invocation_id) gid: vec3<u32>) {{\n\
             if (!pass_in_tile(gid)) {{ return; }}\n\
             let pixel = pass_pixel_index(gid);\n\
             var sum = vec3<f32>(0.0);\n\
             for (var j = pass_params.sample_begin; j < pass_params.sample_end; j++) {{\n\
                 sum += {body};\n\
             }}\n\
             pass_write(gid, sum);\n\
         }}\n"
    );
    gpu.compute_kernel(name, &src, "main").unwrap()
}

#[test]
fn constant_samples_average_exactly_over_65536_samples() {
    let Some(gpu) = gpu_for_tests("constant_samples_average_exactly_over_65536_samples") else { return };
    let kernel = pass_kernel(&gpu, "constant.wgsl", "", "vec3<f32>(0.1, 0.1, 0.1)");
    // Several tiles, including partial ones, so tiling is part of what is checked.
    let opts = PassOptions { tile_size: 4, ..PassOptions::default() };
    let out = run_progressive(&gpu, &kernel, &[], 7, 5, 65_536, &opts).unwrap();
    assert_eq!(out.stop, StopReason::Completed);
    assert_eq!(out.spp_done, 65_536);
    assert_eq!(out.nonfinite, 0);
    // At least 65,536 / 64 rounds of 4 tiles: the f64 host sum did the long accumulation.
    assert!(out.passes >= 4 * 1024, "{} passes", out.passes);
    for (i, s) in out.sums.iter().enumerate() {
        for c in s {
            let mean = c / 65_536.0;
            assert!((mean - 0.1).abs() <= 1e-6 * 0.1, "pixel {i}: mean {mean}");
        }
    }
    for p in out.image.pixels() {
        assert!((f64::from(p.r) - 0.1).abs() <= 1e-6 * 0.1);
    }
}

/// Integer-valued samples: every partial sum is exact in f32, so any split must agree bitwise.
const INTEGER_SAMPLE: &str = "vec3<f32>(f32((pixel * 7u + j * 13u) % 17u), f32(j % 5u), f32((pixel ^ j) & 3u))";

fn integer_sample(pixel: u32, j: u32) -> [f64; 3] {
    [f64::from((pixel * 7 + j * 13) % 17), f64::from(j % 5), f64::from((pixel ^ j) & 3)]
}

#[test]
fn results_do_not_depend_on_the_pass_split() {
    let Some(gpu) = gpu_for_tests("results_do_not_depend_on_the_pass_split") else { return };
    let kernel = pass_kernel(&gpu, "integer.wgsl", "", INTEGER_SAMPLE);
    let (w, h, spp) = (6u32, 5u32, 100u32);
    let expected: Vec<[f64; 3]> = (0..w * h)
        .map(|p| (0..spp).map(|j| integer_sample(p, j)).fold([0.0; 3], |a, s| [a[0] + s[0], a[1] + s[1], a[2] + s[2]]))
        .collect();
    let splits = [
        PassOptions { tile_size: 256, initial_spp_per_pass: 1, max_spp_per_pass: 1, ..PassOptions::default() },
        PassOptions { tile_size: 3, initial_spp_per_pass: 7, max_spp_per_pass: 7, ..PassOptions::default() },
        PassOptions { tile_size: 4, ..PassOptions::default() },
        PassOptions { tile_size: 1, initial_spp_per_pass: 64, max_spp_per_pass: 64, ..PassOptions::default() },
    ];
    let mut passes = Vec::new();
    for opts in &splits {
        let out = run_progressive(&gpu, &kernel, &[], w, h, spp, opts).unwrap();
        assert_eq!(out.spp_done, spp);
        assert_eq!(out.sums, expected, "split {opts:?}");
        passes.push(out.passes);
    }
    // The splits really were different.
    assert_eq!(passes[0], 100);
    assert_eq!(passes[1], 4 * 15); // 2×2 tiles of ≤3 px, ceil(100/7) = 15 rounds
    assert_eq!(passes[3], 30 * 2); // 30 one-pixel tiles, 64 + 36 samples
}

#[test]
fn scene_bind_groups_reach_the_kernel() {
    let Some(gpu) = gpu_for_tests("scene_bind_groups_reach_the_kernel") else { return };
    let extra = "@group(1) @binding(0) var<storage, read> scene: array<f32>;";
    let kernel = pass_kernel(&gpu, "scene.wgsl", extra, "vec3<f32>(scene[pixel], 1.0, f32(j))");
    let (w, h, spp) = (3u32, 2u32, 8u32);
    let data: Vec<f32> = (0..w * h).map(|i| i as f32 * 0.5).collect();
    let buf = gpu.storage_buffer("scene", &data).unwrap();
    let group = kernel.bind_group(&gpu, 1, &[&buf]).unwrap();
    let out = run_progressive(&gpu, &kernel, &[&group], w, h, spp, &PassOptions::default()).unwrap();
    for (i, p) in out.image.pixels().iter().enumerate() {
        // Mean of j over 0..8 is 3.5.
        assert_eq!((p.r, p.g, p.b), (data[i], 1.0, 3.5), "pixel {i}");
    }
    // Forgetting the scene group is a clear error, not a wgpu panic.
    let err = run_progressive(&gpu, &kernel, &[], w, h, spp, &PassOptions::default()).unwrap_err();
    assert!(err.to_string().contains("scene bind groups"), "{err}");
}

#[test]
fn time_limit_keeps_whole_rounds() {
    let Some(gpu) = gpu_for_tests("time_limit_keeps_whole_rounds") else { return };
    let kernel = pass_kernel(&gpu, "integer.wgsl", "", INTEGER_SAMPLE);
    // A zero limit has passed after the first round, whatever the machine's speed.
    let opts = PassOptions {
        tile_size: 2,
        initial_spp_per_pass: 3,
        time_limit: Some(std::time::Duration::ZERO),
        ..PassOptions::default()
    };
    let out = run_progressive(&gpu, &kernel, &[], 5, 3, 1000, &opts).unwrap();
    assert_eq!(out.stop, StopReason::TimeLimit);
    assert_eq!(out.spp_done, 3);
    assert_eq!(out.passes, 6); // one round over 3×2 tiles
    for (p, s) in out.sums.iter().enumerate() {
        let want =
            (0..3).map(|j| integer_sample(p as u32, j)).fold([0.0; 3], |a, s| [a[0] + s[0], a[1] + s[1], a[2] + s[2]]);
        assert_eq!(*s, want, "pixel {p}");
    }
}

#[test]
fn cancel_drops_the_unfinished_round() {
    let Some(gpu) = gpu_for_tests("cancel_drops_the_unfinished_round") else { return };
    let kernel = pass_kernel(&gpu, "constant.wgsl", "", "vec3<f32>(1.0)");
    let opts = PassOptions { tile_size: 2, cancel: Some(Arc::new(AtomicBool::new(true))), ..PassOptions::default() };
    let out = run_progressive(&gpu, &kernel, &[], 4, 4, 50, &opts).unwrap();
    assert_eq!(out.stop, StopReason::Interrupted);
    assert_eq!(out.passes, 1);
    assert_eq!(out.spp_done, 0);
    assert!(out.image.pixels().iter().all(|p| p.r == 0.0 && !p.r.is_nan()));
}

#[test]
fn kernels_breaking_the_pass_contract_are_refused() {
    let Some(gpu) = gpu_for_tests("kernels_breaking_the_pass_contract_are_refused") else { return };
    let kernel = gpu.compute_kernel("smoke.wgsl", SMOKE, "main").unwrap();
    let err = run_progressive(&gpu, &kernel, &[], 4, 4, 1, &PassOptions::default()).unwrap_err();
    assert!(err.to_string().contains("pass contract"), "{err}");
}

// ---- shader assembly ----------------------------------------------------------------

use lumen::gpu::{FeatureSet, KernelCache, ShaderLibrary};

#[test]
fn assembled_kernels_run_and_are_cached_by_feature_set() {
    let Some(gpu) = gpu_for_tests("assembled_kernels_run_and_are_cached_by_feature_set") else { return };
    let mut lib = ShaderLibrary::new(&["bright", "unused"]);
    lib.add("shaders/pass.wgsl", PASS_WGSL).unwrap();
    lib.add(
        "value.wgsl",
        "fn sample_value(j: u32) -> f32 {\n// #if bright\n    return 2.0 + f32(j & 1u);\n// #else\n    return 1.0;\n// #endif\n}",
    )
    .unwrap();
    lib.add(
        "main.wgsl",
        "// #requires pass value\n\
         @compute @workgroup_size(8, 8)\n\
         fn main(@builtin(global_invocation_id) gid: vec3<u32>) {\n\
             if (!pass_in_tile(gid)) { return; }\n\
             var s = 0.0;\n\
             for (var j = pass_params.sample_begin; j < pass_params.sample_end; j++) { s += sample_value(j); }\n\
             pass_write(gid, vec3<f32>(s));\n\
         }",
    )
    .unwrap();
    let mut cache = KernelCache::new();
    let plain = FeatureSet::new();
    let bright = FeatureSet::new().with("bright");
    // Samples alternate 2, 3 with `bright`: the mean over 10 samples is 2.5.
    for (features, want) in [(&plain, 1.0f32), (&bright, 2.5), (&plain, 1.0), (&bright, 2.5)] {
        let kernel = cache
            .get_or_build(features, "main", || lib.assemble(&["main"], features)?.kernel(&gpu, "main.wgsl", "main"))
            .unwrap();
        let out = run_progressive(&gpu, &kernel, &[], 9, 9, 10, &PassOptions::default()).unwrap();
        assert!(out.image.pixels().iter().all(|p| p.g == want), "{features}");
    }
    assert_eq!(cache.len(), 2);
}

#[test]
fn tiles_shrink_for_slow_passes_without_changing_the_result() {
    let Some(gpu) = gpu_for_tests("tiles_shrink_for_slow_passes_without_changing_the_result") else { return };
    let kernel = pass_kernel(&gpu, "integer.wgsl", "", INTEGER_SAMPLE);
    // A zero target makes every pass "too slow": one sample per pass, tiles 256 → 128 → 64 → 32.
    let opts = PassOptions { target_pass_seconds: 0.0, ..PassOptions::default() };
    let (w, h, spp) = (100u32, 70u32, 6u32);
    let out = run_progressive(&gpu, &kernel, &[], w, h, spp, &opts).unwrap();
    assert_eq!(out.passes, 1 + 1 + 4 + 12 + 12 + 12);
    for (p, s) in out.sums.iter().enumerate() {
        let want = (0..spp)
            .map(|j| integer_sample(p as u32, j))
            .fold([0.0; 3], |a, s| [a[0] + s[0], a[1] + s[1], a[2] + s[2]]);
        assert_eq!(*s, want, "pixel {p}");
    }
}

#[test]
fn a_lost_device_is_an_error_not_a_panic() {
    let Some(gpu) = gpu_for_tests("a_lost_device_is_an_error_not_a_panic") else { return };
    let kernel = gpu.compute_kernel("smoke.wgsl", SMOKE, "main").unwrap();
    let data = gpu.storage_buffer("data", &[1u32; 8]).unwrap();
    // Destroying the device is the one portable way to lose it on purpose.
    gpu.device.destroy();
    let err = gpu.storage_buffer("after", &[1u32; 4]).unwrap_err();
    assert!(matches!(err, GpuError::DeviceLost(_)), "{err}");
    assert!(gpu.read_buffer::<u32>(&data, 8).is_err());
    let params = gpu.uniform_buffer("params", &SmokeParams { count: 1, scale: 1.0 });
    let run = params.and_then(|p| {
        let g = kernel.bind_group(&gpu, 0, &[&p, &data, &data, &data])?;
        gpu.dispatch(&kernel, &[&g], [1, 1, 1])
    });
    assert!(run.is_err());
}
