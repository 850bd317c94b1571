// #requires layout
// Ray counting (feature COUNT_RAYS, for `lumen bench`): every closest-hit and occlusion
// query (world_first) counts one ray, like cpu::Context. An invocation counts in a private
// variable and adds its total once, at its end, to a 64-bit counter of two u32 words.

@group(1) @binding(13) var<storage, read_write> ray_count: array<atomic<u32>, 2>;

var<private> rays_traced: u32;

// Adds this invocation's rays to the counter (low word, then the carry into the high word).
fn flush_ray_count() {
    let old = atomicAdd(&ray_count[0], rays_traced);
    if (old + rays_traced < old) {
        atomicAdd(&ray_count[1], 1u);
    }
    rays_traced = 0u;
}
