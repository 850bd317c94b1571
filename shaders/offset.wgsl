// #requires ray
// Robust spawned-ray origins (Wächter & Binder, Ray Tracing Gems ch. 6), scale-aware:
// mirrors cpu::offset_origin with the original f32 constants (256 ulps; 1/32 and 2⁻¹⁶,
// both times the point's error scale, see src/cpu/offset.rs).

const OFFSET_ORIGIN: f32 = 0.03125;
const OFFSET_FLOAT_SCALE: f32 = 1.52587890625e-5;
const OFFSET_INT_SCALE: f32 = 256.0;

fn offset_coord(p: f32, scale: f32, n: f32) -> f32 {
    if (abs(p) < OFFSET_ORIGIN * scale) {
        return p + OFFSET_FLOAT_SCALE * scale * n;
    }
    let ulps = i32(OFFSET_INT_SCALE * n);
    let step = select(ulps, -ulps, p < 0.0);
    let moved = bitcast<f32>(bitcast<i32>(p) + step);
    // An exponent of all ones is ∞ or NaN: keep p.
    if ((bitcast<u32>(moved) & 0x7F800000u) == 0x7F800000u) {
        return p;
    }
    return moved;
}

// Moves surface point p (error scale `scale`) off the surface with geometric normal n
// (either orientation) to the side that `dir` leaves through.
fn offset_origin(p: vec3<f32>, scale: f32, n_geometric: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {
    var n = normalize_or(n_geometric, vec3<f32>(0.0));
    if (dot(n, dir) < 0.0) {
        n = -n;
    }
    return vec3<f32>(offset_coord(p.x, scale, n.x), offset_coord(p.y, scale, n.y), offset_coord(p.z, scale, n.z));
}
