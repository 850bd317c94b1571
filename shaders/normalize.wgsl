// #requires rescale
// Normalising without underflow: mirrors cpu::ray::normalize_scaled. Shading reads it for
// normals, and the escaped rays' code (no other shading code) for their direction.

// v/|v|, or `fallback` for zero; rescaled by a power of two first (ray::normalize_scaled)
// so that the normal of a shape scaled by 1e30 (length 1e-30, squared 0 in f32) keeps
// its direction.
fn normalize_or(v_in: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    let a = abs(v_in);
    let v = v_in * pow2_rescale(max(a.x, max(a.y, a.z)));
    let l2 = dot(v, v);
    if (l2 > 0.0) {
        return v * inverseSqrt(l2);
    }
    return fallback;
}
