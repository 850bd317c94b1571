// #requires ggx
// #if CONDUCTOR
// #requires finite
// #endif
// #if ROUGH_DIELECTRIC
// #requires fresnel
// #endif
// #if PLASTIC
// #requires fresnel
// #endif
// #if PATHTRACER
// #requires warp
// #endif
// The GGX microfacet kinds (cpu::microfacet) in the local frame, o = −d toward the viewer:
// the conductor (exact Fresnel per channel, or F = 1, and the compensating lobe
// m.lobe · (1 − E(μo))(1 − E(μi))), the rough dielectric (Walter et al. 2007: reflection
// and transmission, the compensating lobes of both) and the plastic (a diffuse base of
// albedo ρ under a dielectric coat of index m.ior, GGX when m.alpha > 0, smooth when 0).
//
// The kinds share one description of what they have in common, so that each costly piece
// has one call site in a kernel holding several kinds (llvmpipe inlines every call, and its
// JIT time grows with the code: DESIGN.md "One call site per costly function"): E(μo) is
// read once per vertex (bsdf_vertex), and one evaluation gives f and the density together
// from one half vector, one D, one G2, one Fresnel factor and one albedo read E(μi).
// The arithmetic of each kind is cpu::microfacet's, in f32.

// #if CONDUCTOR
// fresnel::fresnel_conductor per channel: complex index eta + i·k.
fn fresnel_conductor(cos_i: f32, eta: vec3<f32>, k: vec3<f32>) -> vec3<f32> {
    let c = clamp(cos_i, 0.0, 1.0);
    let c2 = c * c;
    let s2 = 1.0 - c2;
    let t0 = eta * eta - k * k - s2;
    let a2b2 = sqrt(t0 * t0 + 4.0 * eta * eta * k * k);
    let a = sqrt(max(0.5 * (a2b2 + t0), vec3<f32>(0.0)));
    let rs = (a2b2 - 2.0 * a * c + c2) / (a2b2 + 2.0 * a * c + c2);
    let rp = rs * (c2 * a2b2 - 2.0 * a * c * s2 + s2 * s2) / (c2 * a2b2 + 2.0 * a * c * s2 + s2 * s2);
    let f = 0.5 * (rs + rp);
    return select(vec3<f32>(1.0), clamp(f, vec3<f32>(0.0), vec3<f32>(1.0)), !non_finite(f));
}

// microfacet::conductor_fresnel: 1 without a complex index.
fn conductor_fresnel(m: Material, cos_i: f32) -> vec3<f32> {
    if (m.eta.w == 0.0) {
        return vec3<f32>(1.0);
    }
    return fresnel_conductor(cos_i, m.eta.xyz, m.k.xyz);
}
// #endif

// #if ROUGH_DIELECTRIC
// The rough dielectric's side: η = ior entering (`front`), else 1/ior. The material's rows
// hold E_R + E_T at η = ior, then at 1/ior; `lobe` / `lobe_back` are the constants (k_t,
// reflect, transmit) of the entering and the leaving side.
struct DielectricSide {
    eta: f32,
    // (k_t, reflect, transmit).
    lobe: vec4<f32>,
    // Albedo rows of this side and of the other.
    own: u32,
    other: u32,
}

fn dielectric_side(m: Material, front: bool) -> DielectricSide {
    if (front) {
        return DielectricSide(m.ior, m.lobe, m.rows, m.rows + DIELECTRIC_NODES);
    }
    return DielectricSide(1.0 / m.ior, m.lobe_back, m.rows + DIELECTRIC_NODES, m.rows);
}

// The generalised half vector of a refraction o → i, facing +z; 0 when undefined.
fn refraction_half_vector(o: vec3<f32>, i: vec3<f32>, eta: f32) -> vec3<f32> {
    let h = -(o + eta * i);
    let len = length(h);
    if (!(len > 1e-12)) {
        return vec3<f32>(0.0);
    }
    let u = h / len;
    return select(u, -u, u.z < 0.0);
}
// #endif

// Whether `m` is shaded here: a rough conductor, a rough dielectric or a plastic (a smooth
// conductor is a delta, sampled by brdf.wgsl).
fn is_microfacet(m: Material) -> bool {
    var yes = false;
// #if CONDUCTOR
    yes = yes || (m.brdf == BRDF_CONDUCTOR && m.alpha > 0.0);
// #endif
// #if ROUGH_DIELECTRIC
    yes = yes || m.brdf == BRDF_ROUGH_DIELECTRIC;
// #endif
// #if PLASTIC
    yes = yes || m.brdf == BRDF_PLASTIC;
// #endif
    return yes;
}

