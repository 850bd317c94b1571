// #requires layout
// #if SHADING
// #requires normalize
// #endif
// Rays, crossings and hits in f32: mirrors src/cpu/{ray,hit}.rs and the Span/Crossing
// types of src/cpu/shapes. Coordinates are relative to the camera (DESIGN.md "GPU renderer").

// Stands for ±∞ at the open ends of spans (WGSL has no infinity literal).
const OPEN: f32 = 3.0e38;
const PI: f32 = 3.14159265358979;
const TAU: f32 = 6.28318530717959;
const INV_PI: f32 = 0.318309886183791;

struct Ray {
    origin: vec3<f32>,
    dir: vec3<f32>,
    tmin: f32,
    tmax: f32,
}

// Where a line crosses a primitive's surface (face as in src/cpu/shapes).
struct Crossing {
    t: f32,
    face: u32,
}

// The interval of the line inside a solid; `valid` is false when the line misses it.
struct Span {
    enter: Crossing,
    exit: Crossing,
    valid: bool,
}

// #if SPANS
fn no_span() -> Span {
    return Span(Crossing(OPEN, 0u), Crossing(-OPEN, 0u), false);
}
// #endif

// Object-space surface data at a crossing.
struct SurfacePoint {
    point: vec3<f32>,
    normal: vec3<f32>,
    uv: vec2<f32>,
}

struct Hit {
    t: f32,
    point: vec3<f32>,
    // Error scale of `point` (offset::error_scale): what spawned rays offset by.
    scale: f32,
    // Unit shading normal facing the incoming ray.
    normal: vec3<f32>,
    // Unit geometric normal facing the incoming ray: sidedness and offsets (differs from
    // `normal` only on smooth meshes).
    geometric: vec3<f32>,
    front_face: bool,
    uv: vec2<f32>,
    material: u32,
    // Index of the top-level object.
    object: u32,
}

// #if AFFINE
fn affine_point(a: Affine, p: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(a.r0.xyz, p) + a.r0.w, dot(a.r1.xyz, p) + a.r1.w, dot(a.r2.xyz, p) + a.r2.w);
}

fn affine_vector(a: Affine, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(a.r0.xyz, v), dot(a.r1.xyz, v), dot(a.r2.xyz, v));
}
// #endif

// #if SHADING
// #if GEOMETRY
// offset::error_scale: the largest over the coordinates of Σⱼ |aᵢⱼ·pⱼ| + |tᵢ|, the size of
// the terms the point affine_point(a, p) is computed from.
fn affine_error_scale(a: Affine, p: vec3<f32>) -> f32 {
    let q = abs(p);
    let x = dot(abs(a.r0.xyz), q) + abs(a.r0.w);
    let y = dot(abs(a.r1.xyz), q) + abs(a.r1.w);
    let z = dot(abs(a.r2.xyz), q) + abs(a.r2.w);
    return max(x, max(y, z));
}

// Normal out of object space with the inverse transpose: the transpose of the
// world-to-object linear part.
fn affine_normal(to_object: Affine, n: vec3<f32>) -> vec3<f32> {
    return n.x * to_object.r0.xyz + n.y * to_object.r1.xyz + n.z * to_object.r2.xyz;
}
// #endif
// #endif
