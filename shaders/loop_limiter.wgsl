// Probe for a driver loop limiter (see docs/DESIGN.md, "Bounded invocations"). Mesa's
// llvmpipe (lavapipe) ends every loop of an invocation once it has run 65,535 loop
// iterations in total; a GPU without such a limiter counts to the end. The trip count comes
// from the buffer so the compiler cannot fold or unroll the loop.
@group(0) @binding(0) var<storage, read_write> probe: array<u32>;

@compute @workgroup_size(1)
fn main() {
    let trips = probe[0];
    var count = 0u;
    loop {
        if (count >= trips) {
            break;
        }
        count += 1u;
    }
    probe[1] = count;
}
