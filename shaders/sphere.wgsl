// Unit sphere and the robust quadratic: mirrors src/cpu/shapes/{quadratic,sphere}.rs.

// Roots t0 ≤ t1 of |f + t·d|² = r2 (x, y), or none (z = 0 flags a miss). Δ computed from
// the closest approach (Ray Tracing Gems ch. 7), roots as q/a and c/q.
fn sphere_roots(f: vec3<f32>, d: vec3<f32>, r2: f32) -> vec3<f32> {
    let a = dot(d, d);
    if (a == 0.0) {
        return vec3<f32>(0.0, 0.0, 0.0);
    }
    let b = dot(f, d);
    let closest = f - (b / a) * d;
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
    return vec3<f32>(min(t0, t1), max(t0, t1), 1.0);
}

fn sphere_span(o: vec3<f32>, d: vec3<f32>) -> Span {
    let r = sphere_roots(o, d, 1.0);
    if (r.z == 0.0) {
        return no_span();
    }
    return Span(Crossing(r.x, 0u), Crossing(r.y, 0u), true);
}

fn sphere_surface(p: vec3<f32>) -> SurfacePoint {
    let n = normalize_or(p, vec3<f32>(0.0, 0.0, 1.0));
    let uv = vec2<f32>(turns(n.y, n.x), acos(clamp(n.z, -1.0, 1.0)) / PI);
    return SurfacePoint(n, n, uv);
}
