// Exact power-of-two rescaling before squaring a vector's length: mirrors
// cpu::ray::pow2_rescale in f32.

// The power of two 2⁻ᵉ bringing m into [1, 2), e clamped to ±126 so that 2⁻ᵉ is itself a
// normal number: multiplying by it is exact, so |v|² of a normal or direction leaving a
// shape scaled by 1e30 (|v| ≈ 1e-30) neither underflows nor changes any digit in range.
fn pow2_rescale(m: f32) -> f32 {
    let e = clamp(i32((bitcast<u32>(m) >> 23u) & 0xFFu) - 127, -126, 126);
    return bitcast<f32>(u32(127 - e) << 23u);
}
