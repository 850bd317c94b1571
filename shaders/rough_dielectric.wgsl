// #requires ggx fresnel
// #if PATHTRACER
// #requires warp
// #endif
// The rough GGX dielectric (cpu::microfacet, Dielectric; Walter et al. 2007) in the local
// frame, o = −d toward the viewer, `front` when the ray enters (η = ior, else 1/ior): single
// scattering plus the compensating lobes of reflection and transmission. The material's
// rows hold E_R + E_T at η = ior, then at 1/ior; `lobe` / `lobe_back` are the constants
// (k_t, reflect, transmit) of the entering and the leaving side.

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

// The half vector of a refraction o → i with its cosines and Walter's denominator
// o·h + η i·h; `valid` when o and i lie on the sides a refraction through h joins.
struct Refraction {
    h: vec3<f32>,
    oh: f32,
    ih: f32,
    den: f32,
    valid: bool,
}

fn refraction(o: vec3<f32>, i: vec3<f32>, eta: f32) -> Refraction {
    let h = refraction_half_vector(o, i, eta);
    let oh = dot(o, h);
    let ih = dot(i, h);
    return Refraction(h, oh, ih, oh + eta * ih, oh > 0.0 && ih < 0.0);
}

// f(o, i), untinted, radiance (transmission includes 1/η²).
fn rough_dielectric_eval(m: Material, s: DielectricSide, o: vec3<f32>, i: vec3<f32>) -> f32 {
    if (o.z <= 0.0 || i.z == 0.0) {
        return 0.0;
    }
    let a = m.alpha;
    let eta = s.eta;
    let e_o = albedo_row(s.own, DIELECTRIC_NODES, o.z);
    if (i.z > 0.0) {
        let h = normalize(o + i);
        let ss = fresnel_dielectric(dot(o, h), eta) * ggx_d(a, h) * ggx_g2(a, o, i) / (4.0 * o.z * i.z);
        return ss + ms_lobe(e_o, albedo_row(s.own, DIELECTRIC_NODES, i.z), s.lobe.y);
    }
    var ss = 0.0;
    let r = refraction(o, i, eta);
    if (r.valid) {
        let d = ggx_d(a, r.h) * ggx_g2(a, o, i);
        ss = (1.0 - fresnel_dielectric(r.oh, eta)) * d * r.oh * -r.ih / (o.z * -i.z * r.den * r.den);
    }
    return ss + ms_lobe(e_o, albedo_row(s.other, DIELECTRIC_NODES, -i.z), s.lobe.z);
}

// #if PATHTRACER
// The mixture's density: single scattering with probability E_o(μo); the rest the cosine
// lobes, transmitted with probability k_t.
fn rough_dielectric_pdf(m: Material, s: DielectricSide, o: vec3<f32>, i: vec3<f32>) -> f32 {
    if (o.z <= 0.0 || i.z == 0.0) {
        return 0.0;
    }
    let p = clamp(albedo_row(s.own, DIELECTRIC_NODES, o.z), 0.0, 1.0);
    let k_t = s.lobe.x;
    let eta = s.eta;
    let cos_pdf = cosine_hemisphere_pdf(abs(i.z));
    if (i.z > 0.0) {
        let h = normalize(o + i);
        let ss = fresnel_dielectric(dot(o, h), eta) * ggx_visible_pdf(m.alpha, o, h) / (4.0 * dot(o, h));
        return p * ss + (1.0 - p) * (1.0 - k_t) * cos_pdf;
    }
    var ss = 0.0;
    let r = refraction(o, i, eta);
    if (r.valid) {
        let v = ggx_visible_pdf(m.alpha, o, r.h);
        ss = (1.0 - fresnel_dielectric(r.oh, eta)) * v * eta * eta * -r.ih / (r.den * r.den);
    }
    return p * ss + (1.0 - p) * k_t * cos_pdf;
}

fn rough_dielectric_sample(m: Material, s: DielectricSide, o: vec3<f32>, xi_lobe: f32, xi0: f32, xi1: f32)
    -> LocalSample {
    let none = LocalSample(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, false, false);
    let p = clamp(albedo_row(s.own, DIELECTRIC_NODES, o.z), 0.0, 1.0);
    var i: vec3<f32>;
    if (xi_lobe < p) {
        let u = xi_lobe / p;
        let h = ggx_sample_visible(m.alpha, o, xi0, xi1);
        let f = fresnel_dielectric(dot(o, h), s.eta);
        // WGSL's refract takes n_i / n_t; zero on total internal reflection.
        let t = refract(-o, h, 1.0 / s.eta);
        if (u >= f && any(t != vec3<f32>(0.0))) {
            // A refraction above the horizon (or a reflection below it) is the
            // single-scattering loss.
            i = normalize(t);
            if (!(i.z < 0.0)) {
                return none;
            }
        } else {
            i = reflect(-o, h);
            if (!(i.z > 0.0)) {
                return none;
            }
        }
    } else {
        let u = (xi_lobe - p) / (1.0 - p);
        let c = cosine_hemisphere(xi0, xi1);
        i = select(c, vec3<f32>(c.x, c.y, -c.z), u < s.lobe.x);
    }
    return local_direction(i);
}
// #endif
