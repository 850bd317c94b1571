//! GPU renderer tests: the WGSL random streams against `sampling::stream`, and (below) GPU
//! renders against the CPU reference and analytic answers. Every GPU test skips itself
//! without an adapter (and fails instead with LUMEN_REQUIRE_GPU=1).

use lumen::gpu::gpu_for_tests;
use lumen::sampling::{stream, CAMERA_BOUNCE};
use lumen::scene::PcgSeed;

const RANDOM_WGSL: &str = include_str!("../shaders/random.wgsl");

/// Thousands of (pixel, sample, bounce) streams, from two seeds (one with a carry into the
/// high word), give bitwise the same u32 and f32 sequences on the GPU as on the CPU.
#[test]
fn random_streams_match_the_cpu_bit_for_bit() {
    let Some(gpu) = gpu_for_tests("random_streams_match_the_cpu_bit_for_bit") else { return };
    const DRAWS: usize = 9;
    let kernel_src = format!(
        "{RANDOM_WGSL}
struct Params {{ seed: vec4<u32>, count: u32 }}
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> keys: array<vec4<u32>>;
@group(0) @binding(2) var<storage, read_write> out_u: array<u32>;
@group(0) @binding(3) var<storage, read_write> out_f: array<f32>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {{
    let i = id.x;
    if (i >= params.count) {{ return; }}
    let k = keys[i];
    var rng = stream(params.seed.xy, params.seed.zw, k.x, k.y, k.z);
    for (var j = 0u; j < {DRAWS}u; j++) {{ out_u[i * {DRAWS}u + j] = pcg_next_u32(&rng); }}
    out_f[i] = pcg_next_f32(&rng);
}}"
    );
    let kernel = gpu.compute_kernel("random_test.wgsl", &kernel_src, "main").unwrap();
    let seeds = [
        PcgSeed::default(),
        PcgSeed { state: 0xFFFF_FFFF_FFFF_FF00, inc: 0xDEAD_BEEF_1234_5678 },
        PcgSeed { state: 0x0000_0000_FFFF_FFFF, inc: u64::MAX },
    ];
    // Keys: a grid of pixels, samples and bounces, including the camera bounce and extremes.
    let mut keys: Vec<[u32; 4]> = Vec::new();
    for p in (0..40_000u32).step_by(997).chain([u32::MAX, 0]) {
        for s in [0u32, 1, 2, 7, 63, 1000, u32::MAX] {
            for b in [0u32, 1, 2, 5, CAMERA_BOUNCE] {
                keys.push([p, s, b, 0]);
            }
        }
    }
    assert!(keys.len() > 1000);
    for seed in seeds {
        #[repr(C)]
        #[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
        struct Params {
            seed: [u32; 4],
            count: u32,
            _pad: [u32; 3],
        }
        let params = Params {
            seed: [seed.state as u32, (seed.state >> 32) as u32, seed.inc as u32, (seed.inc >> 32) as u32],
            count: keys.len() as u32,
            _pad: [0; 3],
        };
        let ub = gpu.uniform_buffer("params", &params).unwrap();
        let kb = gpu.storage_buffer("keys", &keys).unwrap();
        let ou = gpu.storage_buffer_zeroed("out_u", (keys.len() * DRAWS * 4) as u64).unwrap();
        let of = gpu.storage_buffer_zeroed("out_f", (keys.len() * 4) as u64).unwrap();
        let group = kernel.bind_group(&gpu, 0, &[&ub, &kb, &ou, &of]).unwrap();
        gpu.dispatch(&kernel, &[&group], kernel.workgroups_for([keys.len() as u32, 1, 1])).unwrap();
        let got_u: Vec<u32> = gpu.read_buffer(&ou, keys.len() * DRAWS).unwrap();
        let got_f: Vec<f32> = gpu.read_buffer(&of, keys.len()).unwrap();
        for (i, k) in keys.iter().enumerate() {
            let mut rng = stream(seed, k[0], k[1], k[2]);
            for j in 0..DRAWS {
                assert_eq!(got_u[i * DRAWS + j], rng.next_u32(), "seed {seed:?} key {k:?} draw {j}");
            }
            assert_eq!(got_f[i].to_bits(), rng.next_f32().to_bits(), "seed {seed:?} key {k:?} float");
        }
    }
}
