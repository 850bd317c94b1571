// #requires ray
// Unit cube [−0.5, 0.5]³: mirrors src/cpu/shapes/cube.rs. Face = 2·axis + (1 on the + side).

// CUBE_FACE_LAYOUT: (col, row, axis_u, sign_u, axis_v, sign_v) per face.
const CUBE_FACE_COL = array<f32, 6>(0.0, 2.0, 1.0, 1.0, 1.0, 3.0);
const CUBE_FACE_ROW = array<f32, 6>(1.0, 1.0, 0.0, 2.0, 1.0, 1.0);
const CUBE_FACE_AXIS_U = array<u32, 6>(2u, 2u, 0u, 0u, 0u, 0u);
const CUBE_FACE_SIGN_U = array<f32, 6>(-1.0, 1.0, 1.0, 1.0, 1.0, -1.0);
const CUBE_FACE_AXIS_V = array<u32, 6>(1u, 1u, 2u, 2u, 1u, 1u);
const CUBE_FACE_SIGN_V = array<f32, 6>(1.0, 1.0, -1.0, 1.0, 1.0, 1.0);

// #if SPANS
fn cube_span(o: vec3<f32>, d: vec3<f32>) -> Span {
    var enter = Crossing(-OPEN, 0u);
    var exit = Crossing(OPEN, 0u);
    for (var axis = 0u; axis < 3u; axis++) {
        let oi = o[axis];
        let di = d[axis];
        if (di == 0.0) {
            if (abs(oi) > 0.5) {
                return no_span();
            }
            continue;
        }
        let t_lo = (-0.5 - oi) / di;
        let t_hi = (0.5 - oi) / di;
        let face = 2u * axis;
        var near = Crossing(t_hi, face + 1u);
        var far = Crossing(t_lo, face);
        if (di > 0.0) {
            near = Crossing(t_lo, face);
            far = Crossing(t_hi, face + 1u);
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
fn cube_surface(p: vec3<f32>, face_in: u32) -> SurfacePoint {
    let face = min(face_in, 5u);
    let axis = face / 2u;
    let s = select(-0.5, 0.5, face % 2u == 1u);
    var point = clamp(p, vec3<f32>(-0.5), vec3<f32>(0.5));
    point[axis] = s;
    var normal = vec3<f32>(0.0);
    normal[axis] = s * 2.0;
    let cu = CUBE_FACE_SIGN_U[face] * point[CUBE_FACE_AXIS_U[face]] * 2.0;
    let cv = CUBE_FACE_SIGN_V[face] * point[CUBE_FACE_AXIS_V[face]] * 2.0;
    let uv = vec2<f32>((CUBE_FACE_COL[face] + 0.5 * (cu + 1.0)) / 4.0, (CUBE_FACE_ROW[face] + 0.5 * (cv + 1.0)) / 3.0);
    return SurfacePoint(point, normal, uv);
}
// #endif
