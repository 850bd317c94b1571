// #requires float_index
// Integer quotients of the small numbers that name paths and workgroups, without integer
// division: llvmpipe has no vector divide for integers, so each `a / b` between lanes
// became four scalar `div` instructions (in the camera stage, a third of its time on
// skybox.sl). A slot index is below contract::MAX_SLOTS < 2²², so the f32 quotient is within
// one of the integer one (WGSL allows x / y 2.5 ULP, under 0.7 below 2²²) and one step
// each way makes it exact.

// ⌊a / b⌋ for a < 2²² and b ≥ 1.
fn div_small(a: u32, b: u32) -> u32 {
    var q = floor_small(f32(a) / f32(b));
    let r = i32(a) - i32(q * b);
    if (r < 0) {
        q -= 1u;
    } else if (u32(r) >= b) {
        q += 1u;
    }
    return q;
}

// #if CAMERA
// ⌊a / b⌋ for any a and b ≥ 1 (pixel and camera-sample indices): div_small below 2²², the
// integer division above (only for images past 4 megapixels; lanes that all stay below skip
// it).
fn div_u32(a: u32, b: u32) -> u32 {
    if (a < 4194304u) {
        return div_small(a, b);
    }
    return a / b;
}
// #endif
