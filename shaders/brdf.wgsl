// #requires ray
// #if PATHTRACER
// #if DIFFUSE
// #requires onb
// #endif
// #endif
// BRDF sampling, evaluation and densities: mirrors cpu::{bsdf, fresnel, warp}.
// `d` is the unit direction the incoming ray travels along, `n` the unit normal facing it.

// #if PATHTRACER

struct BsdfSample {
    dir: vec3<f32>,
    // f · |cos| / pdf.
    weight: vec3<f32>,
    pdf: f32,
    delta: bool,
    // False when nothing is scattered.
    valid: bool,
}

// #if SPECULAR
fn reflect_dir(d: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return d - 2.0 * dot(d, n) * n;
}
// #endif

// #if DIELECTRIC
fn reflect_dir_dielectric(d: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return d - 2.0 * dot(d, n) * n;
}

// Unpolarised Fresnel reflectance: fresnel::fresnel_dielectric.
fn fresnel_dielectric(cos_i_in: f32, eta: f32) -> f32 {
    let cos_i = clamp(cos_i_in, 0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0) {
        return 1.0;
    }
    let cos_t = sqrt(1.0 - sin2_t);
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

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
    let reflected = BsdfSample(reflect_dir_dielectric(d, n), color, 0.0, true, true);
    if (xi_lobe < f) {
        return reflected;
    }
    let t = refract_dir(d, n, eta);
    if (all(t == vec3<f32>(0.0))) {
        return reflected;
    }
    return BsdfSample(normalize(t), color / (eta * eta), 0.0, true, true);
}
// #endif

// #if DIFFUSE
// Cosine-weighted hemisphere about +z: warp::cosine_hemisphere.
fn cosine_hemisphere(xi0: f32, xi1: f32) -> vec3<f32> {
    let r = sqrt(xi0);
    let phi = TAU * xi1;
    return vec3<f32>(r * cos(phi), r * sin(phi), sqrt(max(1.0 - xi0, 0.0)));
}

fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    return max(cos_theta, 0.0) * INV_PI;
}

fn sample_diffuse(color: vec3<f32>, n: vec3<f32>, xi0: f32, xi1: f32) -> BsdfSample {
    let local = cosine_hemisphere(xi0, xi1);
    let frame = onb(n);
    let dir = normalize(frame.t * local.x + frame.b * local.y + n * local.z);
    let pdf = cosine_hemisphere_pdf(local.z);
    return BsdfSample(dir, color, pdf, false, pdf > 0.0);
}
// #endif

// bsdf::sample_bsdf with the vertex's draws ξ3 (lobe), ξ4, ξ5 (direction).
fn sample_bsdf(m: Material, color: vec3<f32>, d: vec3<f32>, n: vec3<f32>, front_face: bool, xi_lobe: f32, xi0: f32,
               xi1: f32) -> BsdfSample {
// #if SPECULAR
    if (m.brdf == BRDF_SPECULAR) {
        return BsdfSample(reflect_dir(d, n), color, 0.0, true, true);
    }
// #endif
// #if DIELECTRIC
    if (m.brdf == BRDF_DIELECTRIC) {
        return sample_dielectric(color, d, n, select(1.0 / m.ior, m.ior, front_face), xi_lobe);
    }
// #endif
// #if DIFFUSE
    if (m.brdf == BRDF_DIFFUSE) {
        return sample_diffuse(color, n, xi0, xi1);
    }
// #endif
    return BsdfSample(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, true, false);
}

// #endif

// #if SHADOWS
// bsdf::eval_bsdf: f for light from `l` (0 for delta BRDFs).
fn eval_bsdf(m: Material, color: vec3<f32>, n: vec3<f32>, l: vec3<f32>) -> vec3<f32> {
    if (m.brdf == BRDF_DIFFUSE && dot(n, l) > 0.0) {
        return color * INV_PI;
    }
    return vec3<f32>(0.0);
}
// #endif

// #if NEE
// #if DIFFUSE
// bsdf::pdf_bsdf.
fn pdf_bsdf(m: Material, n: vec3<f32>, l: vec3<f32>) -> f32 {
    if (m.brdf == BRDF_DIFFUSE) {
        return cosine_hemisphere_pdf(dot(n, l));
    }
    return 0.0;
}
// #endif
// #endif
