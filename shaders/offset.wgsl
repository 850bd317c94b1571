// #requires ray
// Robust spawned-ray origins (Wächter & Binder, Ray Tracing Gems ch. 6), scale-aware:
// mirrors cpu::offset_origin with the original f32 constants (256 ulps; 1/32 and 2⁻¹⁶,
// both times the point's error scale, see src/cpu/offset.rs).

const OFFSET_ORIGIN: f32 = 0.03125;
const OFFSET_FLOAT_SCALE: f32 = 1.52587890625e-5;
const OFFSET_INT_SCALE: f32 = 256.0;

// i32(x), truncated toward zero, per component, for |x| < 2²², in vector instructions
// (llvmpipe converts i32(f32) one lane and component at a time, with two compares for WGSL's
// saturation: docs/DESIGN.md "Float to index"): trunc(x) + 1.5·2²³ lies in [2²³, 2²⁴), where
// the mantissa's last bit is worth 1, so its bits less those of 1.5·2²³ are the integer,
// negative ones included.
fn trunc_small(x: vec3<f32>) -> vec3<i32> {
    return bitcast<vec3<i32>>(trunc(x) + vec3<f32>(12582912.0)) - vec3<i32>(0x4B400000);
}

// Moves surface point p (error scale `scale`) off the surface with geometric normal n
// (either orientation) to the side that `dir` leaves through: per coordinate, near zero a
// float step of 2⁻¹⁶·scale·n, elsewhere 256·n ulps, unless that lands on ∞ or NaN (then p).
// Straight-line code on all three coordinates at once, each case computed and chosen by a
// select: llvmpipe runs every branch of a lane-divergent `if` masked anyway, and the early
// returns of a per-coordinate function made its three copies at each of a shading stage's
// call sites cost about a sixth of that kernel's compile time (BENCHMARKS.md, "Spawned-ray
// offsets in straight-line code"). Same values as the branches, bit for bit.
fn offset_origin(p: vec3<f32>, scale: f32, n_geometric: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {
    let g = normalize_or(n_geometric, vec3<f32>(0.0));
    let n = select(g, -g, dot(g, dir) < 0.0);
    let near_zero = abs(p) < vec3<f32>(OFFSET_ORIGIN * scale);
    let float_step = p + OFFSET_FLOAT_SCALE * scale * n;
    // |256·n| ≤ 256: i32(256·n) in vector instructions.
    let ulps = trunc_small(OFFSET_INT_SCALE * n);
    let int_step = bitcast<vec3<f32>>(bitcast<vec3<i32>>(p) + select(ulps, -ulps, p < vec3<f32>(0.0)));
    // An exponent of all ones is ∞ or NaN: keep p.
    let overflow = (bitcast<vec3<u32>>(int_step) & vec3<u32>(0x7F800000u)) == vec3<u32>(0x7F800000u);
    return select(select(int_step, p, overflow), float_step, near_zero);
}
