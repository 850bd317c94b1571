// #requires wavefront world
// Ray counts of the stages that trace shadow rays (the CPU reference counts every query
// alike, cpu::Context): one 64-bit add per invocation.

fn flush_rays_traced() {
    if (rays_traced == 0u) {
        return;
    }
    let old = atomicAdd(&control[CTRL_SHADOW_RAYS], rays_traced);
    if (old + rays_traced < old) {
        atomicAdd(&control[CTRL_SHADOW_RAYS + 1u], 1u);
    }
}