// The index of refraction at the vertex (the coat's for a plastic, η of the side for a rough
// dielectric, unused for a conductor).
fn microfacet_eta(m: Material, front: bool) -> f32 {
// #if ROUGH_DIELECTRIC
    if (m.brdf == BRDF_ROUGH_DIELECTRIC) {
        return dielectric_side(m, front).eta;
    }
// #endif
    return m.ior;
}

// The albedo E(μ) the kind's lobe choice and compensation read: its row at `row` (the rough
// dielectric has one per side), or the smooth coat's Fresnel reflectance.
fn microfacet_albedo(m: Material, row: u32, mu: f32) -> f32 {
// #if PLASTIC
    if (m.brdf == BRDF_PLASTIC && m.alpha == 0.0) {
        return fresnel_dielectric(mu, m.ior);
    }
// #endif
    var nodes = DIELECTRIC_NODES;
// #if CONDUCTOR
    nodes = select(DIELECTRIC_NODES, CONDUCTOR_NODES, m.brdf == BRDF_CONDUCTOR);
// #endif
    return albedo_row(row, nodes, mu);
}

// The row of E for directions on the side of o (`own`) or through the surface.
fn microfacet_row(m: Material, front: bool, own: bool) -> u32 {
// #if ROUGH_DIELECTRIC
    if (m.brdf == BRDF_ROUGH_DIELECTRIC) {
        let s = dielectric_side(m, front);
        return select(s.other, s.own, own);
    }
// #endif
    return m.rows;
}

// E(μo) of a vertex, read once for its sample and every direction it evaluates.
fn microfacet_e_o(m: Material, front: bool, o: vec3<f32>) -> f32 {
    return microfacet_albedo(m, microfacet_row(m, front, true), o.z);
}

// #if PATHTRACER
// The probability of the single-scattering lobe: E(μo) (clamped, but for the plastic's coat).
fn microfacet_lobe_probability(m: Material, e_o: f32) -> f32 {
// #if PLASTIC
    if (m.brdf == BRDF_PLASTIC) {
        return e_o;
    }
// #endif
    return clamp(e_o, 0.0, 1.0);
}
// #endif

// f(o, i) (xyz; tinted by `color`, the plastic's base albedo ρ) and, in the path tracer, the
// density with which microfacet_sample produces i (w), for the vertex's E(μo) `e_o`.
fn microfacet_eval(m: Material, color: vec3<f32>, front: bool, o: vec3<f32>, e_o: f32, i: vec3<f32>)
    -> vec4<f32> {
    var transmits = false;
// #if ROUGH_DIELECTRIC
    transmits = m.brdf == BRDF_ROUGH_DIELECTRIC;
// #endif
    if (o.z <= 0.0 || i.z == 0.0 || (i.z < 0.0 && !transmits)) {
        return vec4<f32>(0.0);
    }
    let a = m.alpha;
    let eta = microfacet_eta(m, front);
    let reflects = i.z > 0.0;
    // The half vector of the reflection, or of the refraction (0 and `single` false when
    // no refraction joins o and i), with o·h, i·h and Walter's denominator o·h + η i·h.
    var h = normalize(o + i);
    var single = a > 0.0;
// #if ROUGH_DIELECTRIC
    if (!reflects) {
        h = refraction_half_vector(o, i, eta);
    }
// #endif
    let oh = dot(o, h);
// #if ROUGH_DIELECTRIC
    let ih = dot(i, h);
    let den = oh + eta * ih;
    if (!reflects) {
        single = single && oh > 0.0 && ih < 0.0;
    }
// #endif
    // Single scattering: D G2 / (4 μo μi) times the Fresnel factor (reflection), Walter's
    // transmission term, and the visible normals' density of h (G1(o) max(0, o·h) D(h) / μo)
    // with the Jacobian of the reflection or refraction.
    var ss = vec3<f32>(0.0);
    var ss_pdf = 0.0;
    if (single) {
        let d = ggx_d(a, h);
        let dg = d * ggx_g2(a, o, i);
        // The dielectric's Fresnel reflectance (the rough dielectric's and the coat's).
        var fresnel = 1.0;
// #if ROUGH_DIELECTRIC
        if (m.brdf != BRDF_CONDUCTOR) {
            fresnel = fresnel_dielectric(oh, eta);
        }
// #else
// #if PLASTIC
        if (m.brdf != BRDF_CONDUCTOR) {
            fresnel = fresnel_dielectric(oh, eta);
        }
// #endif
// #endif
// #if PATHTRACER
        let visible = ggx_g1(a, o) * max(oh, 0.0) * d / o.z;
// #endif
        if (reflects) {
            let r = dg / (4.0 * o.z * i.z);
            ss = vec3<f32>(fresnel * r);
// #if CONDUCTOR
            if (m.brdf == BRDF_CONDUCTOR) {
                ss = conductor_fresnel(m, oh) * r;
            }
// #endif
// #if PATHTRACER
            // The rough dielectric reflects with probability F; the others' lobe is the
            // reflection alone.
            ss_pdf = select(1.0, fresnel, transmits) * visible / (4.0 * oh);
// #endif
        }
// #if ROUGH_DIELECTRIC
        if (!reflects) {
            ss = vec3<f32>((1.0 - fresnel) * dg * oh * -ih / (o.z * -i.z * den * den));
// #if PATHTRACER
            ss_pdf = (1.0 - fresnel) * visible * eta * eta * -ih / (den * den);
// #endif
        }
// #endif
    }
    // The compensating lobe (1 − E(μo))(1 − E(μi)) · scale: on the side of o from the own
    // row, through the surface from the other side's.
    let e_i = microfacet_albedo(m, microfacet_row(m, front, reflects), abs(i.z));
    var scale = 1.0;
    var tint = vec3<f32>(1.0);
    var f = color;
// #if CONDUCTOR
    if (m.brdf == BRDF_CONDUCTOR) {
        tint = m.lobe.xyz;
    }
// #endif
// #if ROUGH_DIELECTRIC
    if (transmits) {
        let s = dielectric_side(m, front);
        scale = select(s.lobe.z, s.lobe.y, reflects);
    }
// #endif
// #if PLASTIC
    if (m.brdf == BRDF_PLASTIC) {
        // The base under the coat, internal reflectance r_i = m.lobe.x, its albedo clamped
        // to [0, 1] (optics::compensation::plastic_base_albedo).
        let r_i = m.lobe.x;
        scale = m.lobe.y;
        let rho = clamp(color, vec3<f32>(0.0), vec3<f32>(1.0));
        tint = rho * (1.0 - r_i) / (1.0 - rho * r_i);
        f = vec3<f32>(1.0);
    }
// #endif
    let ms = ms_lobe(e_o, e_i, scale);
    f *= ss + tint * ms;
    var pdf = 0.0;
// #if PATHTRACER
    // The lobes' mixture: single scattering with probability p, else the cosine (for the
    // rough dielectric, transmitted with probability k_t).
    let p = microfacet_lobe_probability(m, e_o);
    var cos_weight = 1.0;
// #if ROUGH_DIELECTRIC
    if (transmits) {
        let k_t = dielectric_side(m, front).lobe.x;
        cos_weight = select(k_t, 1.0 - k_t, reflects);
    }
// #endif
    pdf = p * ss_pdf + (1.0 - p) * cos_weight * cosine_hemisphere_pdf(abs(i.z));
// #endif
    return vec4<f32>(f, pdf);
}

