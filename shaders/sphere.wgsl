// #requires ray
// #if SHAPE_SPANS
// #requires quadratic
// #endif
// #if SHADING
// #if !SPHERE_UV_UNUSED
// #requires angles
// #endif
// #endif
// Unit sphere (radius 1 at the origin): mirrors src/cpu/shapes/sphere.rs.

// #if SHAPE_SPANS
fn sphere_span(o: vec3<f32>, d: vec3<f32>) -> Span {
    let r = sphere_roots(o, d, 1.0);
    if (r.z == 0.0) {
        return no_span();
    }
    return Span(Crossing(r.x, 0u), Crossing(r.y, 0u), true);
}
// #endif

// #if SHADING
// #if !SPHERE_UV_UNUSED
// atan2(y, x)/2π wrapped to [0, 1).
fn turns(y: f32, x: f32) -> f32 {
    var u = atan2_precise(y, x) / TAU;
    if (u < 0.0) {
        u += 1.0;
    }
    if (u >= 1.0) {
        u = 0.0;
    }
    return u;
}
// #endif

fn sphere_surface(p: vec3<f32>) -> SurfacePoint {
    let n = normalize_or(p, vec3<f32>(0.0, 0.0, 1.0));
// #if SPHERE_UV_UNUSED
    // No material of this shading stage reads a pigment on a sphere (features::UV_SHAPES).
    let uv = vec2<f32>(0.0);
// #else
    let uv = vec2<f32>(turns(n.y, n.x), atan2_precise(length(n.xy), n.z) / PI);
// #endif
    return SurfacePoint(n, n, uv);
}
// #endif
