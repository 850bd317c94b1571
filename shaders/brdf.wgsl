// #requires ray
// #if PATHTRACER
// #if DIFFUSE
// #requires onb warp
// #endif
// #endif
// #if DIELECTRIC
// #requires fresnel
// #endif
// #if MICROFACET
// #requires microfacet
// #endif
// BSDF sampling, evaluation and densities in the world frame: mirrors cpu::bsdf, with the
// microfacet kinds' local-frame code in microfacet.wgsl. `d` is the unit direction the
// incoming ray travels along, `n` the unit normal facing it, `l` a light direction pointing
// away from the surface.

// What a vertex's BSDF reads wherever it is sampled or evaluated, computed once per vertex:
// d, n, the side, and for the microfacet kinds the local frame, o = −d in it and E(μo)
// (microfacet.wgsl; the shading stage evaluates several directions per vertex).
struct BsdfVertex {
    d: vec3<f32>,
    n: vec3<f32>,
    front_face: bool,
// #if MICROFACET
    frame: Frame,
    o: vec3<f32>,
    e_o: f32,
// #endif
}

// #if MICROFACET
// Whether the vertex samples in the local frame: a microfacet kind, or the diffuse one,
// which shares their cosine lobe (sample_bsdf).
fn bsdf_in_frame(m: Material) -> bool {
// #if DIFFUSE
    return is_microfacet(m) || m.brdf == BRDF_DIFFUSE;
// #else
    return is_microfacet(m);
// #endif
}
// #endif

fn bsdf_vertex(m: Material, d: vec3<f32>, n: vec3<f32>, front_face: bool) -> BsdfVertex {
// #if MICROFACET
    var v = BsdfVertex(d, n, front_face, Frame(vec3<f32>(0.0), vec3<f32>(0.0), n), vec3<f32>(0.0), 0.0);
    if (bsdf_in_frame(m)) {
        v.frame = frame_of(n);
        v.o = to_local(v.frame, -d);
    }
    if (is_microfacet(m)) {
        v.e_o = microfacet_e_o(m, front_face, v.o);
    }
    return v;
// #else
    return BsdfVertex(d, n, front_face);
// #endif
}

// #if PATHTRACER

struct BsdfSample {
    dir: vec3<f32>,
    // f · |cos| / pdf.
    weight: vec3<f32>,
    pdf: f32,
    delta: bool,
    // False when nothing is scattered.
    valid: bool,
    // A microfacet lobe's direction, whose f and pdf (hence weight) the shading stage still
    // evaluates (bsdf_finish), at the one call site of eval_bsdf and pdf_bsdf it also
    // evaluates light directions at: llvmpipe inlines every call, so a second call site
    // compiles the whole BSDF again. The CPU evaluates the same quantities in the local
    // frame (cpu::microfacet::finish); here the world-frame direction is taken back to it.
    pending: bool,
}

// #if MICROFACET
// microfacet::finish: the sample in direction `dir` (unit) whose BSDF value is f and
// density pdf, invalid when nothing scatters; `n` is the shading normal.
fn bsdf_finish(dir: vec3<f32>, f: vec3<f32>, pdf: f32, n: vec3<f32>) -> BsdfSample {
    let weight = f * (abs(dot(n, dir)) / pdf);
    let valid = pdf > 0.0 && !non_finite(dir) && any(f != vec3<f32>(0.0)) && !non_finite(weight);
    return BsdfSample(dir, weight, pdf, false, valid, false);
}
// #endif

// #if DIELECTRIC
// Refraction, or a zero vector on total internal reflection: fresnel::refract.
fn refract_dir(d: vec3<f32>, n: vec3<f32>, eta: f32) -> vec3<f32> {
    let cos_i = -dot(d, n);
    let sin2_t = max(1.0 - cos_i * cos_i, 0.0) / (eta * eta);
    if (sin2_t >= 1.0) {
        return vec3<f32>(0.0);
    }
    let cos_t = sqrt(1.0 - sin2_t);
    return d / eta + (cos_i / eta - cos_t) * n;
}

fn sample_dielectric(color: vec3<f32>, d: vec3<f32>, n: vec3<f32>, eta: f32, xi_lobe: f32) -> BsdfSample {
    let f = fresnel_dielectric(-dot(d, n), eta);
    let reflected = BsdfSample(reflect(d, n), color, 0.0, true, true, false);
    if (xi_lobe < f) {
        return reflected;
    }
    let t = refract_dir(d, n, eta);
    if (all(t == vec3<f32>(0.0))) {
        return reflected;
    }
    return BsdfSample(normalize(t), color / (eta * eta), 0.0, true, true, false);
}
// #endif

