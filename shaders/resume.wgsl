// #requires pass
// Resumable passes, for drivers with a loop limiter (feature LOOP_LIMITER; docs/DESIGN.md,
// "Loop limiter and path-granular passes"). A pass may then take several dispatches: each
// invocation runs whole paths until the driver's limiter fires (or the host's path budget
// is spent), keeps the exact f32 partial sums in pass_out and pass_state, and the next
// dispatch resumes at the first path not yet summed, so the pass sum is bit for bit the
// one an unlimited dispatch would compute.

// Per tile pixel (same index as pass_out): .xyz = f32 bits of the partial sum over the
// paths of the current camera sample, .w = paths of this pass done | flags below. The host
// zeroes it before the first dispatch of a pass.
@group(0) @binding(2) var<storage, read_write> pass_state: array<vec4<u32>>;

const RESUME_PROGRESS: u32 = 0x0FFFFFFFu; // paths of this pass summed, (j − j0)·n + i
const RESUME_DONE: u32 = 0x10000000u;     // every path of the pass is summed
const RESUME_NEEDS_SOLO: u32 = 0x20000000u; // the first path of a dispatch was cut: run it alone
const RESUME_LIMITED: u32 = 0x40000000u;  // run alone and cut anyway: counted as 0
const RESUME_NO_SOLO: u32 = 0xFFFFFFFFu;  // pass_params.solo_pixel when every pixel runs

// Index of this invocation's pixel in pass_out and pass_state.
fn pass_index(gid: vec3<u32>) -> u32 {
    return gid.y * pass_params.tile_size.x + gid.x;
}

// Whether the driver's loop limiter has fired in this invocation: once it has, every loop
// exits at its first back-edge, so a loop of two iterations stops after one. The trip count
// is not a constant (tile_size.x is never 0) so the compiler cannot unroll the loop away.
fn loop_limiter_fired() -> bool {
    let trips = select(2u, 3u, pass_params.tile_size.x == 0u);
    var count = 0u;
    loop {
        count += 1u;
        if (count >= trips) {
            break;
        }
    }
    return count < trips;
}
