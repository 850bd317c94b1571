// #requires ray
// #if SHAPE_SPANS
// #requires quadratic
// #endif
// #if SHADING
// #if !CYLINDER_UV_UNUSED
// #requires angles
// #endif
// #endif
// Unit cylinder (axis z, radius 0.5, z ∈ [−0.5, 0.5], capped): mirrors
// src/cpu/shapes/cylinder.rs. Faces: 0 side, 1 bottom cap, 2 top cap.

// #if SHAPE_SPANS
fn cylinder_span(o: vec3<f32>, d: vec3<f32>) -> Span {
    let fxy = vec3<f32>(o.x, o.y, 0.0);
    let dxy = vec3<f32>(d.x, d.y, 0.0);
    var enter = Crossing(-OPEN, 0u);
    var exit = Crossing(OPEN, 0u);
    if (d.x == 0.0 && d.y == 0.0) {
        if (dot(fxy, fxy) > 0.25) {
            return no_span();
        }
    } else {
        let r = sphere_roots(fxy, dxy, 0.25);
        if (r.z == 0.0) {
            return no_span();
        }
        enter = Crossing(r.x, 0u);
        exit = Crossing(r.y, 0u);
    }
    if (d.z == 0.0) {
        if (abs(o.z) > 0.5) {
            return no_span();
        }
    } else {
        let t_lo = (-0.5 - o.z) / d.z;
        let t_hi = (0.5 - o.z) / d.z;
        var near = Crossing(t_hi, 2u);
        var far = Crossing(t_lo, 1u);
        if (d.z > 0.0) {
            near = Crossing(t_lo, 1u);
            far = Crossing(t_hi, 2u);
        }
        if (near.t > enter.t) {
            enter = near;
        }
        if (far.t < exit.t) {
            exit = far;
        }
    }
    if (enter.t <= exit.t) {
        return Span(enter, exit, true);
    }
    return no_span();
}
// #endif

// #if SHADING
fn cylinder_surface(p: vec3<f32>, face: u32) -> SurfacePoint {
    if (face == 0u) {
        let r = normalize_or(vec3<f32>(p.x, p.y, 0.0), vec3<f32>(1.0, 0.0, 0.0));
        let z = clamp(p.z, -0.5, 0.5);
// #if CYLINDER_UV_UNUSED
        // No material of this shading stage reads a pigment on a cylinder (features::UV_SHAPES).
        let uv = vec2<f32>(0.0);
// #else
        let uv = vec2<f32>(z + 0.5, (atan2_precise(r.y, r.x) / TAU + 1.0) / 2.0);
// #endif
        return SurfacePoint(vec3<f32>(0.5 * r.x, 0.5 * r.y, z), r, uv);
    }
    if (face == 2u) {
        return SurfacePoint(vec3<f32>(p.x, p.y, 0.5), vec3<f32>(0.0, 0.0, 1.0),
            vec2<f32>((3.0 - 2.0 * p.x) / 4.0, (3.0 - 2.0 * p.y) / 4.0));
    }
    return SurfacePoint(vec3<f32>(p.x, p.y, -0.5), vec3<f32>(0.0, 0.0, -1.0),
        vec2<f32>((3.0 - 2.0 * p.x) / 4.0, (1.0 + 2.0 * p.y) / 4.0));
}
// #endif
