// #requires random
// Keyed permutations: sampling::permute and sampling::permute_below (src/sampling/strata.rs)
// in the same u32 steps, so both devices permute alike.

// sampling::permute: the place of element i under the permutation of 0..2^bits that `key`
// picks (a four-round Feistel network, then a keyed rotation).
fn permute(i: u32, bits: u32, key: u32) -> u32 {
    if (bits == 0u) {
        return 0u;
    }
    let mask = 0xFFFFFFFFu >> (32u - bits);
    let a = bits / 2u;
    let b = bits - a;
    var x = i & mask;
    for (var round = 0u; round < 4u; round++) {
        let low = select(b, a, round % 2u == 0u);
        let high = bits - low;
        let lo = x & ((1u << low) - 1u);
        let hi = x >> low;
        let f = hash32(lo ^ (key + round * 0x9E3779B9u));
        x = (lo << high) | ((hi ^ f) & ((1u << high) - 1u));
    }
    return (x + hash32(key ^ 0x5851F42Du)) & mask;
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
