// #requires wf_path camera
// Camera stage of the path tracer: one invocation per path slot of the batch writes its
// camera ray. The rest of a path's start is implicit, to save two per-lane stores here and
// loads later: bounce 0's ray queue is every slot in order (wf_intersect.wgsl), its
// throughput 1 and the camera a delta "previous vertex" (load_beta); the host has cleared
// the radiance.

@compute @workgroup_size(WF_WORKGROUP)
fn camera_stage(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_id) local: vec3<u32>) {
    let lane = local.x; // not local_invocation_index (wf_path.wgsl)
    let slot = wf_direct_slot(group.x, lane);
    if (slot == WF_NONE) {
        return;
    }
    let id = path_id(slot);
    store_ray(slot, pixel_ray(id.pixel, id.j));
}
