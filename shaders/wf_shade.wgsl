// #requires mis random pigment brdf offset constants wf_hit
// #if POINT_LIGHTS
// #requires point_lights
// #endif
// #if SHADOWS
// #requires wf_shadow_ray
// #if NEE
// #requires env_light
// #endif
// #endif
// Shading stage of one BRDF kind (SHADE_QUEUE; src/gpu/wavefront/stages.rs compiles one per
// kind the scene uses, each with only its BRDF's code): one path vertex of
// cpu::path_tracer per invocation. Seven draws, emission MIS-weighted against NEE; at
// non-delta vertices the point lights and NEE become shadow rays with their contribution
// (traced by the shadow stage, pbrt-v4's deferred scheme); then BSDF sampling, Russian
// roulette and the next ray.

// path_tracer::roulette_probability.
fn roulette_probability(color: vec3<f32>) -> f32 {
    return clamp(1.0 - max(max(color.x, color.y), color.z), 0.05, 1.0);
}

// Emitted radiance at the hit, MIS-weighted when NEE could also have sampled it (and
// settings.nee asks for it: see pt_escaped).
fn pt_emitted(prev: Previous, hit: Hit, m: Material) -> vec3<f32> {
    let le = pigment_color(m.emitted, hit.uv);
// #if AREA_LIGHTS
    if (all(le == vec3<f32>(0.0)) || settings.nee == 0u || prev.delta || (hit.object & CSG_NODE_BIT) != 0u) {
        return le;
    }
    let i = shapes[hit.object].light;
    if (i == 0xFFFFFFFFu) {
        return le;
    }
    let nee_pdf = light_selection_pdf() * light_pdf(area_lights[i], prev.point, prev.object, hit.point, hit.geometric);
    return le * power_heuristic(prev.pdf, nee_pdf);
// #else
    return le;
// #endif
}

// #if NEE
// #if SHADOWS
// Next-event estimation at a non-delta vertex: one light chosen by ξ0, a point by ξ1 ξ2.
// Returns the shadow ray and its contribution f·Le·cosθ·w/p (valid = false: nothing to
// trace).
struct LightRay {
    ray: Ray,
    value: vec3<f32>,
    valid: bool,
}

fn pt_sample_light(hit: Hit, m: Material, color: vec3<f32>, d: vec3<f32>, xi0: f32, xi1: f32, xi2: f32) -> LightRay {
    let none = LightRay(Ray(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, 0.0), vec3<f32>(0.0), false);
    let n = light_count();
    if (n == 0u) {
        return none;
    }
    let select_pdf = light_selection_pdf();
    let choice = min(u32(xi0 * f32(n)), n - 1u);
    var dir: vec3<f32>;
    var radiance: vec3<f32>;
    var pdf: f32;
    var is_area = false;
    var y = vec3<f32>(0.0);
    var ny = vec3<f32>(0.0);
    var sy = 0.0;
// #if AREA_LIGHTS
    if (choice < settings.area_light_count) {
        let light = area_lights[choice];
        let lp = light_sample(light, hit.point, hit.object, xi1, xi2);
        let to = lp.point - hit.point;
        let dist = length(to);
        if (!(lp.pdf > 0.0) || !(dist > 0.0)) {
            return none;
        }
        dir = to / dist;
        radiance = light_emission(light, lp);
        pdf = select_pdf * lp.pdf;
        is_area = true;
        y = lp.point;
        ny = lp.normal;
        sy = lp.scale;
    }
// #endif
    if (!is_area) {
        let s = env_sample(xi1, xi2);
        if (!(s.w > 0.0)) {
            return none;
        }
        dir = s.xyz;
        radiance = escape_radiance(dir);
        pdf = select_pdf * s.w;
    }
    let f = eval_bsdf(m, color, d, hit.normal, hit.front_face, dir);
    if (all(f == vec3<f32>(0.0)) || all(radiance == vec3<f32>(0.0))) {
        return none;
    }
    if ((dot(dir, hit.normal) > 0.0) != (dot(dir, hit.geometric) > 0.0)) {
        // Shading normals never take light from behind the facet (cpu Hit::consistent).
        return none;
    }
    let o = offset_origin(hit.point, hit.scale, hit.geometric, dir);
    var ray = Ray(o, dir, 0.0, OPEN);
    if (is_area) {
        let e = offset_origin(y, sy, ny, hit.point - y);
        ray = Ray(o, e - o, 0.0, 1.0);
    }
    let weight = power_heuristic(pdf, pdf_bsdf(m, d, hit.normal, hit.front_face, dir));
    // |cos|: a rough dielectric also receives light from behind (transmission).
    return LightRay(ray, f * radiance * (abs(dot(hit.normal, dir)) * weight / pdf), true);
}
// #endif
// #endif

