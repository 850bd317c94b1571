// #requires bindings ray
// #if AREA_LIGHTS
// #requires shapes
// #endif
// #if SHADOWS
// #requires onb pigment
// #endif
// #if CUBE_LIGHTS
// #requires spherical_rectangle
// #endif
// Area lights for next-event estimation: mirrors cpu::area_light and cpu::warp (cone and
// sphere warps). Positions are in the camera frame.

struct LightPoint {
    point: vec3<f32>,
    // Error scale of `point` (offset::error_scale).
    scale: f32,
    normal: vec3<f32>,
    object_point: vec3<f32>,
    pdf: f32,
    // Meshes: the uv at the point (the object point alone does not give it).
    uv: vec2<f32>,
}

// #if AREA_LIGHTS
// #if MESH_LIGHTS
// 1 / (world area) as a solid-angle density at x, for a light point y of normal n.
fn mesh_light_pdf(light: AreaLight, x: vec3<f32>, y: vec3<f32>, n: vec3<f32>) -> f32 {
    let to_light = y - x;
    let dist2 = dot(to_light, to_light);
    let cos_light = abs(dot(normalize_or(n, vec3<f32>(0.0)), to_light)) / sqrt(dist2);
    if (!(cos_light > 0.0) || !(dist2 > 0.0)) {
        return 0.0;
    }
    return dist2 / (cos_light * light.area);
}

