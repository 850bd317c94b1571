// #requires ray rescale
// The ray–sphere quadratic without cancellation: mirrors src/cpu/shapes/quadratic.rs.
// Used by the sphere and the cylinder's side.

// Roots t0 ≤ t1 of |f + t·d|² = r2 (x, y), or none (z = 0 flags a miss). d is rescaled by a
// power of two first (exact) so that |d|² neither underflows (shapes scaled by ≳ 1e19)
// nor overflows, and the roots are scaled back. Δ computed from the closest approach
// (Ray Tracing Gems ch. 7), corrected once by its own closest approach so that an inexact
// b/a (a GPU's division may be 2.5 ulp off) does not move it by |f|·ulp, roots as q/a and
// c/q: cpu::shapes::quadratic says more.
fn sphere_roots(f: vec3<f32>, d_in: vec3<f32>, r2: f32) -> vec3<f32> {
    let ad = abs(d_in);
    let s = pow2_rescale(max(ad.x, max(ad.y, ad.z)));
    let d = d_in * s;
    let a = dot(d, d);
    if (!(a > 0.0) || !(a < OPEN)) {
        return vec3<f32>(0.0, 0.0, 0.0);
    }
    let b = dot(f, d);
    let first = f - (b / a) * d;
    let closest = first - (dot(first, d) / a) * d;
    let disc = a * (r2 - dot(closest, closest));
    if (!(disc >= 0.0)) {
        return vec3<f32>(0.0, 0.0, 0.0);
    }
    let c = dot(f, f) - r2;
    let q = -(b + select(-1.0, 1.0, b >= 0.0) * sqrt(disc));
    var t0 = 0.0;
    var t1 = 0.0;
    if (q != 0.0) {
        t0 = q / a;
        t1 = c / q;
    }
    return vec3<f32>(min(t0, t1) * s, max(t0, t1) * s, 1.0);
}
