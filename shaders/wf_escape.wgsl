// #requires wf_path mis environment
// Escape stage: rays of this bounce that hit nothing add the environment's radiance,
// MIS-weighted against NEE (cpu::path_tracer), and their paths end.

@compute @workgroup_size(WF_WORKGROUP)
fn escape_stage(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_id) local: vec3<u32>) {
    let lane = local.x; // not local_invocation_index (wf_path.wgsl)
    let slot = wf_slot(Q_ESCAPE, group.x, lane);
    if (slot == WF_NONE) {
        return;
    }
    let ray = load_ray(slot);
    let beta = load_beta(slot, atomicLoad(&control[CTRL_BOUNCE]));
    add_radiance(slot, beta.xyz * pt_escaped(load_previous(slot, beta), normalize(ray.dir)));
}
