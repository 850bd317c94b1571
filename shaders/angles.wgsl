// #requires ray
// Angles to f32 precision. WGSL allows atan2 (and acos, defined through it) an error of
// 4096 ulps, and software drivers use it: lavapipe's atan2 is off by ~1e-4, enough to
// pick the neighbouring texel of an environment map in one pixel out of fifty. This one
// stays within 2e-7 rad of the f64 value on every driver. The polar angle of a direction
// d is atan2_precise(|d.xy|, d.z): acos(z/|d|) without acos's loss of precision near the
// poles.

// atan2(y, x) in (−π, π]: the octant is reduced to a ratio q in [0, 1], where
// atan(q) = q·P(q²) with P a degree-8 least-squares fit (max error 1.1e-7 rad in f32).
fn atan2_precise(y: f32, x: f32) -> f32 {
    let ax = abs(x);
    let ay = abs(y);
    let hi = max(ax, ay);
    if (hi == 0.0) {
        // atan2(±0, +0) = 0, atan2(±0, −0) = π (the sign of y is dropped: u wraps anyway).
        return select(0.0, PI, (bitcast<u32>(x) >> 31u) == 1u);
    }
    let q = min(ax, ay) / hi;
    let s = q * q;
    var p = 0.0028340642;
    p = p * s - 0.016005030;
    p = p * s + 0.042587608;
    p = p * s - 0.074954458;
    p = p * s + 0.10636754;
    p = p * s - 0.14202571;
    p = p * s + 0.19992484;
    p = p * s - 0.33333066;
    p = p * s + 1.0;
    var a = q * p;
    if (ay > ax) {
        a = 0.5 * PI - a;
    }
    if (x < 0.0) {
        a = PI - a;
    }
    return select(a, -a, y < 0.0);
}
