// #requires bindings environment lights
// #if ENV_IMAGE
// #if STAGE_SHADE
// #requires float_index
// #endif
// #if ESCAPES
// #requires cell_index
// #endif
// #endif
// The environment as a light: mirrors cpu::env_light and sampling::distribution (the
// tables are packed in `floats` at environment.dist_offset, see src/gpu/pack.rs).

// #if ENV_IMAGE
// A Distribution1D of n cells packed at floats[base] (Distribution1D::packed; the DIST1D_*
// offsets are generated from sampling::distribution::packed).
fn dist1d_pdf_cell(base: u32, n: u32, i: u32) -> f32 {
    let integral = float_at(base + DIST1D_INTEGRAL);
    if (integral > 0.0) {
        return float_at(base + DIST1D_VALUES + i) / integral;
    }
    return 1.0;
}

// The words of a packed table of n cells.
fn dist1d_words(n: u32) -> u32 {
    return DIST1D_WORDS + DIST1D_WORDS_PER_CELL * n;
}

// #if STAGE_SHADE
fn dist1d_find_cell(base: u32, n: u32, u: f32) -> u32 {
    let cdf = base + DIST1D_CDF + n;
    var lo = 0u;
    var hi = n;
    while (hi - lo > 1u) {
        let mid = (lo + hi) / 2u;
        if (float_at(cdf + mid) <= u) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}
// #endif

// #if STAGE_SHADE
// Distribution1D::sample: (x, pdf, cell).
fn dist1d_sample(base: u32, n: u32, u: f32) -> vec3<f32> {
    let cell = dist1d_find_cell(base, n, u);
    let cdf = base + DIST1D_CDF + n;
    let c0 = float_at(cdf + cell);
    let width = float_at(cdf + cell + 1u) - c0;
    var du = 0.0;
    if (width > 0.0) {
        du = clamp((u - c0) / width, 0.0, 1.0);
    }
    let nf = f32(n);
    let upper = bitcast<f32>(bitcast<u32>((f32(cell) + 1.0) / nf) - 1u);
    let x = max(min((f32(cell) + du) / nf, upper), f32(cell) / nf);
    return vec3<f32>(x, dist1d_pdf_cell(base, n, cell), f32(cell));
}
// #endif

// Where row `row`'s table starts: after the marginal's (Distribution2D::packed_row).
fn env_row_base(row: u32) -> u32 {
    return environment.dist_offset + dist1d_words(environment.tex_height) + row * dist1d_words(environment.tex_width);
}

// #if ESCAPES
// Distribution2D::pdf.
fn env_dist_pdf(u: f32, v: f32) -> f32 {
    let w = environment.tex_width;
    let h = environment.tex_height;
    let row = cell_index(v * f32(h), h);
    let col = cell_index(u * f32(w), w);
    return dist1d_pdf_cell(environment.dist_offset, h, row) * dist1d_pdf_cell(env_row_base(row), w, col);
}
// #endif

// #if STAGE_SHADE
// env_light::equirect_dir.
fn equirect_dir(u: f32, v: f32, rotation_rad: f32) -> vec3<f32> {
    let phi = TAU * u + rotation_rad;
    let theta = PI * v;
    let s = sin(theta);
    return vec3<f32>(s * cos(phi), s * sin(phi), cos(theta));
}
// #endif

fn env_image_pdf(pdf_uv: f32, v: f32) -> f32 {
    let sin_theta = sin(PI * v);
    if (sin_theta <= 0.0) {
        return 0.0;
    }
    return pdf_uv / (2.0 * PI * PI * sin_theta);
}
// #endif

// #if STAGE_SHADE
// EnvLight::sample: a unit direction toward the environment, its density and the radiance
// along it (an image's: the sampled texel's, cpu::env_light::EnvSample); `azimuth` is
// turn(xi1).
struct EnvSample {
    dir: vec3<f32>,
    pdf: f32,
    radiance: vec3<f32>,
}

fn env_sample(xi0: f32, xi1: f32, azimuth: vec2<f32>) -> EnvSample {
// #if ENV_IMAGE
    if (environment.kind == ENV_IMAGE) {
        // The row by the marginal distribution, then the column by that row's conditional
        // one, through one call site of dist1d_sample: llvmpipe inlines every call, and each
        // site compiles its binary search and per-lane loads again. NIR cannot prove this
        // loop's trip count (two: a first draw is never negative), so it stays rolled; the
        // exit test also holds for a NaN, so the loop ends whatever the tables hold.
        var v = vec3<f32>(-1.0);
        var u = vec3<f32>(0.0);
        var base = environment.dist_offset;
        var n = environment.tex_height;
        var xi = xi1;
        loop {
            u = dist1d_sample(base, n, xi);
            if (!(v.x < 0.0)) {
                break;
            }
            v = u;
            base = env_row_base(floor_small(v.z));
            n = environment.tex_width;
            xi = xi0;
        }
        let dir = equirect_dir(u.x, v.x, environment.rotation_rad);
        return EnvSample(dir, env_image_pdf(u.y * v.y, v.x), env_texel_radiance(floor_small(u.z), floor_small(v.z)));
    }
// #endif
    let dir = uniform_sphere(xi0, azimuth);
    return EnvSample(dir, UNIFORM_SPHERE_PDF, escape_radiance(dir));
}
// #endif

// #if ESCAPES
// #if ENV_IMAGE
// EnvLight::pdf of the image light for the direction at (u, v) of the map.
fn env_image_pdf_at(uv: vec2<f32>) -> f32 {
    return env_image_pdf(env_dist_pdf(uv.x, uv.y), uv.y);
}
// #endif
// #endif
