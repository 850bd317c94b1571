// GPU smoke test: a known integer and float pattern, checked against Rust by
// tests/gpu_infra.rs. Exercises a uniform, a read-only storage input and two outputs.

struct Params {
    count: u32,
    scale: f32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> input: array<f32>;
@group(0) @binding(2) var<storage, read_write> out_u: array<u32>;
@group(0) @binding(3) var<storage, read_write> out_f: array<f32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= params.count) {
        return;
    }
    // Wrapping u32 arithmetic, as Rust's wrapping_mul.
    out_u[i] = (i * i) ^ 0x5bd1e995u;
    // Exact in f32: small integers times a power of two, plus an input read.
    out_f[i] = f32(i) * params.scale + input[i];
}
