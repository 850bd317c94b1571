// Indices from floats in vector instructions. llvmpipe converts u32(f32) one lane at a time
// (a scalar convert and two compares for WGSL's saturation, per lane: two dozen
// instructions for four lanes); this is a vector floor, add and integer subtract
// (docs/DESIGN.md "Float to index").

// ⌊x⌋ for 0 ≤ x < 2²³: in x + 2²³ the mantissa's last bit is worth 1, so its bits less
// those of 2²³ are ⌊x⌋.
fn floor_small(x: f32) -> u32 {
    return bitcast<u32>(floor(x) + 8388608.0) - 0x4B000000u;
}
