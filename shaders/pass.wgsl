// The progressive-pass kernel contract (see docs/DESIGN.md, "GPU passes", and
// src/gpu/passes.rs). A pass kernel declares exactly these two bindings in group 0; the
// scene's buffers go in groups 1 and up. Invocation (gid.x, gid.y) handles the pixel at
// column gid.x, row gid.y *of the tile*; it sums its camera samples j in
// [sample_begin, sample_end) and writes (not adds) the sum with pass_write.

struct PassParams {
    tile_origin: vec2<u32>,  // image pixel of the tile's top-left corner
    tile_size: vec2<u32>,    // tile width, height in pixels
    image_size: vec2<u32>,   // image width, height in pixels
    sample_begin: u32,       // first camera sample index j0 of this pass
    sample_end: u32,         // one past the last camera sample index j1
    // Resumable kernels only (shaders/resume.wgsl); others ignore them:
    solo_pixel: u32,         // the one tile pixel (row * tile width + column) to run, or all: 0xFFFFFFFF
    path_budget: u32,        // at most this many paths per invocation per dispatch (0: no bound)
    _pad: vec2<u32>,
}

@group(0) @binding(0) var<uniform> pass_params: PassParams;
@group(0) @binding(1) var<storage, read_write> pass_out: array<vec4<f32>>;

// Whether this invocation maps to a pixel of the tile (dispatches round up).
fn pass_in_tile(gid: vec3<u32>) -> bool {
    return gid.x < pass_params.tile_size.x && gid.y < pass_params.tile_size.y;
}

// The image pixel (column, row) of this invocation; row 0 is the top.
fn pass_pixel(gid: vec3<u32>) -> vec2<u32> {
    return pass_params.tile_origin + gid.xy;
}

// The pixel index used by the random stream rule: row * width + column.
fn pass_pixel_index(gid: vec3<u32>) -> u32 {
    let p = pass_pixel(gid);
    return p.y * pass_params.image_size.x + p.x;
}

// Stores this pixel's sum over the pass's samples.
fn pass_write(gid: vec3<u32>, sum: vec3<f32>) {
    pass_out[gid.y * pass_params.tile_size.x + gid.x] = vec4<f32>(sum, 0.0);
}
