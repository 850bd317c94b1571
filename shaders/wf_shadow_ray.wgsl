// #requires wavefront ray
// #if STAGE_SHADE
// #requires shadow_set
// #else
// #requires shadow_get
// #endif
// A path's shadow rays in `shadow`: batch.shadow_rays records per path slot of three vec4
// (origin and tmin; direction and tmax; contribution and 1), a record whose last word is 0
// ending the list (StateBuffer::Shadow: 48 bytes per ray). The shading stages write them,
// the shadow stage and the CSG stage's second launch read them.

fn shadow_index(slot: u32, k: u32) -> u32 {
    return 3u * (slot * batch.shadow_rays + k);
}

// #if STAGE_SHADE
// Shadow ray k of path `slot` (k < batch.shadow_rays) and what it adds if nothing blocks it.
fn queue_shadow(slot: u32, k: u32, ray: Ray, value: vec3<f32>) {
    let i = shadow_index(slot, k);
    shadow_set(i, vec4<f32>(ray.origin, ray.tmin));
    shadow_set(i + 1u, vec4<f32>(ray.dir, ray.tmax));
    shadow_set(i + 2u, vec4<f32>(value, 1.0));
}

// #if POINT_LIGHTS
// Ends the path's list after `count` rays (a full list needs no end mark).
fn end_shadows(slot: u32, count: u32) {
    if (count < batch.shadow_rays) {
        shadow_set(shadow_index(slot, count) + 2u, vec4<f32>(0.0));
    }
}
// #endif
// #else
struct ShadowRay {
    ray: Ray,
    value: vec3<f32>,
    // False past the end of the path's list.
    present: bool,
}

fn load_shadow_ray(slot: u32, k: u32) -> ShadowRay {
    let i = shadow_index(slot, k);
    let o = shadow_get(i);
    let d = shadow_get(i + 1u);
    let v = shadow_get(i + 2u);
    return ShadowRay(Ray(o.xyz, d.xyz, o.w, d.w), v.xyz, v.w != 0.0);
}
// #endif
