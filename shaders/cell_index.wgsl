// #requires float_index
// The cell of n ≥ 1 unit cells that x falls in, the first and last taking everything beyond:
// min(u32(max(x, 0)), n − 1) for the sizes of tables and images (n < 2²³), in vector
// instructions (float_index.wgsl).
fn cell_index(x: f32, n: u32) -> u32 {
    return min(floor_small(clamp(x, 0.0, 8388607.0)), n - 1u);
}
