// #requires bindings onb float_index
// #if PATHTRACER
// #requires finite
// #endif
// The GGX microfacet distribution in the local frame of the normal (z = n): optics::ggx in
// f32 (D, Smith's height-correlated G2 and G1, visible-normal sampling by spherical caps;
// microfacet.wgsl forms their density from G1 and D), the energy rows of the compensation (optics::energy_tables::row_value) and
// the local-frame sample shared by the microfacet kinds (cpu::microfacet).

// A material's local frame: t, b and the normal n.
struct Frame {
    t: vec3<f32>,
    b: vec3<f32>,
    n: vec3<f32>,
}

fn frame_of(n: vec3<f32>) -> Frame {
    let o = onb(n);
    return Frame(o.t, o.b, n);
}

fn to_local(f: Frame, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(v, f.t), dot(v, f.b), dot(v, f.n));
}

// D(h) = α² / (π (sin²θ + α² cos²θ)²), sin²θ from x² + y² (accurate as α → 0).
fn ggx_d(alpha: f32, h: vec3<f32>) -> f32 {
    if (h.z <= 0.0) {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let t = h.x * h.x + h.y * h.y + h.z * h.z * a2;
    return a2 / (PI * t * t);
}

// √(cos²θ + α² sin²θ) = |cos θ|(1 + 2Λ): Smith's Λ without tan θ.
fn ggx_lambda_term(alpha: f32, w: vec3<f32>) -> f32 {
    return sqrt(w.z * w.z + alpha * alpha * (w.x * w.x + w.y * w.y));
}

// G2(o, i) = 1 / (1 + Λ(o) + Λ(i)), written so grazing directions give 0.
fn ggx_g2(alpha: f32, o: vec3<f32>, i: vec3<f32>) -> f32 {
    let co = abs(o.z);
    let ci = abs(i.z);
    let den = ci * ggx_lambda_term(alpha, o) + co * ggx_lambda_term(alpha, i);
    return select(0.0, 2.0 * co * ci / den, den > 0.0);
}

// #if PATHTRACER
fn to_world(f: Frame, v: vec3<f32>) -> vec3<f32> {
    return f.t * v.x + f.b * v.y + f.n * v.z;
}

// G1(w) = 2|cos θ| / (|cos θ| + √(cos²θ + α² sin²θ)).
fn ggx_g1(alpha: f32, w: vec3<f32>) -> f32 {
    let c = abs(w.z);
    let den = c + ggx_lambda_term(alpha, w);
    return select(0.0, 2.0 * c / den, den > 0.0);
}

// A visible normal from o (o.z > 0): o plus a uniform point of the spherical cap
// z > −o.z, in the configuration stretched to α = 1 (Dupuy & Benyoub 2023).
fn ggx_sample_visible(alpha: f32, o: vec3<f32>, u0: f32, u1: f32) -> vec3<f32> {
    let ws = normalize(vec3<f32>(alpha * o.x, alpha * o.y, o.z));
    let phi = TAU * u0;
    let z = (1.0 - u1) * (1.0 + ws.z) - ws.z;
    let s = sqrt(max(1.0 - z * z, 0.0));
    let h = vec3<f32>(s * cos(phi), s * sin(phi), z) + ws;
    let m = vec3<f32>(alpha * h.x, alpha * h.y, max(h.z, 0.0));
    let len = length(m);
    return select(vec3<f32>(0.0, 0.0, 1.0), m / len, len > 0.0);
}

// A local-frame sample: direction, f·|cos|/pdf, pdf; `delta` for the smooth plastic coat.
// A non-delta lobe leaves weight and pdf to the shading stage, which evaluates the BSDF at
// the sampled direction through the call site it evaluates the lights' directions at
// (wf_shade.wgsl): each call site would compile the whole BSDF again.
struct LocalSample {
    dir: vec3<f32>,
    weight: vec3<f32>,
    pdf: f32,
    delta: bool,
    valid: bool,
}

// A sampled non-delta direction, its f and density still to evaluate.
fn local_direction(i: vec3<f32>) -> LocalSample {
    return LocalSample(i, vec3<f32>(0.0), 0.0, false, !non_finite(i));
}

// A local sample in the world frame (brdf.wgsl's BsdfSample; pending unless a delta lobe,
// whose weight is scaled by `delta_weight`).
fn world_sample(f: Frame, s: LocalSample, delta_weight: vec3<f32>) -> BsdfSample {
    let dir = normalize(to_world(f, s.dir));
    if (s.delta) {
        return BsdfSample(dir, s.weight * delta_weight, s.pdf, true, s.valid, false);
    }
    return BsdfSample(dir, vec3<f32>(0.0), 0.0, false, s.valid, s.valid);
}
// #endif

// The albedo row at `offset` in `rows` (`n` nodes uniform in √μ) read at μ.
fn albedo_row(offset: u32, n: u32, mu: f32) -> f32 {
    let t = clamp(sqrt(max(mu, 0.0)), 0.0, 1.0) * f32(n - 1u);
    let j = min(floor_small(t), n - 2u);
    let w = t - f32(j);
    return row_at(offset + j) * (1.0 - w) + row_at(offset + j + 1u) * w;
}

// (1 − E(μo))(1 − E(μi)) · scale (optics::compensation::ms_lobe).
fn ms_lobe(e_o: f32, e_i: f32, scale: f32) -> f32 {
    return max(1.0 - e_o, 0.0) * max(1.0 - e_i, 0.0) * scale;
}
