// #requires world
// #if FLAT
// #requires pigment environment
// #endif
// #if POINTLIGHT
// #requires environment
// #if POINT_LIGHTS
// #requires pigment brdf point_lights
// #endif
// #endif
// The first-hit integrators (DESIGN.md "Integrators"): OnOff, Flat, PointLight. The path
// tracer's stages are the wf_*.wgsl files.

// #if ONOFF
fn radiance_onoff(ray: Ray) -> vec3<f32> {
    if (occluded(ray)) {
        return settings.color0.xyz;
    }
    return settings.color1.xyz;
}
// #endif

// #if FLAT
fn radiance_flat(ray: Ray) -> vec3<f32> {
    let hit = closest_hit(ray);
    if (hit.t >= OPEN) {
        return escape_radiance(ray.dir);
    }
    let m = material_at(hit.material);
    return pigment_color(m.emitted, hit.uv) + pigment_color(m.pigment, hit.uv);
}
// #endif

// #if POINTLIGHT
// The camera ray (query 0, closest hit) and each lit light's shadow ray (query i + 1, any
// hit) go through one world_first call in one loop: Mesa inlines every call, so two call
// sites would compile the traversal, and a scene's CSG evaluation, twice into the kernel.
fn radiance_point_light(ray: Ray) -> vec3<f32> {
    var result = settings.color1.xyz;
    var queries = 1u;
    var hit: Hit;
// #if POINT_LIGHTS
    queries += settings.point_light_count;
    var m: Material;
    var emitted = vec3<f32>(0.0);
    var color = vec3<f32>(0.0);
    var s: PointLightSample;
// #endif
    for (var q = 0u; q < queries; q++) {
        var query = ray;
// #if POINT_LIGHTS
        if (q > 0u) {
            // Raytracer.jl's model: the shadow ray is traced only for lights in front (as
            // cpu::point_light_factor).
            s = point_light_sample(q - 1u, hit, false);
            if (!s.lit) {
                continue;
            }
            query = s.ray;
        }
// #endif
        let cand = world_first(query, q > 0u);
        if (q == 0u) {
            if (cand.c.t >= OPEN) {
                return escape_radiance(ray.dir);
            }
            hit = hit_of(cand, ray);
// #if POINT_LIGHTS
            m = material_at(hit.material);
            emitted = pigment_color(m.emitted, hit.uv);
            color = pigment_color(m.pigment, hit.uv);
// #endif
            continue;
        }
// #if POINT_LIGHTS
        if (cand.c.t >= OPEN) {
            let cos_theta = max(dot(hit.normal, s.l), 0.0);
            let f = eval_bsdf(m, color, bsdf_vertex(m, normalize(ray.dir), hit.normal, hit.front_face), s.l).xyz;
            result += (emitted + f) * s.radiance * cos_theta;
        }
// #endif
    }
    return result;
}
// #endif
