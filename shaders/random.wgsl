// PCG32 (XSH-RR 64/32) and the per-(pixel, sample, bounce) stream rule of
// src/sampling/mod.rs, bit for bit. WGSL has no 64-bit integers, so a 64-bit value is a
// vec2<u32> (x = low word, y = high word) and the multiply works on 16-bit limbs.

struct Pcg {
    state: vec2<u32>,
    inc: vec2<u32>,
}

const PCG_MULTIPLIER: vec2<u32> = vec2<u32>(0x4C957F2Du, 0x5851F42Du); // 6364136223846793005

// High 32 bits of the 64-bit product of two u32 (schoolbook on 16-bit limbs).
fn mul_hi_u32(a: u32, b: u32) -> u32 {
    let a0 = a & 0xFFFFu;
    let a1 = a >> 16u;
    let b0 = b & 0xFFFFu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let p11 = a1 * b1;
    let mid = (p00 >> 16u) + (p01 & 0xFFFFu) + (p10 & 0xFFFFu);
    return p11 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u);
}

// Wrapping 64-bit product.
fn mul_u64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x * b.x;
    let hi = mul_hi_u32(a.x, b.x) + a.x * b.y + a.y * b.x;
    return vec2<u32>(lo, hi);
}

// Wrapping 64-bit sum.
fn add_u64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    let carry = select(0u, 1u, lo < a.x);
    return vec2<u32>(lo, a.y + b.y + carry);
}

fn pcg_next_u32(rng: ptr<function, Pcg>) -> u32 {
    let old = (*rng).state;
    (*rng).state = add_u64(mul_u64(old, PCG_MULTIPLIER), (*rng).inc);
    // xorshifted = u32(((old >> 18) ^ old) >> 27), rot = old >> 59.
    let shifted = vec2<u32>((old.x >> 18u) | (old.y << 14u), old.y >> 18u);
    let x = shifted ^ old;
    let xorshifted = (x.x >> 27u) | (x.y << 5u);
    let rot = old.y >> 27u;
    return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
}

// pcg32_srandom_r(init_state, init_seq).
fn pcg_new(init_state: vec2<u32>, init_seq: vec2<u32>) -> Pcg {
    var rng: Pcg;
    rng.state = vec2<u32>(0u, 0u);
    rng.inc = vec2<u32>((init_seq.x << 1u) | 1u, (init_seq.y << 1u) | (init_seq.x >> 31u));
    pcg_next_u32(&rng);
    rng.state = add_u64(rng.state, init_state);
    pcg_next_u32(&rng);
    return rng;
}

// Wellons' lowbias32, as sampling::hash32.
fn hash32(v: u32) -> u32 {
    var x = v;
    x ^= x >> 16u;
    x *= 0x7feb352du;
    x ^= x >> 15u;
    x *= 0x846ca68bu;
    x ^= x >> 16u;
    return x;
}

// sampling::stream: the generator of one (pixel, sample, bounce), from the tracer's seed.
fn stream(seed_state: vec2<u32>, seed_inc: vec2<u32>, pixel: u32, sample: u32, bounce: u32) -> Pcg {
    let key_lo = hash32(hash32(hash32(pixel) ^ sample) ^ bounce);
    let key_hi = hash32(key_lo ^ 0x9E3779B9u);
    return pcg_new(add_u64(seed_state, vec2<u32>(key_lo, key_hi)), seed_inc);
}

// #if CAMERA
// A uniform float in [0, 1) with 24 random bits: exactly Pcg32::next_f32. (Path vertices
// take the 24 bits as integers, to stratify them: strata.wgsl.)
fn pcg_next_f32(rng: ptr<function, Pcg>) -> f32 {
    return f32(pcg_next_u32(rng) >> 8u) * (1.0 / 16777216.0);
}
// #endif
