// #requires bindings ray
// #if SPHERE
// #requires sphere
// #endif
// #if PLANE
// #requires plane
// #endif
// #if CUBE
// #requires cube
// #endif
// #if CYLINDER
// #requires cylinder
// #endif
// #if MESH
// #requires mesh
// #endif
// #if ROUND_SPHERES
// #requires quadratic
// #endif
// Placed primitives: mirrors src/cpu/shapes/{mod,instance}.rs. The ray moves into object
// space without normalising its direction, so t means the same point in both spaces.

// #if GEOMETRY
// #if SPANS
// #if SHAPE_SPANS
fn primitive_span(kind: u32, o: vec3<f32>, d: vec3<f32>) -> Span {
    switch kind {
// #if SPHERE
        case SHAPE_SPHERE: {
            return sphere_span(o, d);
        }
// #endif
// #if PLANE
        case SHAPE_PLANE: {
            return plane_span(o, d);
        }
// #endif
// #if CUBE
        case SHAPE_CUBE: {
            return cube_span(o, d);
        }
// #endif
// #if CYLINDER
        case SHAPE_CYLINDER: {
            return cylinder_span(o, d);
        }
// #endif
        default: {
            return no_span();
        }
    }
}

// The span of the ray's whole line through the shape of record `s`, of kind `kind`
// (`s.kind`, or the same kind as a constant where gpu::traversal's unrolled lists know it).
fn record_span(s: Shape, kind: u32, ray: Ray) -> Span {
    return primitive_span(kind, affine_point(s.to_object, ray.origin), affine_vector(s.to_object, ray.dir));
}

// #if INDEXED_SHAPES
// The span of the ray's whole line through shape `i`.
fn shape_span(i: u32, ray: Ray) -> Span {
    let s = shape_at(i);
    return record_span(s, s.kind, ray);
}
// #endif
// #endif

// #endif

// #if TRAVERSE
// The first finite crossing in `sp` with t in the open range (tmin, tmax); t = OPEN when
// there is none.
fn span_first_crossing(sp: Span, ray: Ray) -> Crossing {
    if (sp.valid) {
        if (sp.enter.t > ray.tmin && sp.enter.t < ray.tmax && abs(sp.enter.t) < OPEN) {
            return sp.enter;
        }
        if (sp.exit.t > ray.tmin && sp.exit.t < ray.tmax && abs(sp.exit.t) < OPEN) {
            return sp.exit;
        }
    }
    return Crossing(OPEN, 0u);
}

// #if BVH
// #if !OBJECT_LIST
// The first finite crossing of bounded shape `i` with t in the open range (tmin, tmax);
// t = OPEN when there is none. (A list's shapes are tested by gpu::traversal's generated
// code, their kinds known.)
fn shape_first_crossing(i: u32, ray: Ray) -> Crossing {
// #if MESH
    if (shape_at(i).kind == SHAPE_MESH) {
        return mesh_first_crossing(i, ray);
    }
// #endif
// #if ROUND_SPHERES
    // Every finite shape is a round sphere (prepare::round_spheres, as cpu::World's
    // round_first_crossing): the quadratic in the world, about the centre (to_world's
    // translation) with the squared radius (the squared length of its first row, s² for
    // s·R), from six of the record's words where the object-space test loads thirteen.
    // t is the same parameter either way.
    let w = shape_at(i).to_world;
    let r = sphere_roots(ray.origin - vec3<f32>(w.r0.w, w.r1.w, w.r2.w), ray.dir, dot(w.r0.xyz, w.r0.xyz));
    if (r.z == 0.0) {
        return Crossing(OPEN, 0u);
    }
    return span_first_crossing(Span(Crossing(r.x, 0u), Crossing(r.y, 0u), true), ray);
// #else
    return span_first_crossing(shape_span(i, ray), ray);
// #endif
}
// #endif
// #endif

// #if PLANE
// The first finite crossing of plane `i` with t in (tmin, tmax), as shape_first_crossing.
fn plane_first_crossing(i: u32, ray: Ray) -> Crossing {
    let s = shape_at(i);
    return span_first_crossing(plane_span(affine_point(s.to_object, ray.origin), affine_vector(s.to_object, ray.dir)), ray);
}
// #endif
// #endif

// #if SHADING
fn primitive_surface(kind: u32, p: vec3<f32>, face: u32) -> SurfacePoint {
    switch kind {
// #if SPHERE
        case SHAPE_SPHERE: {
            return sphere_surface(p);
        }
// #endif
// #if PLANE
        case SHAPE_PLANE: {
            return plane_surface(p);
        }
// #endif
// #if CUBE
        case SHAPE_CUBE: {
            return cube_surface(p, face);
        }
// #endif
// #if CYLINDER
        case SHAPE_CYLINDER: {
            return cylinder_surface(p, face);
        }
// #endif
        default: {
            return SurfacePoint(p, vec3<f32>(0.0, 0.0, 1.0), vec2<f32>(0.0));
        }
    }
}

// The hit at crossing `c` of the shape whose record is `s` (loaded by the caller, which may
// need it again); `flip` reverses the outward normal (surfaces
// carved by a subtracted CSG child).
fn shape_surface_hit(s: Shape, ray: Ray, c: Crossing, flip: bool, object: u32) -> Hit {
// #if MESH
    if (s.kind == SHAPE_MESH) {
        return mesh_surface_hit(s, ray, c, object);
    }
// #endif
    let o = affine_point(s.to_object, ray.origin);
    let d = affine_vector(s.to_object, ray.dir);
    let sp = primitive_surface(s.kind, o + c.t * d, c.face);
    let point = affine_point(s.to_world, sp.point);
    let n = normalize_or(affine_normal(s.to_object, sp.normal), vec3<f32>(0.0));
    let outward = select(n, -n, flip);
    let front_face = dot(outward, ray.dir) < 0.0;
    let normal = select(-outward, outward, front_face);
    let scale = affine_error_scale(s.to_world, sp.point);
    return Hit(c.t, point, scale, normal, normal, front_face, sp.uv, s.material, object);
}
// #endif
// #endif

// A candidate hit, kept cheap until the closest is known: the crossing, the primitive
// that produced it, whether its normal is flipped (CSG DIFF), the top-level object.
struct Candidate {
    c: Crossing,
    shape: u32,
    flip: bool,
    object: u32,
}

// #if !STAGE_SHADE
fn no_candidate() -> Candidate {
    return Candidate(Crossing(OPEN, 0u), 0u, false, 0u);
}
// #endif
