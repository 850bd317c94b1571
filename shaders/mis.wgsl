// #requires wf_path bindings
// #if EMISSION
// #requires words_get
// #endif
// #if NEE
// #requires lights
// #endif
// #if ESCAPES
// #requires environment
// #if NEE
// #requires env_light
// #endif
// #endif
// The path tracer's multiple importance sampling (DESIGN.md "Integrators"): the previous
// vertex a path stores between stages, the power heuristic, and the MIS weight of radiance
// found by BSDF sampling (escaped rays here; emitters hit in wf_shade.wgsl).

// #if EMISSION
// What the next vertex needs to know about the one that scattered the ray to it (emission
// MIS; an escape needs only the density, pt_escaped).
struct Previous {
    point: vec3<f32>,
    object: u32,
    // Delta scattering (or the camera): what the ray finds gets full weight.
    delta: bool,
    pdf: f32,
}

// `beta` is the path's F_BETA field, which the caller has loaded anyway: its w is the
// previous BSDF density, negative for a delta vertex (storage loads are costly on llvmpipe
// and are not merged). The point and object (W_PREV) are read only by emission MIS, and
// only after a non-delta vertex: a delta vertex (and the camera, at every path's first
// hit) skips the load.
fn load_previous(slot: u32, beta: vec4<f32>) -> Previous {
    let delta = beta.w < 0.0;
    var w = vec4<u32>(0u);
    if (!delta) {
        w = words_get(field(W_PREV, slot));
    }
    return Previous(bitcast<vec3<f32>>(w.xyz), w.w, delta, beta.w);
}
// #endif

// #if NEE
// path_tracer::power_heuristic a² / (a² + b²), written with the ratio of the smaller density
// to the larger so that f32 does not overflow: a light seen edge-on has a solid-angle
// density beyond 1e19, whose square is ∞ (and ∞/∞ NaN).
fn power_heuristic(a: f32, b: f32) -> f32 {
    if (!(a > 0.0)) {
        return 0.0;
    }
    if (a >= b) {
        let r = b / a;
        return 1.0 / (1.0 + r * r);
    }
    let r = a / b;
    let r2 = r * r;
    return r2 / (1.0 + r2);
}
// #endif

// #if ESCAPES
// Radiance of an escaping ray, MIS-weighted when NEE samples the environment. NEE code
// compiled in still obeys settings.nee (as cpu::path_tracer does), so a full-featured
// kernel renders a scene without NEE correctly.
// An image environment's (u, v) (two precise atan2) is computed once for the radiance
// and the light's density. `prev_pdf` is the previous vertex's BSDF density as the path's
// throughput field keeps it (negative after a delta vertex or the camera): the escape
// reads nothing else of that vertex, so no `words` load (load_previous).
fn pt_escaped(prev_pdf: f32, dir: vec3<f32>) -> vec3<f32> {
    if (environment.is_light == 0u) {
        return vec3<f32>(0.0);
    }
    let d = escape_direction(dir);
    var le = environment.a.xyz;
// #if ENV_GRADIENT
    if (environment.kind == ENV_GRADIENT) {
        le = env_gradient_radiance(d);
    }
// #endif
// #if ENV_IMAGE
    var uv = vec2<f32>(0.0);
    if (environment.kind == ENV_IMAGE) {
        uv = equirect_uv(d, environment.rotation_rad);
        le = env_image_radiance(uv);
    }
// #endif
// #if NEE
    // The light's density only where MIS weighs it: camera rays and rays leaving delta
    // surfaces (most of a sky-lit scene's escapes) skip the image's two table reads.
    if (settings.nee == 0u || prev_pdf < 0.0) {
        return le;
    }
    var pdf = UNIFORM_SPHERE_PDF;
// #if ENV_IMAGE
    if (environment.kind == ENV_IMAGE) {
        pdf = env_image_pdf_at(uv);
    }
// #endif
    return le * power_heuristic(prev_pdf, light_selection_pdf() * pdf);
// #else
    return le;
// #endif
}
// #endif
