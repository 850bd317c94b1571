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
    let m = materials[hit.material];
    return pigment_color(m.emitted, hit.uv) + pigment_color(m.pigment, hit.uv);
}
// #endif

// #if POINTLIGHT
fn radiance_point_light(ray: Ray) -> vec3<f32> {
    let hit = closest_hit(ray);
    if (hit.t >= OPEN) {
        return escape_radiance(ray.dir);
    }
    var result = settings.color1.xyz;
// #if POINT_LIGHTS
    let m = materials[hit.material];
    let emitted = pigment_color(m.emitted, hit.uv);
    let color = pigment_color(m.pigment, hit.uv);
    for (var i = 0u; i < settings.point_light_count; i++) {
        let s = point_light_sample(i, hit);
        // The shadow ray is traced only for lights in front (as cpu::point_light_factor).
        if (s.lit && !occluded(s.ray)) {
            let cos_theta = max(dot(hit.normal, s.l), 0.0);
            let f = eval_bsdf(m, color, normalize(ray.dir), hit.normal, hit.front_face, s.l);
            result += (emitted + f) * s.radiance * cos_theta;
        }
    }
// #endif
    return result;
}
// #endif
