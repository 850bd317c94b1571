// #requires ggx finite
// #if PATHTRACER
// #requires warp
// #endif
// The GGX conductor (cpu::microfacet, Conductor) in the local frame, o = −d toward the
// viewer: single scattering with the exact conductor Fresnel per channel (or F = 1), plus
// the compensating lobe m.lobe · (1 − E(μo))(1 − E(μi)) over the material's albedo row.

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

// f(o, i), untinted (m.alpha > 0).
fn conductor_eval(m: Material, o: vec3<f32>, i: vec3<f32>) -> vec3<f32> {
    if (o.z <= 0.0 || i.z <= 0.0) {
        return vec3<f32>(0.0);
    }
    let a = m.alpha;
    let h = normalize(o + i);
    let ss = ggx_d(a, h) * ggx_g2(a, o, i) / (4.0 * o.z * i.z);
    let shape = ms_lobe(albedo_row(m.rows, CONDUCTOR_NODES, o.z), albedo_row(m.rows, CONDUCTOR_NODES, i.z), 1.0);
    return conductor_fresnel(m, dot(o, h)) * ss + m.lobe.xyz * shape;
}

// #if PATHTRACER
// The mixture's density: visible normals with probability E(μo), else the cosine.
fn conductor_pdf(m: Material, o: vec3<f32>, i: vec3<f32>) -> f32 {
    if (o.z <= 0.0 || i.z <= 0.0) {
        return 0.0;
    }
    let p = clamp(albedo_row(m.rows, CONDUCTOR_NODES, o.z), 0.0, 1.0);
    let h = normalize(o + i);
    return p * ggx_visible_pdf(m.alpha, o, h) / (4.0 * dot(o, h)) + (1.0 - p) * cosine_hemisphere_pdf(i.z);
}

fn conductor_sample(m: Material, o: vec3<f32>, xi_lobe: f32, xi0: f32, xi1: f32) -> LocalSample {
    let p = clamp(albedo_row(m.rows, CONDUCTOR_NODES, o.z), 0.0, 1.0);
    var i: vec3<f32>;
    if (xi_lobe < p) {
        i = reflect(-o, ggx_sample_visible(m.alpha, o, xi0, xi1));
    } else {
        i = cosine_hemisphere(xi0, xi1);
    }
    return local_direction(i);
}
// #endif