// #if SHADOWS
// prepare::MeshLight::choose and AreaLight::sample_mesh: the triangle ξ0 falls in by the
// CDF of world areas (file order), a uniform point on it by the rest of ξ0 and ξ1.
fn light_sample_mesh(light: AreaLight, s: Shape, x: vec3<f32>, xi0: f32, xi1: f32) -> LightPoint {
    let n = light.mesh_triangles;
    var lo = 0u;
    var hi = n;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (float_at(light.mesh_cdf + mid) <= xi0) {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    let t = min(lo, n - 1u);
    let below = select(float_at(light.mesh_cdf + t - 1u), 0.0, t == 0u);
    let width = float_at(light.mesh_cdf + t) - below;
    let u = select(0.5, clamp((xi0 - below) / width, 0.0, 1.0), width > 0.0);
    let tri = bitcast<u32>(float_at(light.mesh_cdf + n + t));
    let base = MESH_POSITION_VEC4S * tri;
    let p0 = tri_position_at(base).xyz;
    let p1 = tri_position_at(base + 1u).xyz;
    let p2 = tri_position_at(base + 2u).xyz;
    let su = sqrt(u);
    let b0 = 1.0 - su;
    let b1 = xi1 * su;
    let b2 = 1.0 - b0 - b1;
    let p_obj = b0 * p0 + b1 * p1 + b2 * p2;
    let y = affine_point(s.to_world, p_obj);
    let normal = normalize_or(affine_normal(s.to_object, cross(p1 - p0, p2 - p0)), vec3<f32>(0.0, 0.0, 1.0));
    var uv = vec2<f32>(b1, b2);
    if ((s.mesh & MESH_UVS) != 0u) {
        let sh = MESH_SHADING_VEC4S * tri;
        let uv01 = tri_shading_at(sh + 3u);
        uv = b0 * uv01.xy + b1 * uv01.zw + b2 * tri_shading_at(sh + 4u).xy;
    }
    let scale = affine_error_scale(s.to_world, max(max(abs(p0), abs(p1)), abs(p2)));
    return LightPoint(y, scale, normal, p_obj, mesh_light_pdf(light, x, y, normal), uv);
}
// #endif
// #endif
// #endif

const UNIFORM_SPHERE_PDF: f32 = 0.0795774715459477;

// #if SHADOWS
// (cos φ, sin φ) of φ = 2π·ξ: the azimuth every light sample of a vertex draws from the
// same ξ (cone, sphere and uniform environment alike), computed once for them all (each
// call of cos and sin compiles its own polynomial on llvmpipe).
fn turn(xi: f32) -> vec2<f32> {
    let phi = TAU * xi;
    return vec2<f32>(cos(phi), sin(phi));
}

// warp::uniform_sphere (sphere lights and the uniform environment), its azimuth given as
// turn(ξ1).
fn uniform_sphere(xi0: f32, azimuth: vec2<f32>) -> vec3<f32> {
    let z = 1.0 - 2.0 * xi0;
    let r = sqrt(max(1.0 - z * z, 0.0));
    return vec3<f32>(r * azimuth.x, r * azimuth.y, z);
}
// #endif

// #if AREA_LIGHTS
// Each kind of area light (SPHERE_LIGHTS, CUBE_LIGHTS, MESH_LIGHTS) has its code only where
// the scene has such a light: on SIMD software GPUs a branch some lane takes costs every
// lane (DESIGN.md "Software adapters"), and on llvmpipe every table load compiled in costs
// compile time whether it runs or not. PRIMITIVE_LIGHTS (sphere or cube lights, or lights
// not known to be meshes) holds what spheres and cubes share.

// #if SPHERE_LIGHTS
// warp::cone_one_minus_cos: 1 − cos θmax without cancellation.
fn cone_one_minus_cos(r: f32, d: f32) -> f32 {
    let sin2 = min((r / d) * (r / d), 1.0);
    let c = sqrt(1.0 - sin2);
    return sin2 / (1.0 + c);
}

fn uniform_cone_pdf(one_minus_cos_max: f32) -> f32 {
    return 1.0 / (TAU * one_minus_cos_max);
}

// Whether light i is sampled by its cone from x (a sphere, x outside it, not on it).
fn light_uses_cone(light: AreaLight, x: vec3<f32>, x_object: u32) -> bool {
    return light.sphere.w > 0.0 && x_object != light.shape && length(light.sphere.xyz - x) > light.sphere.w;
}
// #endif

// #if PRIMITIVE_LIGHTS
// #if LIGHT_NORMALS
// area_light::object_normal (for emission's MIS density and a textured light's face).
fn light_object_normal(kind: u32, p: vec3<f32>) -> vec3<f32> {
// #if SPHERE_LIGHTS
    if (kind == SHAPE_SPHERE) {
        return normalize(p);
    }
// #endif
    let a = abs(p);
    if (a.x >= a.y && a.x >= a.z) {
        return vec3<f32>(sign(p.x), 0.0, 0.0);
    }
    if (a.y >= a.z) {
        return vec3<f32>(0.0, sign(p.y), 0.0);
    }
    return vec3<f32>(0.0, 0.0, sign(p.z));
}
// #endif

// AreaLight::area_pdf_solid_angle: the area density 1 / area at y (outward object normal
// n_obj) as a solid-angle density at x.
fn light_area_pdf(s: Shape, x: vec3<f32>, y: vec3<f32>, n_obj: vec3<f32>, area: f32) -> f32 {
    let n_world = affine_normal(s.to_object, n_obj);
    let to_light = y - x;
    let dist2 = dot(to_light, to_light);
    let cos_light = abs(dot(normalize_or(n_world, vec3<f32>(0.0)), to_light)) / sqrt(dist2);
    if (!(cos_light > 0.0) || !(dist2 > 0.0) || !(area > 0.0)) {
        return 0.0;
    }
    return dist2 / (cos_light * area);
}

// #if SPHERE_LIGHTS
// AreaLight::sphere_area: the world area of the light's unit sphere by Nanson's formula
// at n_obj.
fn light_sphere_area(light: AreaLight, s: Shape, n_obj: vec3<f32>) -> f32 {
    return 2.0 * TAU * light.det * length(affine_normal(s.to_object, n_obj));
}
// #endif

// #if CUBE_LIGHTS
// AreaLight::cube_faces: the faces NEE samples from x (on object x_object), per axis the
// world area sampled there (one face's, both faces', or 0) and the side (±1: only the
// face x is in front of; 0: both). cpu::area_light's module documentation says why.
struct CubeFaces {
    weight: vec3<f32>,
    side: vec3<f32>,
}

fn cube_faces(light: AreaLight, s: Shape, x: vec3<f32>, x_object: u32) -> CubeFaces {
    if (x_object != light.shape) {
        let p = affine_point(s.to_object, x);
        let front = abs(p) > vec3<f32>(CUBE_FACE_REACH);
        let w = select(vec3<f32>(0.0), light.face_areas, front);
        if (w.x + w.y + w.z > 0.0) {
            return CubeFaces(w, select(vec3<f32>(0.0), sign(p), front));
        }
    }
    return CubeFaces(2.0 * light.face_areas, vec3<f32>(0.0));
}

// CubeFaces::area.
fn cube_faces_area(f: CubeFaces) -> f32 {
    return f.weight.x + f.weight.y + f.weight.z;
}

// CubeFaces::solid_angle_pdf: the density of a point drawn by solid angle on a face of
// sampled area `weight` (its share of the sampled area over its solid angle).
fn cube_face_solid_angle_pdf(f: CubeFaces, weight: f32, r: SphericalRectangle) -> f32 {
    return weight / (cube_faces_area(f) * r.solid_angle);
}

// The unit vector along object axis i (DVec3::AXES[i]).
fn unit_axis(i: u32) -> vec3<f32> {
    return select(vec3<f32>(0.0), vec3<f32>(1.0), vec3<u32>(i) == vec3<u32>(0u, 1u, 2u));
}

// AreaLight::solid_angle_face: the face of `axis` that f samples, seen from x, where NEE
// samples it by solid angle; solid_angle 0 where it samples that face by area (a sheared
// cube's parallelogram, both faces of the pair sampled, or Ω outside [SOLID_ANGLE_MIN,
// SOLID_ANGLE_MAX]).
fn solid_angle_face(light: AreaLight, s: Shape, x: vec3<f32>, f: CubeFaces, axis: u32) -> SphericalRectangle {
    var r: SphericalRectangle;
    let side = f.side[axis];
    if (side != 0.0 && (light.rectangular_faces & (1u << axis)) != 0u) {
        // The face's corner (−0.5 on its own two axes) and edges along its (u, v) axes
        // (area_light::face_axes), in the world.
        let corner = select(vec3<f32>(-0.5), vec3<f32>(0.5 * side), unit_axis(axis) > vec3<f32>(0.0));
        let c = affine_point(s.to_world, corner);
        let a = affine_vector(s.to_world, unit_axis((axis + 1u) % 3u));
        let b = affine_vector(s.to_world, unit_axis((axis + 2u) % 3u));
        if (may_subtend(x, c, a, b, SOLID_ANGLE_MIN)) {
            r = spherical_rectangle(x, c, a, b);
            if (!(r.solid_angle >= SOLID_ANGLE_MIN && r.solid_angle <= SOLID_ANGLE_MAX)) {
                r.solid_angle = 0.0;
            }
        }
    }
    return r;
}
// #endif

// #endif

// #if SHADOWS
// #if CUBE_LIGHTS
// area_light::CubeFace: the face NEE samples, picked from ξ0.
struct CubeFace {
    axis: u32,
    // +1 or −1: which face of the pair.
    side: f32,
    // The rest of ξ0, uniform in [0, 1) within the face: its first coordinate.
    u: f32,
}

// CubeFace::pick: the axis by ξ0 against the faces' weights, then the side (where both
// are sampled) and the face's first coordinate from the rest of ξ0.
fn pick_cube_face(f: CubeFaces, xi0: f32) -> CubeFace {
    let w = f.weight;
    let u = xi0 * cube_faces_area(f);
    // An axis of weight 0 is never chosen, even where rounding puts u at the end.
    var axis = 2u;
    var lo = w.x + w.y;
    if (u < w.x || (w.y == 0.0 && w.z == 0.0)) {
        axis = 0u;
        lo = 0.0;
    } else if (u < w.x + w.y || w.z == 0.0) {
        axis = 1u;
        lo = w.x;
    }
    let v = clamp((u - lo) / w[axis], 0.0, 0.99999994);
    if (f.side[axis] == 0.0) {
        // Both faces: v rescaled to [0, 2) gives the side (0: +, 1: −), then a coordinate.
        let v2 = 2.0 * v;
        let side = floor(v2);
        return CubeFace(axis, select(-1.0, 1.0, side == 0.0), v2 - side);
    }
    return CubeFace(axis, f.side[axis], v);
}

// CubeFace::point: the object point at fractions st of the face (s along the next axis,
// t along the one after), and the outward normal.
fn cube_face_point(face: CubeFace, st: vec2<f32>) -> array<vec3<f32>, 2> {
    let s = 0.5 * face.side;
    let a = st.x - 0.5;
    let b = st.y - 0.5;
    switch face.axis {
        case 0u: {
            return array<vec3<f32>, 2>(vec3<f32>(s, a, b), vec3<f32>(face.side, 0.0, 0.0));
        }
        case 1u: {
            return array<vec3<f32>, 2>(vec3<f32>(b, s, a), vec3<f32>(0.0, face.side, 0.0));
        }
        default: {
            return array<vec3<f32>, 2>(vec3<f32>(a, b, s), vec3<f32>(0.0, 0.0, face.side));
        }
    }
}
// #endif
// #endif

// #if SHADOWS
// #if SPHERE_LIGHTS
// area_light::sample_cone: a point on the sphere's visible cap, uniform in the cone of
// directions it subtends from x.
fn light_sample_cone(light: AreaLight, s: Shape, x: vec3<f32>, xi0: f32, azimuth: vec2<f32>) -> LightPoint {
    let c = light.sphere.xyz;
    let r = light.sphere.w;
    let d = length(c - x);
    let omc_max = cone_one_minus_cos(r, d);
    // warp::uniform_cone.
    let one_minus_cos = xi0 * omc_max;
    let cos_theta = 1.0 - one_minus_cos;
    let sin_theta0 = sqrt(max(one_minus_cos * (2.0 - one_minus_cos), 0.0));
    let local = vec3<f32>(sin_theta0 * azimuth.x, sin_theta0 * azimuth.y, cos_theta);
    let sin2_theta = local.x * local.x + local.y * local.y;
    let sin_theta_max = r / d;
    let cos_alpha = sin2_theta / sin_theta_max
        + cos_theta * sqrt(max(1.0 - sin2_theta / (sin_theta_max * sin_theta_max), 0.0));
    let sin_alpha = sqrt(max(1.0 - cos_alpha * cos_alpha, 0.0));
    let w = (c - x) / d;
    let frame = onb(w);
    let sin_theta = sqrt(sin2_theta);
    var e = frame.t;
    if (sin_theta > 0.0) {
        e = (frame.t * local.x + frame.b * local.y) / sin_theta;
    }
    let normal = normalize(e * sin_alpha - w * cos_alpha);
    let point = c + r * normal;
    // point = c + r·normal, so its terms are |c| and r·|normal|.
    let t = abs(c) + abs(r * normal);
    let scale = max(t.x, max(t.y, t.z));
    return LightPoint(point, scale, normal, affine_point(s.to_object, point), uniform_cone_pdf(omc_max), vec2<f32>(0.0));
}
// #endif
// #endif

// #if SHADOWS
// AreaLight::sample.
// `azimuth` is turn(xi1).
fn light_sample(light: AreaLight, s: Shape, x: vec3<f32>, x_object: u32, xi0: f32, xi1: f32, azimuth: vec2<f32>) -> LightPoint {
// #if SPHERE_LIGHTS
    if (light_uses_cone(light, x, x_object)) {
        return light_sample_cone(light, s, x, xi0, azimuth);
    }
// #endif
// #if MESH_LIGHTS
// #if PRIMITIVE_LIGHTS
    if (light.mesh_triangles > 0u) {
// #endif
        return light_sample_mesh(light, s, x, xi0, xi1);
// #if PRIMITIVE_LIGHTS
    }
// #endif
// #endif
// #if PRIMITIVE_LIGHTS
    var p_obj: vec3<f32>;
    var n_obj: vec3<f32>;
    var area: f32;
    // A density in solid angle already known (a cube face sampled by solid angle), else 0.
    var solid_pdf = 0.0;
// #if SPHERE_LIGHTS
    if (s.kind == SHAPE_SPHERE) {
        p_obj = uniform_sphere(xi0, azimuth);
        n_obj = p_obj;
        area = light_sphere_area(light, s, n_obj);
    }
// #endif
// #if CUBE_LIGHTS
    if (s.kind == SHAPE_CUBE) {
        // A face by ξ0, then a point on it from the rest of ξ0 and ξ1, by solid angle or
        // by area (cpu::area_light's module documentation).
        let f = cube_faces(light, s, x, x_object);
        let face = pick_cube_face(f, xi0);
        let r = solid_angle_face(light, s, x, f, face.axis);
        area = cube_faces_area(f);
        var st = vec2<f32>(face.u, xi1);
        if (r.solid_angle > 0.0) {
            st = spherical_rectangle_sample(r, face.u, xi1);
            solid_pdf = cube_face_solid_angle_pdf(f, f.weight[face.axis], r);
        }
        let pn = cube_face_point(face, st);
        p_obj = pn[0];
        n_obj = pn[1];
    }
// #endif
    let y = affine_point(s.to_world, p_obj);
    var pdf = solid_pdf;
    if (!(solid_pdf > 0.0)) {
        pdf = light_area_pdf(s, x, y, n_obj, area);
    }
    let scale = affine_error_scale(s.to_world, p_obj);
    let n_world = normalize_or(affine_normal(s.to_object, n_obj), vec3<f32>(0.0));
    return LightPoint(y, scale, n_world, p_obj, pdf, vec2<f32>(0.0));
// #endif
}
// #endif

// #if EMISSION
// AreaLight::pdf: density of light_sample producing y (geometric normal n_y) from x (for
// emission's MIS weight, in the shading stages of kinds with emitters).
fn light_pdf(light: AreaLight, s: Shape, x: vec3<f32>, x_object: u32, y: vec3<f32>, n_y: vec3<f32>) -> f32 {
// #if SPHERE_LIGHTS
    if (light_uses_cone(light, x, x_object)) {
        return uniform_cone_pdf(cone_one_minus_cos(light.sphere.w, length(light.sphere.xyz - x)));
    }
// #endif
// #if MESH_LIGHTS
// #if PRIMITIVE_LIGHTS
    if (light.mesh_triangles > 0u) {
// #endif
        return mesh_light_pdf(light, x, y, n_y);
// #if PRIMITIVE_LIGHTS
    }
// #endif
// #endif
// #if PRIMITIVE_LIGHTS
    let n_obj = light_object_normal(s.kind, affine_point(s.to_object, y));
// #if CUBE_LIGHTS
    if (s.kind == SHAPE_CUBE) {
        // CubeFaces::samples: 0 on a face the sampling skips from x. n_obj is ±1 on one
        // axis and 0 on the others, so dot products pick that axis's entries exactly.
        let f = cube_faces(light, s, x, x_object);
        let axis = abs(n_obj);
        let side = dot(f.side, axis);
        if (!(dot(f.weight, axis) > 0.0) || (side != 0.0 && side != dot(n_obj, vec3<f32>(1.0)))) {
            return 0.0;
        }
        let r = solid_angle_face(light, s, x, f, u32(dot(axis, vec3<f32>(0.0, 1.0, 2.0))));
        if (r.solid_angle > 0.0) {
            return cube_face_solid_angle_pdf(f, dot(f.weight, axis), r);
        }
        return light_area_pdf(s, x, y, n_obj, cube_faces_area(f));
    }
// #endif
// #if SPHERE_LIGHTS
    return light_area_pdf(s, x, y, n_obj, light_sphere_area(light, s, n_obj));
// #else
    return 0.0;
// #endif
// #endif
}
// #endif

// #if SHADOWS
// AreaLight::emission at a sampled point. (The light functions take the light's shape
// record `s` from the caller, which loads it once: on llvmpipe each load site of a
// lane-divergent storage record compiles a per-lane loop per word.)
fn light_emission(light: AreaLight, s: Shape, lp: LightPoint) -> vec3<f32> {
    let m = material_at(s.material);
// #if !TEXTURED_LIGHTS
    // Every area light emits a uniform pigment: no surface point to find on the light.
    return uniform_pigment_color(m.emitted);
// #else
// #if MESH_LIGHTS
// #if PRIMITIVE_LIGHTS
    if (light.mesh_triangles > 0u) {
// #endif
        return pigment_color(m.emitted, lp.uv);
// #if PRIMITIVE_LIGHTS
    }
// #endif
// #endif
// #if PRIMITIVE_LIGHTS
    let n = light_object_normal(s.kind, lp.object_point);
    var face = 0u;
// #if CUBE_LIGHTS
    if (s.kind == SHAPE_CUBE) {
        let a = abs(n);
        var axis = 0u;
        if (a.y > a.x && a.y >= a.z) {
            axis = 1u;
        } else if (a.z > a.x && a.z > a.y) {
            axis = 2u;
        }
        face = 2u * axis + select(0u, 1u, n[axis] > 0.0);
    }
// #endif
    let uv = primitive_surface(s.kind, lp.object_point, face).uv;
    return pigment_color(m.emitted, uv);
// #endif
// #endif
}
// #endif
// #endif

// Lights NEE chooses from: area lights, then the environment (cpu::lights::Lights).
fn light_count() -> u32 {
    return settings.area_light_count + environment.is_light;
}

fn light_selection_pdf() -> f32 {
    let n = light_count();
    return select(0.0, 1.0 / f32(n), n > 0u);
}
