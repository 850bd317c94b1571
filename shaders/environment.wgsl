// #requires bindings ray normalize
// #if ENV_IMAGE
// #requires textures
// #if !STAGE_SHADE
// #requires angles cell_index
// #endif
// #endif
// What escaping rays see: mirrors scene::Environment::radiance and cpu::env_light. Without
// a scene environment the packer stores a uniform one of the background colour.

// #if ENV_IMAGE
// The image's radiance over texel (col, row): scene::texel_radiance.
fn env_texel_radiance(col: u32, row: u32) -> vec3<f32> {
    return texel(environment.tex_offset, environment.tex_width, col, row) * environment.intensity;
}

// #if !STAGE_SHADE
// (A shading stage meets the image only through NEE, whose sample carries its texel's
// radiance: env_sample.)
// (u, v) of a unit direction on the equirectangular map: scene::equirect_uv.
fn equirect_uv(d: vec3<f32>, rotation_rad: f32) -> vec2<f32> {
    var u = (atan2_precise(d.y, d.x) - rotation_rad) / TAU;
    u -= floor(u);
    if (u >= 1.0) {
        u = 0.0;
    }
    return vec2<f32>(u, atan2_precise(length(d.xy), d.z) / PI);
}

// The image's radiance at (u, v).
fn env_image_radiance(uv: vec2<f32>) -> vec3<f32> {
    let w = environment.tex_width;
    let h = environment.tex_height;
    let col = cell_index(uv.x * f32(w), w);
    let row = cell_index(uv.y * f32(h), h);
    return env_texel_radiance(col, row);
}
// #endif
// #endif

// #if ENV_GRADIENT
fn env_gradient_radiance(d: vec3<f32>) -> vec3<f32> {
    if (d.z >= 0.0) {
        return environment.b.xyz * (1.0 - d.z) + environment.a.xyz * d.z;
    }
    return environment.b.xyz * (1.0 + d.z) + environment.c.xyz * (-d.z);
}
// #endif

fn escape_direction(dir: vec3<f32>) -> vec3<f32> {
    return normalize_or(dir, vec3<f32>(0.0, 0.0, 1.0));
}

// #if !ESCAPES
// (Escaped rays of the path tracer look the environment up in pt_escaped, with its MIS
// density: wf_classify.wgsl.)
fn escape_radiance(dir: vec3<f32>) -> vec3<f32> {
    let d = escape_direction(dir);
// #if ENV_GRADIENT
    if (environment.kind == ENV_GRADIENT) {
        return env_gradient_radiance(d);
    }
// #endif
// #if ENV_IMAGE
// #if !STAGE_SHADE
    if (environment.kind == ENV_IMAGE) {
        return env_image_radiance(equirect_uv(d, environment.rotation_rad));
    }
// #endif
// #endif
    return environment.a.xyz;
}
// #endif
