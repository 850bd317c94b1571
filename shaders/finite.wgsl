// Whether any channel is NaN or infinite (by bits: immune to fast-math folding).
fn non_finite(v: vec3<f32>) -> bool {
    let e = bitcast<vec3<u32>>(v) & vec3<u32>(0x7F800000u);
    return any(e == vec3<u32>(0x7F800000u));
}
