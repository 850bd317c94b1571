// #requires bindings
// #if PIGMENT_IMAGE
// #requires textures cell_index
// #endif
// Pigments: mirrors scene::Pigment::color_at (uniform, checkered, image nearest/bilinear).

// #if PIGMENT_IMAGE
fn image_lookup(p: Pigment, u: f32, v: f32) -> vec3<f32> {
    let w = p.tex_width;
    let h = p.tex_height;
    if (w == 0u || h == 0u) {
        return vec3<f32>(0.0);
    }
    if (p.image_filter == FILTER_NEAREST) {
        let col = cell_index(u * f32(w), w);
        let row = cell_index(v * f32(h), h);
        return texel(p.tex_offset, w, col, row);
    }
    // Bilinear: wrap in u, clamp in v.
    let x = u * f32(w) - 0.5;
    let y = clamp(v * f32(h) - 0.5, 0.0, f32(h - 1u));
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let wi = i32(w);
    let c0 = u32(((i32(x0) % wi) + wi) % wi);
    let c1 = u32(((i32(x0 + 1.0) % wi) + wi) % wi);
    let r0 = floor_small(y0);
    let r1 = min(r0 + 1u, h - 1u);
    let top = texel(p.tex_offset, w, c0, r0) * (1.0 - fx) + texel(p.tex_offset, w, c1, r0) * fx;
    let bottom = texel(p.tex_offset, w, c0, r1) * (1.0 - fx) + texel(p.tex_offset, w, c1, r1) * fx;
    return top * (1.0 - fy) + bottom * fy;
}
// #endif

// A uniform pigment's colour (its `a`): what pigment_color gives it anywhere, read without
// the other kinds' code where only uniform pigments can reach the call.
fn uniform_pigment_color(index: u32) -> vec3<f32> {
    return pigment_at(index).a.xyz;
}

fn pigment_color(index: u32, uv: vec2<f32>) -> vec3<f32> {
    let p = pigment_at(index);
// #if PIGMENT_CHECKERED
    if (p.kind == PIGMENT_CHECKERED) {
        // The parities of ⌊u·n⌋ and ⌊v·n⌋ in float arithmetic, exact on every f32 integer
        // (halving and flooring one are exact): as the CPU's i64 cells, without llvmpipe's
        // per-lane float-to-int conversions (float_index.wgsl).
        let cell = floor(uv * f32(p.n));
        let parity = cell - 2.0 * floor(cell * 0.5);
        if (parity.x + parity.y != 1.0) {
            return p.a.xyz;
        }
        return p.b.xyz;
    }
// #endif
// #if PIGMENT_IMAGE
    if (p.kind == PIGMENT_IMAGE) {
        return image_lookup(p, uv.x, uv.y);
    }
// #endif
    return uniform_pigment_color(index);
}
