// #requires bindings ray
// #if ENV_IMAGE
// #requires textures angles
// #endif
// What escaping rays see: mirrors scene::Environment::radiance and cpu::env_light. Without
// a scene environment the packer stores a uniform one of the background colour.

// #if ENV_IMAGE
// (u, v) of a unit direction on the equirectangular map: scene::equirect_uv.
fn equirect_uv(d: vec3<f32>, rotation_rad: f32) -> vec2<f32> {
    var u = (atan2_precise(d.y, d.x) - rotation_rad) / TAU;
    u -= floor(u);
    if (u >= 1.0) {
        u = 0.0;
    }
    return vec2<f32>(u, atan2_precise(length(d.xy), d.z) / PI);
}
// #endif

fn escape_radiance(dir: vec3<f32>) -> vec3<f32> {
    let d = normalize_or(dir, vec3<f32>(0.0, 0.0, 1.0));
// #if ENV_GRADIENT
    if (environment.kind == ENV_GRADIENT) {
        if (d.z >= 0.0) {
            return environment.b.xyz * (1.0 - d.z) + environment.a.xyz * d.z;
        }
        return environment.b.xyz * (1.0 + d.z) + environment.c.xyz * (-d.z);
    }
// #endif
// #if ENV_IMAGE
    if (environment.kind == ENV_IMAGE) {
        let uv = equirect_uv(d, environment.rotation_rad);
        let w = environment.tex_width;
        let h = environment.tex_height;
        let col = min(u32(uv.x * f32(w)), w - 1u);
        let row = min(u32(uv.y * f32(h)), h - 1u);
        return texel(environment.tex_offset, w, col, row) * environment.intensity;
    }
// #endif
    return environment.a.xyz;
}