// #if DIFFUSE
// The cosine lobe's direction `local` (warp::cosine_hemisphere) in the frame (t, b, n).
fn sample_diffuse(color: vec3<f32>, t: vec3<f32>, b: vec3<f32>, n: vec3<f32>, local: vec3<f32>) -> BsdfSample {
    let dir = normalize(t * local.x + b * local.y + n * local.z);
    let pdf = cosine_hemisphere_pdf(local.z);
    return BsdfSample(dir, color, pdf, false, pdf > 0.0, false);
}
// #endif

// bsdf::sample_bsdf with the vertex's draws ξ3 (lobe), ξ4, ξ5 (direction).
fn sample_bsdf(m: Material, color: vec3<f32>, v: BsdfVertex, xi_lobe: f32, xi0: f32, xi1: f32) -> BsdfSample {
    let d = v.d;
    let n = v.n;
// #if SPECULAR
    if (m.brdf == BRDF_SPECULAR) {
        return BsdfSample(reflect(d, n), color, 0.0, true, true, false);
    }
// #endif
// #if DIELECTRIC
    if (m.brdf == BRDF_DIELECTRIC) {
        return sample_dielectric(color, d, n, select(1.0 / m.ior, m.ior, v.front_face), xi_lobe);
    }
// #endif
// #if CONDUCTOR
    if (m.brdf == BRDF_CONDUCTOR && m.alpha == 0.0) {
        return BsdfSample(reflect(d, n), color * conductor_fresnel(m, -dot(d, n)), 0.0, true, true, false);
    }
// #endif
// #if MICROFACET
    if (bsdf_in_frame(m)) {
        // One call site for every kind's cosine lobe and visible normals: a diffuse vertex
        // (E(μo) = 0) draws the cosine lobe there.
        let s = microfacet_sample(m, v.front_face, v.o, v.e_o, xi_lobe, xi0, xi1);
// #if DIFFUSE
        if (m.brdf == BRDF_DIFFUSE) {
            return sample_diffuse(color, v.frame.t, v.frame.b, n, s.dir);
        }
// #endif
        // Only the smooth coat returns a delta, whose weight is 1 (the pigment is the base's).
        return world_sample(v.frame, s, vec3<f32>(1.0));
    }
// #else
// #if DIFFUSE
    if (m.brdf == BRDF_DIFFUSE) {
        let frame = onb(n);
        return sample_diffuse(color, frame.t, frame.b, n, cosine_hemisphere(xi0, xi1));
    }
// #endif
// #endif
    return BsdfSample(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, true, false, false);
}

// #if SHADOWS
// Whether the vertex's scattering is a Dirac delta (no light sampling there): among the
// kinds whose kernels sample lights, a smooth conductor, and smooth glass where the
// rough-dielectric stage shades it.
fn bsdf_is_delta(m: Material) -> bool {
// #if DIELECTRIC
    if (m.brdf == BRDF_DIELECTRIC) {
        return true;
    }
// #endif
// #if CONDUCTOR
    if (m.brdf == BRDF_CONDUCTOR) {
        return m.alpha == 0.0;
    }
// #endif
    return false;
}

// #if POINT_LIGHTS
// scene::Brdf::transmits: point lights behind the surface reach it too (a rough dielectric).
fn bsdf_transmits(m: Material) -> bool {
// #if ROUGH_DIELECTRIC
    return m.brdf == BRDF_ROUGH_DIELECTRIC;
// #else
    return false;
// #endif
}
// #endif
// #endif

// #endif

// bsdf::eval_bsdf and, in the path tracer, bsdf::pdf_bsdf: f for light from `l` seen
// along −d (xyz) and the density with which sample_bsdf produces l (w), both 0 for delta
// BSDFs. One function for both, so that a microfacet kind finds its half vector, D and
// Fresnel factor once for the two.
fn eval_bsdf(m: Material, color: vec3<f32>, v: BsdfVertex, l: vec3<f32>) -> vec4<f32> {
// #if DIFFUSE
    if (m.brdf == BRDF_DIFFUSE) {
        let c = dot(v.n, l);
        var pdf = 0.0;
// #if PATHTRACER
        pdf = cosine_hemisphere_pdf(c);
// #endif
        return vec4<f32>(select(vec3<f32>(0.0), color * INV_PI, c > 0.0), pdf);
    }
// #endif
// #if MICROFACET
    if (is_microfacet(m)) {
        return microfacet_eval(m, color, v.front_face, v.o, v.e_o, to_local(v.frame, l));
    }
// #endif
    return vec4<f32>(0.0);
}
