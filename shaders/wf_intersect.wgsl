// #requires wf_classify world
// Closest-hit stage: BVH and planes for every ray of this bounce's ray queue; rays that hit
// nothing end their paths here (wf_classify.wgsl). With CSG_QUEUE, the CSG trees the traversal met are handed to the CSG stage with the best
// candidate so far, instead of being evaluated here (DESIGN.md "Software adapters": code
// reachable in this kernel costs every ray on SIMD software GPUs).

@compute @workgroup_size(WF_WORKGROUP)
fn intersect_stage(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_id) local: vec3<u32>) {
    let lane = local.x; // not local_invocation_index (wf_path.wgsl)
    let bounce = atomicLoad(&control[CTRL_BOUNCE]);
    // Bounce 0's queue is every slot in order: the camera stage writes no entries.
    var slot = WF_NONE;
    if (bounce == 0u) {
        slot = wf_direct_slot(group.x, lane);
    } else {
        slot = wf_slot(Q_RAY + (bounce & 1u), group.x, lane);
    }
    if (slot == WF_NONE) {
        return;
    }
// #if CSG
// #if !CSG_QUEUE
    csg_use_slot(slot);
// #endif
// #endif
    let ray = load_ray(slot);
// #if CSG_QUEUE
    let best = traverse(ray, false);
    let to_csg = deferred.count > 0u;
    if (to_csg) {
        let base = deferred_record(slot, 0u);
        deferred_refs[base] = deferred.count;
        for (var k = 0u; k < deferred.count; k++) {
            deferred_refs[base + 1u + k] = deferred.refs[k];
        }
    }
    classify(slot, best, to_csg, ray.dir, bounce);
// #else
    classify(slot, world_first(ray, false), false, ray.dir, bounce);
// #endif
}