// #if PATHTRACER
// A direction from o: with probability p (microfacet_lobe_probability) a visible normal h,
// reflected (the rough dielectric refracts with probability 1 − F(o·h); a smooth coat is a
// delta reflection), else the cosine lobe (the rough dielectric's transmitted with
// probability k_t). Its f and density are left to microfacet_eval.
fn microfacet_sample(m: Material, front: bool, o: vec3<f32>, e_o: f32, xi_lobe: f32, xi0: f32, xi1: f32)
    -> LocalSample {
    let none = LocalSample(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, false, false);
    let p = microfacet_lobe_probability(m, e_o);
    var i: vec3<f32>;
    if (xi_lobe < p) {
// #if PLASTIC
        if (m.brdf == BRDF_PLASTIC && m.alpha == 0.0) {
            // The smooth coat reflects F(μo), chosen with probability F(μo).
            return LocalSample(vec3<f32>(-o.x, -o.y, o.z), vec3<f32>(1.0), 0.0, true, true);
        }
// #endif
        let h = ggx_sample_visible(m.alpha, o, xi0, xi1);
        i = reflect(-o, h);
// #if ROUGH_DIELECTRIC
        if (m.brdf == BRDF_ROUGH_DIELECTRIC) {
            let eta = dielectric_side(m, front).eta;
            let u = xi_lobe / p;
            let f = fresnel_dielectric(dot(o, h), eta);
            // WGSL's refract takes n_i / n_t; zero on total internal reflection.
            let t = refract(-o, h, 1.0 / eta);
            if (u >= f && any(t != vec3<f32>(0.0))) {
                // A refraction above the horizon (or a reflection below it) is the
                // single-scattering loss.
                i = normalize(t);
                if (!(i.z < 0.0)) {
                    return none;
                }
            } else if (!(i.z > 0.0)) {
                return none;
            }
        }
// #endif
    } else {
        i = cosine_hemisphere(xi0, xi1);
// #if ROUGH_DIELECTRIC
        if (m.brdf == BRDF_ROUGH_DIELECTRIC) {
            let u = (xi_lobe - p) / (1.0 - p);
            i = select(i, vec3<f32>(i.x, i.y, -i.z), u < dielectric_side(m, front).lobe.x);
        }
// #endif
    }
    return local_direction(i);
}
// #endif
