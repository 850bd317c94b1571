// #requires mis random strata pigment brdf offset constants wf_hit paths_set
// #if AREA_LIGHTS
// #requires words_set
// #endif
// #if POINT_LIGHTS
// #requires point_lights
// #endif
// #if SHADOWS
// #requires wf_shadow_ray
// #if NEE
// #requires env_light cell_index
// #endif
// #endif
// Shading stage: one kernel for every BRDF kind of the scene, with only those kinds' code
// (src/gpu/wavefront/stages.rs, Stage::kernel_kinds), launched once per kind over that
// kind's queue (shade_queue.x): one path vertex of cpu::path_tracer per invocation. Seven
// draws, emission MIS-weighted against NEE; at non-delta vertices the point lights and NEE
// become shadow rays with their contribution (traced by the shadow stage, pbrt-v4's
// deferred scheme); then BSDF sampling, Russian roulette and the next ray.

// path_tracer::roulette_probability.
fn roulette_probability(color: vec3<f32>) -> f32 {
    return clamp(1.0 - max(max(color.x, color.y), color.z), 0.05, 1.0);
}

// #if EMISSION
// Emitted radiance at the hit, MIS-weighted when NEE could also have sampled it (and
// settings.nee asks for it: see pt_escaped). Only in the stages of BRDF kinds with an
// emitting material (features::KindUse).
// `hs` is the hit shape's record (the hit object's, unless that is a CSG tree).
fn pt_emitted(prev: Previous, hit: Hit, m: Material, hs: Shape) -> vec3<f32> {
// #if TEXTURED_EMISSION
    let le = pigment_color(m.emitted, hit.uv);
// #else
    // Every emission of this kind is uniform.
    let le = uniform_pigment_color(m.emitted);
// #endif
// #if AREA_LIGHTS
    if (all(le == vec3<f32>(0.0)) || settings.nee == 0u || prev.delta || (hit.object & CSG_NODE_BIT) != 0u) {
        return le;
    }
    if (hs.light == NONE) {
        return le;
    }
    let nee_pdf = light_selection_pdf() * light_pdf(area_light_at(hs.light), hs, prev.point, prev.object, hit.point, hit.geometric);
    return le * power_heuristic(prev.pdf, nee_pdf);
// #else
    return le;
// #endif
}
// #endif

// #if NEE
// #if SHADOWS
// Next-event estimation's light sample at a non-delta vertex: one light chosen by ξ0, a
// point by ξ1 ξ2. The direction to it, its radiance and density (solid angle, the choice
// included); for an area light the point, normal and error scale that end the shadow ray.
// valid = false: nothing to trace.
struct NeeSample {
    dir: vec3<f32>,
    radiance: vec3<f32>,
    pdf: f32,
    area: bool,
    y: vec3<f32>,
    ny: vec3<f32>,
    sy: f32,
    valid: bool,
}

fn pt_sample_light(hit: Hit, xi0: f32, xi1: f32, xi2: f32) -> NeeSample {
    var l = NeeSample(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, false, vec3<f32>(0.0), vec3<f32>(0.0), 0.0, false);
    let n = light_count();
    if (n == 0u) {
        return l;
    }
    let select_pdf = light_selection_pdf();
    let choice = cell_index(xi0 * f32(n), n);
    let azimuth = turn(xi2);
// #if AREA_LIGHTS
    if (choice < settings.area_light_count) {
        let light = area_light_at(choice);
        // The light's shape record, loaded once for all the light code below.
        let ls = shape_at(light.shape);
        let lp = light_sample(light, ls, hit.point, hit.object, xi1, xi2, azimuth);
        let to = lp.point - hit.point;
        let dist = length(to);
        if (!(lp.pdf > 0.0) || !(dist > 0.0)) {
            return l;
        }
        return NeeSample(to / dist, light_emission(light, ls, lp), select_pdf * lp.pdf, true, lp.point, lp.normal, lp.scale, true);
    }
// #endif
    let s = env_sample(xi1, xi2, azimuth);
    if (!(s.pdf > 0.0)) {
        return l;
    }
    l.dir = s.dir;
    l.radiance = s.radiance;
    l.pdf = select_pdf * s.pdf;
    l.valid = true;
    return l;
}

// The shadow ray of light sample `l` and its contribution f·Le·|cosθ|·w/p, where f and
// `bsdf_pdf` are the BSDF's value and density at l.dir (valid = false: nothing to trace).
struct LightRay {
    ray: Ray,
    value: vec3<f32>,
    valid: bool,
}

fn pt_light_ray(hit: Hit, l: NeeSample, f: vec3<f32>, bsdf_pdf: f32) -> LightRay {
    let none = LightRay(Ray(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, 0.0), vec3<f32>(0.0), false);
    if (all(f == vec3<f32>(0.0)) || all(l.radiance == vec3<f32>(0.0))) {
        return none;
    }
    if ((dot(l.dir, hit.normal) > 0.0) != (dot(l.dir, hit.geometric) > 0.0)) {
        // Shading normals never take light from behind the facet (cpu SurfaceHit::consistent).
        return none;
    }
    let o = offset_origin(hit.point, hit.scale, hit.geometric, l.dir);
    var ray = Ray(o, l.dir, 0.0, OPEN);
    if (l.area) {
        let e = offset_origin(l.y, l.sy, l.ny, hit.point - l.y);
        ray = Ray(o, e - o, 0.0, 1.0);
    }
    let weight = power_heuristic(l.pdf, bsdf_pdf);
    // |cos|: a rough dielectric also receives light from behind (transmission).
    return LightRay(ray, f * l.radiance * (abs(dot(hit.normal, l.dir)) * weight / l.pdf), true);
}
// #endif
// #endif