@compute @workgroup_size(WF_WORKGROUP)
fn shade_stage(@builtin(global_invocation_id) gid: vec3<u32>) {
    let slot = wf_slot(SHADE_QUEUE, wf_index(gid));
    if (slot == WF_NONE) {
        return;
    }
    let bounce = atomicLoad(&control[CTRL_BOUNCE]);
    let ray = load_ray(slot);
    let c = load_hit(slot);
    let hit = shape_surface_hit(c.shape, ray, c.c, c.flip, c.object);
    // The seven draws of this vertex, used or not.
    let id = path_id(slot);
    var rng = stream(settings.tracer_seed.xy, settings.tracer_seed.zw, id.pixel, id.sample, bounce);
    var xi: array<f32, 7>;
    for (var k = 0u; k < 7u; k++) {
        xi[k] = pcg_next_f32(&rng);
    }
    let m = materials[hit.material];
    let color = pigment_color(m.pigment, hit.uv);
    let beta_pdf = load_beta(slot, bounce);
    let prev = load_previous(slot, beta_pdf);
    var beta = beta_pdf.xyz;
    add_radiance(slot, beta * pt_emitted(prev, hit, m));
    if (bounce == settings.max_depth) {
        return;
    }
    let d = normalize(ray.dir);
// #if SHADOWS
    // Non-delta vertex: every point light in front, then NEE, as shadow rays.
    var shadows = 0u;
    if (!bsdf_is_delta(m)) {
// #if POINT_LIGHTS
        for (var i = 0u; i < settings.point_light_count; i++) {
            let s = point_light_sample(i, hit);
            if (s.lit) {
                let cos_theta = dot(hit.normal, s.l);
                let f = eval_bsdf(m, color, d, hit.normal, hit.front_face, s.l);
                queue_shadow(slot, shadows, s.ray, beta * (f * s.radiance * cos_theta));
                shadows++;
            }
        }
// #endif
// #if NEE
        if (settings.nee != 0u) {
            let lr = pt_sample_light(hit, m, color, d, xi[0], xi[1], xi[2]);
            if (lr.valid) {
                queue_shadow(slot, shadows, lr.ray, beta * lr.value);
                shadows++;
            }
        }
// #endif
    }
    if (shadows > 0u) {
// #if POINT_LIGHTS
        // Without point lights a vertex queues at most the one NEE ray, a full list.
        end_shadows(slot, shadows);
// #endif
        wf_push(Q_SHADOW, slot);
    }
// #endif
    let s = sample_bsdf(m, color, d, hit.normal, hit.front_face, xi[3], xi[4], xi[5]);
    if (!s.valid || (dot(s.dir, hit.normal) > 0.0) != (dot(s.dir, hit.geometric) > 0.0)) {
        return;
    }
    beta *= s.weight;
    if (bounce >= settings.roulette_depth) {
        let q = roulette_probability(color);
        if (xi[6] <= q) {
            return;
        }
        beta = beta / (1.0 - q);
    }
    if (all(beta == vec3<f32>(0.0))) {
        return;
    }
    // A delta vertex is marked by a negative density (load_previous).
    paths[field(F_BETA, slot)] = vec4<f32>(beta, select(s.pdf, -1.0, s.delta));
// #if AREA_LIGHTS
    // Only emission MIS at the next hit reads the previous point and object (pt_emitted).
    words[field(W_PREV, slot)] = vec4<u32>(bitcast<vec3<u32>>(hit.point), hit.object);
// #endif
    store_ray(slot, Ray(offset_origin(hit.point, hit.scale, hit.geometric, s.dir), s.dir, 0.0, OPEN));
    wf_push(Q_RAY + ((bounce + 1u) & 1u), slot);
}
