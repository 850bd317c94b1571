// #requires world random pigment environment brdf offset integrators
// #if NEE
// #requires lights env_light
// #endif
// The path tracer: mirrors cpu::path_tracer function by function (DESIGN.md
// "Integrators"): seven draws per vertex, emission MIS-weighted against NEE, point lights
// always, NEE of one area light or the environment, BSDF sampling, Russian roulette.

// What the next vertex needs to know about the one that scattered the ray to it.
struct Previous {
    point: vec3<f32>,
    object: u32,
    // Delta scattering (or the camera): what the ray finds gets full weight.
    delta: bool,
    pdf: f32,
}

// path_tracer::roulette_probability.
fn roulette_probability(color: vec3<f32>) -> f32 {
    return clamp(1.0 - max(max(color.x, color.y), color.z), 0.05, 1.0);
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

// Emitted radiance at the hit, MIS-weighted when NEE could also have sampled it. NEE code
// compiled in still obeys settings.nee (as cpu::path_tracer does), so a full-featured
// kernel renders a scene without NEE correctly.
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
    let nee_pdf = light_selection_pdf() * light_pdf(area_lights[i], prev.point, prev.object, hit.point);
    return le * power_heuristic(prev.pdf, nee_pdf);
// #else
    return le;
// #endif
}

// Radiance of an escaping ray, MIS-weighted when NEE samples the environment.
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

// #if NEE
// Next-event estimation at a diffuse vertex: one light chosen by ξ0, a point by ξ1 ξ2.
fn pt_sample_light(hit: Hit, m: Material, color: vec3<f32>, xi0: f32, xi1: f32, xi2: f32) -> vec3<f32> {
    let n = light_count();
    if (n == 0u) {
        return vec3<f32>(0.0);
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
            return vec3<f32>(0.0);
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
            return vec3<f32>(0.0);
        }
        dir = s.xyz;
        radiance = escape_radiance(dir);
        pdf = select_pdf * s.w;
    }
    let f = eval_bsdf(m, color, hit.normal, dir);
    if (all(f == vec3<f32>(0.0)) || all(radiance == vec3<f32>(0.0))) {
        return vec3<f32>(0.0);
    }
    let o = offset_origin(hit.point, hit.scale, hit.normal, dir);
    var shadow = Ray(o, dir, 0.0, OPEN);
    if (is_area) {
        let e = offset_origin(y, sy, ny, hit.point - y);
        shadow = Ray(o, e - o, 0.0, 1.0);
    }
    if (occluded(shadow)) {
        return vec3<f32>(0.0);
    }
    let weight = power_heuristic(pdf, pdf_bsdf(m, hit.normal, dir));
    return f * radiance * (dot(hit.normal, dir) * weight / pdf);
}
// #endif

// Radiance along one camera ray: path `sample` of pixel `pixel`.
fn radiance_path(camera_ray: Ray, pixel: u32, sample: u32) -> vec3<f32> {
    var radiance = vec3<f32>(0.0);
    var beta = vec3<f32>(1.0);
    var ray = camera_ray;
    var prev = Previous(vec3<f32>(0.0), 0xFFFFFFFFu, true, 0.0);
    for (var bounce = 0u; bounce <= settings.max_depth; bounce++) {
        let hit = closest_hit(ray);
        if (hit.t >= OPEN) {
            radiance += beta * pt_escaped(prev, normalize(ray.dir));
            break;
        }
        // The seven draws of this vertex, used or not.
        var rng = stream(settings.tracer_seed.xy, settings.tracer_seed.zw, pixel, sample, bounce);
        var xi: array<f32, 7>;
        for (var k = 0u; k < 7u; k++) {
            xi[k] = pcg_next_f32(&rng);
        }
        let m = materials[hit.material];
        let color = pigment_color(m.pigment, hit.uv);
        radiance += beta * pt_emitted(prev, hit, m);
        if (bounce == settings.max_depth) {
            break;
        }
        if (m.brdf == 0u) {
// #if POINT_LIGHTS
            var direct = vec3<f32>(0.0);
            for (var i = 0u; i < settings.point_light_count; i++) {
                let s = point_light_at(i, hit);
                let cos_theta = dot(hit.normal, s.l);
                if (cos_theta > 0.0) {
                    direct += eval_bsdf(m, color, hit.normal, s.l) * s.radiance * cos_theta;
                }
            }
            radiance += beta * direct;
// #endif
// #if NEE
            if (settings.nee != 0u) {
                radiance += beta * pt_sample_light(hit, m, color, xi[0], xi[1], xi[2]);
            }
// #endif
        }
        let d = normalize(ray.dir);
        let s = sample_bsdf(m, color, d, hit.normal, hit.front_face, xi[3], xi[4], xi[5]);
        if (!s.valid) {
            break;
        }
        beta *= s.weight;
        if (bounce >= settings.roulette_depth) {
            let q = roulette_probability(color);
            if (xi[6] <= q) {
                break;
            }
            beta = beta / (1.0 - q);
        }
        if (all(beta == vec3<f32>(0.0))) {
            break;
        }
        prev = Previous(hit.point, hit.object, s.delta, s.pdf);
        ray = Ray(offset_origin(hit.point, hit.scale, hit.normal, s.dir), s.dir, 0.0, OPEN);
    }
    return radiance;
}