@compute @workgroup_size(WF_WORKGROUP)
fn shade_stage(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_id) local: vec3<u32>) {
    let lane = local.x; // not local_invocation_index (wf_path.wgsl)
    let slot = wf_slot(shade_queue.x, group.x, lane);
    if (slot == WF_NONE) {
        return;
    }
    let bounce = atomicLoad(&control[CTRL_BOUNCE]);
    let ray = load_ray(slot);
    let c = load_hit(slot);
    // The hit shape's record, loaded once for the surface and the emission's MIS weight.
    let hs = shape_at(c.shape);
    let hit = shape_surface_hit(hs, ray, c.c, c.flip, c.object);
    // The seven draws of this vertex, used or not, each in its sample's stratum.
    let id = path_id(slot);
    var rng = stream(settings.tracer_seed.xy, settings.tracer_seed.zw, id.pixel, id.sample, bounce);
    var x: array<u32, 7>;
    for (var k = 0u; k < 7u; k++) {
        // The 24 bits of pcg_next_f32.
        x[k] = pcg_next_u32(&rng) >> 8u;
    }
    let xi = stratified_draws(x, settings.strata_seed, id.pixel, id.sample, bounce, settings.strata_bits);
    let m = material_at(hit.material);
    let color = pigment_color(m.pigment, hit.uv);
    let beta_pdf = load_beta(slot, bounce);
    var beta = beta_pdf.xyz;
// #if EMISSION
    add_radiance(slot, beta * pt_emitted(load_previous(slot, beta_pdf), hit, m, hs));
// #endif
    if (bounce == settings.max_depth) {
        return;
    }
    let v = bsdf_vertex(m, normalize(ray.dir), hit.normal, hit.front_face);
    var s = sample_bsdf(m, color, v, xi[3], xi[4], xi[5]);
    // The directions where this vertex evaluates its BSDF, all through the one call site of
    // eval_bsdf in the loop below (llvmpipe inlines every call: each call site would
    // compile the whole BSDF again): at a non-delta vertex each point light in front
    // and the NEE light sample, which become shadow rays, then the sampled direction when
    // its lobe left f and the density to evaluate (s.pending).
    var point = 0u;
    var nee = 0u;
// #if SHADOWS
    var shadows = 0u;
    if (!bsdf_is_delta(m)) {
// #if POINT_LIGHTS
        point = settings.point_light_count;
// #endif
// #if NEE
        nee = select(0u, 1u, settings.nee != 0u);
// #endif
    }
// #if NEE
    var light: NeeSample;
    if (nee != 0u) {
        light = pt_sample_light(hit, xi[0], xi[1], xi[2]);
    }
// #endif
// #endif
// #if MICROFACET
    let count = point + nee + select(0u, 1u, s.pending);
// #else
    let count = point + nee;
// #endif
    for (var k = 0u; k < count; k++) {
        var dir = s.dir;
// #if POINT_LIGHTS
        var pl: PointLightSample;
        if (k < point) {
            pl = point_light_sample(k, hit, bsdf_transmits(m));
            if (!pl.lit) {
                continue;
            }
            dir = pl.l;
        }
// #endif
// #if NEE
// #if SHADOWS
        if (k == point && nee != 0u) {
            if (!light.valid) {
                continue;
            }
            dir = light.dir;
        }
// #endif
// #endif
        let f_pdf = eval_bsdf(m, color, v, dir);
        let f = f_pdf.xyz;
// #if POINT_LIGHTS
        if (k < point) {
            queue_shadow(slot, shadows, pl.ray, beta * (f * pl.radiance * abs(dot(hit.normal, pl.l))));
            shadows++;
            continue;
        }
// #endif
        let pdf = f_pdf.w;
// #if NEE
// #if SHADOWS
        if (k == point && nee != 0u) {
            let lr = pt_light_ray(hit, light, f, pdf);
            if (lr.valid) {
                queue_shadow(slot, shadows, lr.ray, beta * lr.value);
                shadows++;
            }
            continue;
        }
// #endif
// #endif
// #if MICROFACET
        s = bsdf_finish(dir, f, pdf, hit.normal);
// #endif
    }
// #if SHADOWS
    if (shadows > 0u) {
// #if POINT_LIGHTS
        // Without point lights a vertex queues at most the one NEE ray, a full list.
        end_shadows(slot, shadows);
// #endif
        wf_push(Q_SHADOW, slot);
    }
// #endif
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
    paths_set(field(F_BETA, slot), vec4<f32>(beta, select(s.pdf, -1.0, s.delta)));
// #if AREA_LIGHTS
    // Only emission MIS at the next hit reads the previous point and object (pt_emitted).
    words_set(field(W_PREV, slot), vec4<u32>(bitcast<vec3<u32>>(hit.point), hit.object));
// #endif
    store_ray(slot, Ray(offset_origin(hit.point, hit.scale, hit.geometric, s.dir), s.dir, 0.0, OPEN));
    wf_push(Q_RAY + ((bounce + 1u) & 1u), slot);
}
