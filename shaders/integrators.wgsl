// #requires world
// #if FLAT
// #requires pigment environment
// #endif
// #if POINTLIGHT
// #requires environment
// #if POINT_LIGHTS
// #requires pigment brdf offset
// #endif
// #endif
// #if PATHTRACER
// #if POINT_LIGHTS
// #requires offset
// #endif
// #endif
// The first-hit integrators (DESIGN.md "Integrators"): OnOff, Flat, PointLight. The path
// tracer is in path_tracer.wgsl.

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

// #if POINT_LIGHTS
// Direct light from point light i at a surface point: the light's colour times its falloff
// f(d) and the unit direction to it, or zero when the light is behind the surface or
// occluded (the shadow ray is traced only when needed, as cpu::point_light_factor does).
struct PointLightSample {
    l: vec3<f32>,
    radiance: vec3<f32>,
}

fn point_light_at(i: u32, hit: Hit) -> PointLightSample {
    let light = point_lights[i];
    let to_light = light.position.xyz - hit.point;
    let dist = length(to_light);
    let l = to_light / dist;
    let origin = offset_origin(hit.point, hit.scale, hit.normal, l);
    // The shadow ray stops just short of the light (t < 1, exclusive).
    if (dist <= 0.0 || dot(hit.normal, l) <= 0.0 || occluded(Ray(origin, light.position.xyz - origin, 0.0, 1.0))) {
        return PointLightSample(l, vec3<f32>(0.0));
    }
    var falloff = 1.0;
    if (light.position.w > 0.0) {
        let q = light.position.w / dist;
        falloff = q * q;
    }
    return PointLightSample(l, light.color.xyz * falloff);
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
        let s = point_light_at(i, hit);
        let cos_theta = max(dot(hit.normal, s.l), 0.0);
        result += (emitted + eval_bsdf(m, color, hit.normal, s.l)) * s.radiance * cos_theta;
    }
// #endif
    return result;
}
// #endif
