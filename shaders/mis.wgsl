// #requires wf_path bindings
// #if NEE
// #requires lights
// #endif
// #if STAGE_ESCAPE
// #requires environment
// #if NEE
// #requires env_light
// #endif
// #endif
// The path tracer's multiple importance sampling (DESIGN.md "Integrators"): the previous
// vertex a path stores between stages, the power heuristic, and the MIS weight of radiance
// found by BSDF sampling (escaped rays here; emitters hit in wf_shade.wgsl).

// What the next vertex needs to know about the one that scattered the ray to it.
struct Previous {
    point: vec3<f32>,
    object: u32,
    // Delta scattering (or the camera): what the ray finds gets full weight.
    delta: bool,
    pdf: f32,
}

fn load_previous(slot: u32) -> Previous {
    let w = words[field(W_PREV, slot)];
    return Previous(paths[field(F_PREV, slot)].xyz, w.x, w.y != 0u, paths[field(F_BETA, slot)].w);
}

// #if NEE
fn power_heuristic(a: f32, b: f32) -> f32 {
    let a2 = a * a;
    let b2 = b * b;
    if (a2 + b2 > 0.0) {
        return a2 / (a2 + b2);
    }
    return 0.0;
}
// #endif

// #if STAGE_ESCAPE
// Radiance of an escaping ray, MIS-weighted when NEE samples the environment. NEE code
// compiled in still obeys settings.nee (as cpu::path_tracer does), so a full-featured
// kernel renders a scene without NEE correctly.
fn pt_escaped(prev: Previous, dir: vec3<f32>) -> vec3<f32> {
    if (environment.is_light == 0u) {
        return vec3<f32>(0.0);
    }
    let le = escape_radiance(dir);
// #if NEE
    if (settings.nee == 0u || prev.delta) {
        return le;
    }
    return le * power_heuristic(prev.pdf, light_selection_pdf() * env_pdf(dir));
// #else
    return le;
// #endif
}
// #endif
