// #requires wf_path world wf_shadow_ray paths_get paths_set
// #if WF_COUNT
// #requires wf_counting
// #endif
// Shadow stage: for every path that queued shadow rays this bounce, trace them in order
// (any-hit) and add the contribution of each one nothing blocks. One invocation per path,
// so a path's radiance is only ever written by one invocation, in a fixed order. With
// CSG_QUEUE, a ray that meets CSG trees and nothing else leaves them in its deferred
// record and the path goes to Q_SHADOW_CSG: the CSG stage evaluates them after this stage
// and adds those rays' contributions (in ray order, after the ones added here).

@compute @workgroup_size(WF_WORKGROUP)
fn shadow_stage(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_id) local: vec3<u32>) {
    let lane = local.x; // not local_invocation_index (wf_path.wgsl)
    let slot = wf_slot(Q_SHADOW, group.x, lane);
    if (slot == WF_NONE) {
        return;
    }
// #if CSG
// #if !CSG_QUEUE
    csg_use_slot(slot);
// #endif
// #endif
    let ri = field(F_RADIANCE, slot);
    var radiance = paths_get(ri).xyz;
// #if CSG_QUEUE
    var pending = false;
// #endif
    for (var k = 0u; k < batch.shadow_rays; k++) {
        let s = load_shadow_ray(slot, k);
        if (!s.present) {
            break;
        }
        let ray = s.ray;
// #if CSG_QUEUE
// #if WF_COUNT
        rays_traced += 1u;
// #endif
        let record = deferred_record(slot, 1u + k);
        var trees = 0u;
        if (traverse(ray, true).c.t >= OPEN) {
            trees = deferred.count;
            if (trees == 0u) {
                radiance += s.value;
            }
            for (var j = 0u; j < trees; j++) {
                deferred_refs[record + 1u + j] = deferred.refs[j];
            }
        }
        deferred_refs[record] = trees;
        pending = pending || trees > 0u;
// #else
        if (!occluded(ray)) {
            radiance += s.value;
        }
// #endif
    }
    paths_set(ri, vec4<f32>(radiance, 0.0));
// #if CSG_QUEUE
    if (pending) {
        wf_push(Q_SHADOW_CSG, slot);
    }
// #endif
// #if WF_COUNT
    flush_rays_traced(slot);
// #endif
}
