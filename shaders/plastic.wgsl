// #requires ggx fresnel
// #if PATHTRACER
// #requires warp
// #endif
// The plastic (cpu::microfacet, Plastic) in the local frame, o = −d toward the viewer: a
// diffuse base of albedo ρ (the pigment) under a dielectric coat of index m.ior, GGX when
// m.alpha > 0 (its reflected albedo E_R in the material's row) and smooth (exact Fresnel,
// a delta reflection) when m.alpha = 0. m.lobe = (internal r_i, base scale).

// The coat's reflected albedo E_R(μ).
fn coat_albedo(m: Material, mu: f32) -> f32 {
    if (m.alpha == 0.0) {
        return fresnel_dielectric(mu, m.ior);
    }
    return albedo_row(m.rows, DIELECTRIC_NODES, mu);
}

// f(o, i): the coat's GGX reflection (none when smooth: a delta) and the base.
fn plastic_eval(m: Material, rho: vec3<f32>, o: vec3<f32>, i: vec3<f32>) -> vec3<f32> {
    if (o.z <= 0.0 || i.z <= 0.0) {
        return vec3<f32>(0.0);
    }
    let r_i = m.lobe.x;
    let shape = ms_lobe(coat_albedo(m, o.z), coat_albedo(m, i.z), m.lobe.y);
    var f = rho * (1.0 - r_i) / (1.0 - rho * r_i) * shape;
    if (m.alpha > 0.0) {
        let a = m.alpha;
        let h = normalize(o + i);
        f += vec3<f32>(fresnel_dielectric(dot(o, h), m.ior) * ggx_d(a, h) * ggx_g2(a, o, i) / (4.0 * o.z * i.z));
    }
    return f;
}

// #if PATHTRACER
// Density of the non-delta scattering: the coat with probability E_R(μo), else the cosine.
fn plastic_pdf(m: Material, o: vec3<f32>, i: vec3<f32>) -> f32 {
    if (o.z <= 0.0 || i.z <= 0.0) {
        return 0.0;
    }
    let p = coat_albedo(m, o.z);
    var coat = 0.0;
    if (m.alpha > 0.0) {
        let h = normalize(o + i);
        coat = ggx_visible_pdf(m.alpha, o, h) / (4.0 * dot(o, h));
    }
    return p * coat + (1.0 - p) * cosine_hemisphere_pdf(i.z);
}

fn plastic_sample(m: Material, o: vec3<f32>, xi_lobe: f32, xi0: f32, xi1: f32) -> LocalSample {
    let p = coat_albedo(m, o.z);
    var i: vec3<f32>;
    if (xi_lobe < p) {
        if (m.alpha == 0.0) {
            // The smooth coat reflects F(μo), chosen with probability F(μo).
            return LocalSample(vec3<f32>(-o.x, -o.y, o.z), vec3<f32>(1.0), 0.0, true, true);
        }
        i = reflect(-o, ggx_sample_visible(m.alpha, o, xi0, xi1));
    } else {
        i = cosine_hemisphere(xi0, xi1);
    }
    return local_direction(i);
}
// #endif
