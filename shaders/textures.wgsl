// #requires bindings
// Texel reads from the `floats` buffer (image pigments, image environments).

// Texel (col, row) of the image whose rgb triples start at floats[offset].
fn texel(offset: u32, width: u32, col: u32, row: u32) -> vec3<f32> {
    let i = offset + 3u * (row * width + col);
    return vec3<f32>(float_at(i), float_at(i + 1u), float_at(i + 2u));
}
