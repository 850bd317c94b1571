// #requires wavefront world
// Ray counts of the stages that trace shadow rays (the CPU reference counts every query
// alike, cpu::Context): one 64-bit add per invocation, to the counter of the path's shard
// (contract::Control), so that the threads of a software GPU do not share its line.

fn flush_rays_traced(slot: u32) {
    if (rays_traced == 0u) {
        return;
    }
    let at = ctrl_shadow_rays(wf_shard(slot));
    let old = atomicAdd(&control[at], rays_traced);
    if (old + rays_traced < old) {
        atomicAdd(&control[at + 1u], 1u);
    }
}
