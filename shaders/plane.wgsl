// #requires ray
// Unit plane z = 0 (the half-space z ≤ 0 in CSG): mirrors src/cpu/shapes/plane.rs.

// #if SPANS
fn plane_span(o: vec3<f32>, d: vec3<f32>) -> Span {
    // Parallel within PLANE_PARALLEL_SLOPE (prepare::PLANE_PARALLEL_SLOPE): the plane is all
    // inside or all outside, whichever way rounding tipped d.z.
    let a = abs(d);
    if (a.z <= PLANE_PARALLEL_SLOPE * max(a.x, max(a.y, a.z))) {
        if (o.z <= 0.0) {
            return Span(Crossing(-OPEN, 0u), Crossing(OPEN, 0u), true);
        }
        return no_span();
    }
    let t = -o.z / d.z;
    if (d.z > 0.0) {
        return Span(Crossing(-OPEN, 0u), Crossing(t, 0u), true);
    }
    return Span(Crossing(t, 0u), Crossing(OPEN, 0u), true);
}
// #endif

// #if SHADING
fn plane_frac(x: f32) -> f32 {
    let f = x - floor(x);
    return select(f, 0.0, f >= 1.0);
}

fn plane_surface(p: vec3<f32>) -> SurfacePoint {
    return SurfacePoint(vec3<f32>(p.x, p.y, 0.0), vec3<f32>(0.0, 0.0, 1.0), vec2<f32>(plane_frac(p.x), plane_frac(p.y)));
}
// #endif
