// #requires ray
// Unit cube [−0.5, 0.5]³: mirrors src/cpu/shapes/cube.rs. Face = 2·axis + (1 on the + side).

// CUBE_FACE_LAYOUT: (col, row, axis_u, sign_u, axis_v, sign_v) per face.
const CUBE_FACE_COL = array<f32, 6>(0.0, 2.0, 1.0, 1.0, 1.0, 3.0);
const CUBE_FACE_ROW = array<f32, 6>(1.0, 1.0, 0.0, 2.0, 1.0, 1.0);
const CUBE_FACE_AXIS_U = array<u32, 6>(2u, 2u, 0u, 0u, 0u, 0u);
const CUBE_FACE_SIGN_U = array<f32, 6>(-1.0, 1.0, 1.0, 1.0, 1.0, -1.0);
const CUBE_FACE_AXIS_V = array<u32, 6>(1u, 1u, 2u, 2u, 1u, 1u);
const CUBE_FACE_SIGN_V = array<f32, 6>(1.0, 1.0, -1.0, 1.0, 1.0, 1.0);

// #if SHAPE_SPANS
// The slab test of src/cpu/shapes/cube.rs in straight-line vector code (the same divisions
// and comparisons, in the same axis order, so the same crossings): a per-axis loop with an
// early return stays a loop on llvmpipe, run masked around each listed cube.
fn cube_span(o: vec3<f32>, d: vec3<f32>) -> Span {
    // An axis the line runs parallel to bounds nothing if the origin is inside its slab,
    // and leaves no span otherwise.
    let parallel = d == vec3<f32>(0.0);
    if (any(parallel & (abs(o) > vec3<f32>(0.5)))) {
        return no_span();
    }
    let dd = select(d, vec3<f32>(1.0), parallel);
    let t_lo = (vec3<f32>(-0.5) - o) / dd;
    let t_hi = (vec3<f32>(0.5) - o) / dd;
    let up = d > vec3<f32>(0.0);
    let near = select(select(t_hi, t_lo, up), vec3<f32>(-OPEN), parallel);
    let far = select(select(t_lo, t_hi, up), vec3<f32>(OPEN), parallel);
    // Face 2·axis + 1 on the + side: a line going up enters on the − side.
    let near_face = vec3<u32>(0u, 2u, 4u) + select(vec3<u32>(1u), vec3<u32>(0u), up);
    let far_face = vec3<u32>(0u, 2u, 4u) + select(vec3<u32>(0u), vec3<u32>(1u), up);
    // The latest entry and earliest exit, an earlier axis winning ties (as the loop).
    var enter = Crossing(-OPEN, 0u);
    var exit = Crossing(OPEN, 0u);
    for (var axis = 0u; axis < 3u; axis++) {
        let later = near[axis] > enter.t;
        enter = Crossing(select(enter.t, near[axis], later), select(enter.face, near_face[axis], later));
        let sooner = far[axis] < exit.t;
        exit = Crossing(select(exit.t, far[axis], sooner), select(exit.face, far_face[axis], sooner));
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
// #if CUBE_UV_UNUSED
    // No material of this shading stage reads a pigment on a cube (features::UV_SHAPES).
    let uv = vec2<f32>(0.0);
// #else
    let cu = CUBE_FACE_SIGN_U[face] * point[CUBE_FACE_AXIS_U[face]] * 2.0;
    let cv = CUBE_FACE_SIGN_V[face] * point[CUBE_FACE_AXIS_V[face]] * 2.0;
    let uv = vec2<f32>((CUBE_FACE_COL[face] + 0.5 * (cu + 1.0)) / 4.0, (CUBE_FACE_ROW[face] + 0.5 * (cv + 1.0)) / 3.0);
// #endif
    return SurfacePoint(point, normal, uv);
}
// #endif
