// Keyed permutations: sampling::permute and sampling::permute_below (src/sampling/strata.rs)
// in the same u32 steps, so both devices permute alike.

// sampling::permute: the place of element i under the permutation of 0..2^bits that `key`
// picks (four rounds of keyed xor or add, odd multiply and xor-shift modulo 2^bits, then a
// rotation by the key's high half).
fn permute(i: u32, bits: u32, key: u32) -> u32 {
    if (bits == 0u) {
        return 0u;
    }
    let mask = 0xFFFFFFFFu >> (32u - bits);
    let half = (bits + 1u) / 2u;
    let s = key & 0xFFFFu;
    var x = i & mask;
    x = ((x ^ s) * ((s >> 3u) | 1u)) & mask;
    x ^= x >> half;
    x = ((x + (s >> 5u)) * 0x2C1B3C6Du) & mask;
    x ^= x >> half;
    x = ((x ^ (s >> 9u)) * ((s >> 6u) | 1u)) & mask;
    x ^= x >> half;
    x = ((x + (s >> 2u)) * 0x297A2D39u) & mask;
    x ^= x >> half;
    return (x + (key >> 16u)) & mask;
}

// #if CAMERA
// sampling::permute_below: element i (< n) under a permutation of 0..n for any n ≥ 1, by
// cycle walking over `permute` on the next power of two (fewer than two steps on average;
// once per camera sample).
fn permute_below(i: u32, n: u32, key: u32) -> u32 {
    if (n <= 1u) {
        return 0u;
    }
    let bits = 32u - countLeadingZeros(n - 1u);
    var x = permute(i, bits, key);
    while (x >= n) {
        x = permute(x, bits, key);
    }
    return x;
}
// #endif
