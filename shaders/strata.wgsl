// #requires random
// Stratified vertex draws: sampling::strata (src/sampling/strata.rs) in the same u32
// steps, so every draw is the CPU's bit for bit.

const STRATA_MAX: u32 = 65536u;

// sampling::permute: the stratum of element i (< n) under the permutation `key` picks
// (a four-round Feistel network on the bits of n - 1, cycle-walked into 0..n, then a keyed
// rotation).
fn strata_permute(i: u32, n: u32, key: u32) -> u32 {
    if (n <= 1u) {
        return 0u;
    }
    let bits = 32u - countLeadingZeros(n - 1u);
    let a = bits / 2u;
    let b = bits - a;
    var x = i & (0xFFFFFFFFu >> (32u - bits));
    // Cycle walking ends within the orbit of i (fewer than two steps on average).
    loop {
        for (var round = 0u; round < 4u; round++) {
            let low = select(b, a, round % 2u == 0u);
            let high = bits - low;
            let lo = x & ((1u << low) - 1u);
            let hi = x >> low;
            let f = hash32(lo ^ (key + round * 0x9E3779B9u));
            x = (lo << high) | ((hi ^ f) & ((1u << high) - 1u));
        }
        if (x < n) {
            break;
        }
    }
    return (x + hash32(key ^ 0x5851F42Du) % n) % n;
}

// sampling::seed_word of the tracer's seed (state.lo, state.hi, inc.lo, inc.hi).
fn strata_seed_word(seed: vec4<u32>) -> u32 {
    return hash32(seed.x ^ hash32(seed.y ^ hash32(seed.z ^ hash32(seed.w))));
}

// sampling::in_stratum: ⌊(c·2²⁴ + x) / m⌋ in u32 steps, for stratum c < m ≤ 2¹⁶ and a
// 24-bit draw x.
fn in_stratum(c: u32, m: u32, x: u32) -> u32 {
    let t = 16777216u;
    let y = c * (t % m);
    return c * (t / m) + y / m + (y % m + x) / m;
}

// sampling::VertexStrata::one and ::two applied to a vertex's seven 24-bit draws:
// dimensions 0, 3 and 6 alone, (1, 2) and (4, 5) as 2D points; `count` = M
// (settings.strata). Each result is exact in f32, the CPU's f64 draw bit for bit.
fn stratified_draws(x: array<u32, 7>, seed_word: u32, pixel: u32, sample: u32, bounce: u32, count: u32) -> array<f32, 7> {
    let m = clamp(count, 1u, STRATA_MAX);
    let index = sample % m;
    let base = hash32(hash32(hash32(pixel ^ seed_word) ^ (sample / m)) ^ bounce);
    // s with s² = m, or 0 (sqrt of an integer ≤ 2¹⁶ is within rounding of its root).
    var side = u32(round(sqrt(f32(m))));
    if (side * side != m) {
        side = 0u;
    }
    var u: array<u32, 7>;
    for (var d = 0u; d < 7u; d++) {
        let stratum = strata_permute(index, m, hash32(base ^ d));
        if (side != 0u && (d == 1u || d == 4u)) {
            u[d] = in_stratum(stratum % side, side, x[d]);
            u[d + 1u] = in_stratum(stratum / side, side, x[d + 1u]);
            d++;
        } else {
            u[d] = in_stratum(stratum, m, x[d]);
        }
    }
    var xi: array<f32, 7>;
    for (var d = 0u; d < 7u; d++) {
        xi[d] = f32(u[d]) * (1.0 / 16777216.0);
    }
    return xi;
}
