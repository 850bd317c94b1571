// #requires random permute
// Stratified vertex draws: sampling::strata (src/sampling/strata.rs) in the same u32
// steps (masks and shifts only), so every draw is the CPU's bit for bit.

// sampling::in_stratum: ⌊(c·2²⁴ + x) / 2^n⌋, the 24-bit draw x in stratum c of 2^n.
fn in_stratum(c: u32, n: u32, x: u32) -> u32 {
    return (c << (24u - n)) | (x >> n);
}

// sampling::VertexStrata::draws, line for line: a vertex's seven 24-bit draws moved into
// the strata of sample `sample` of `pixel` at `bounce`. `k` = settings.strata_bits
// (sampling::strata_bits keeps it within 16); `seed_word` = settings.strata_seed. Each
// result is exact in f32.
fn stratified_draws(x: array<u32, 7>, seed_word: u32, pixel: u32, sample: u32, bounce: u32, k: u32) -> array<f32, 7> {
    // VertexStrata::new
    let index = sample & ((1u << k) - 1u);
    let base = hash32(hash32(hash32(pixel ^ seed_word) ^ (sample >> k)) ^ bounce);
    let across = (k + 1u) / 2u;
    var xi: array<f32, 7>;
    var cell = 0u;
    for (var d = 0u; d < 7u; d++) {
        let second = d == 2u || d == 5u;
        if (!second) {
            cell = permute(index, k, hash32(base ^ d));
        }
        var c = cell;
        var n = k;
        if (d == 1u || d == 4u) {
            c = cell & ((1u << across) - 1u);
            n = across;
        } else if (second) {
            c = cell >> across;
            n = k - across;
        }
        xi[d] = f32(in_stratum(c, n, x[d])) * (1.0 / 16777216.0);
    }
    return xi;
}
