// #requires wavefront
// The control kernels: one invocation each, between stages, so that no launch is sized by
// the host (no read-back): `dispatch_args` turns queue lengths into indirect dispatch
// arguments; `advance` ends a bounce (counts its rays, empties the queues it consumed,
// swaps the ray queues) and sizes the next bounce's closest-hit launch.

// Grid of a launch over `n` entries: (x, y, 1) workgroups, x ≤ WF_MAX_GRID. The CSG
// stage's launch covers both its queues (at most one is non-empty: wf_csg.wgsl).
fn write_args(q: u32) {
    var n = atomicLoad(&control[CTRL_COUNT + q]);
    if (q == Q_CSG) {
        n += atomicLoad(&control[CTRL_COUNT + Q_SHADOW_CSG]);
    }
    let groups = (n + WF_WORKGROUP - 1u) / WF_WORKGROUP;
    let x = min(groups, WF_MAX_GRID);
    var y = 0u;
    if (x > 0u) {
        y = (groups + x - 1u) / x;
    }
    args[3u * q] = x;
    args[3u * q + 1u] = y;
    args[3u * q + 2u] = 1u;
}

// The number of queues, WF_QUEUES, read from the size of `args` (three words per queue):
// with a bound it cannot see, LLVM keeps these one-invocation loops as loops instead of
// unrolling them into twelve copies of per-lane atomics, and llvmpipe compiles the control
// kernels ~30 % faster (they run once per launch, so unrolling gains nothing).
fn queue_count() -> u32 {
    return arrayLength(&args) / 3u;
}

fn write_all_args() {
    for (var q = 0u; q < queue_count(); q++) {
        write_args(q);
    }
}

@compute @workgroup_size(1)
fn dispatch_args() {
    write_all_args();
}

// After the shadow stage: the bounce's closest-hit CSG queue has been evaluated, so it is
// emptied and the CSG stage's second launch covers the shadow rays' trees alone.
@compute @workgroup_size(1)
fn shadow_csg_args() {
    atomicStore(&control[CTRL_COUNT + Q_CSG], 0u);
    write_all_args();
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
    add_u64_counter(CTRL_RAYS, atomicLoad(&control[CTRL_COUNT + current]));
    for (var q = 0u; q < queue_count(); q++) {
        if (q != Q_RAY + ((bounce + 1u) & 1u)) {
            atomicStore(&control[CTRL_COUNT + q], 0u);
        }
    }
    atomicStore(&control[CTRL_BOUNCE], bounce + 1u);
    write_all_args();
}
