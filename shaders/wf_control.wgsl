// #requires wavefront
// The control kernels: one invocation each, between stages. Launch arguments are kept by
// the pushes themselves (wf_push), so all that is left is emptying queues: `advance` ends a
// bounce (counts its rays, empties the queues it consumed and their launches, moves to the
// next bounce); `shadow_csg_args` empties the closest-hit CSG queue before the CSG stage's
// second launch of the bounce, over the shadow rays' trees.

// The number of queues, WF_QUEUES, read from the size of `args_rays` (three words per
// queue): with a bound it cannot see, LLVM keeps these one-invocation loops as loops
// instead of unrolling them into twelve copies of per-lane atomics, and llvmpipe compiles
// the control kernels ~30 % faster (they run once per launch, so unrolling gains nothing).
fn queue_count() -> u32 {
    return arrayLength(&args_rays) / 3u;
}

// Queue q is empty in every shard, and so is its launch.
fn empty_queue(q: u32) {
    for (var s = 0u; s < WF_SHARDS; s++) {
        atomicStore(&control[ctrl_count(q, s)], 0u);
    }
    wf_clear_launch(q);
}

// After the shadow stage: the bounce's closest-hit CSG queue has been evaluated, so it is
// emptied and the CSG stage's second launch covers the shadow rays' trees alone.
@compute @workgroup_size(1)
fn shadow_csg_args() {
    empty_queue(Q_CSG);
}

// Adds n to the 64-bit counter at control[at] (low word), control[at + 1] (high word).
fn add_u64_counter(at: u32, n: u32) {
    let old = atomicAdd(&control[at], n);
    if (old + n < old) {
        atomicAdd(&control[at + 1u], 1u);
    }
}

@compute @workgroup_size(1)
fn advance() {
    let bounce = atomicLoad(&control[CTRL_BOUNCE]);
    let current = Q_RAY + (bounce & 1u);
    var rays = 0u;
    for (var s = 0u; s < WF_SHARDS; s++) {
        rays += atomicLoad(&control[ctrl_count(current, s)]);
// #if WF_SHADOW_COUNT
        // Without point lights each path in the shadow queue traced one shadow ray: the
        // shadow stage need not count them with an atomic per invocation.
        rays += atomicLoad(&control[ctrl_count(Q_SHADOW, s)]);
// #endif
    }
    add_u64_counter(CTRL_RAYS, rays);
    for (var q = 0u; q < queue_count(); q++) {
        if (q != Q_RAY + ((bounce + 1u) & 1u)) {
            empty_queue(q);
        }
    }
    atomicStore(&control[CTRL_BOUNCE], bounce + 1u);
}
