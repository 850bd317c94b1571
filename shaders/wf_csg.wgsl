// #requires wf_classify csg nearest
// #if WF_SHADOW_CSG
// #requires wf_shadow_ray paths_get paths_set
// #endif
// CSG stage: the trees a query deferred (in the order it met them, as cpu::World evaluates
// them). Launched twice per bounce over two queues, one of them empty each time
// (wf_control.wgsl): after the closest-hit stage over Q_CSG, the rays whose closest-hit
// query met trees, against the best candidate the traversal found; after the shadow stage
// over Q_SHADOW_CSG, the paths whose shadow rays met trees and nothing else, whose
// contributions it then adds. Only this kernel holds CSG code, and it calls csg_first from
// one place (Mesa inlines every call site).

@compute @workgroup_size(WF_WORKGROUP)
fn csg_stage(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_id) local: vec3<u32>) {
    let lane = local.x; // not local_invocation_index (wf_path.wgsl)
// #if WF_SHADOW_CSG
    // Whichever of the two queues is not empty: the closest-hit one unless its lengths,
    // summed over the shards, are 0.
    var closest = 0u;
    for (var s = 0u; s < WF_SHARDS; s++) {
        closest += atomicLoad(&control[ctrl_count(Q_CSG, s)]);
    }
    let shadows = closest == 0u;
    let slot = wf_slot(select(Q_CSG, Q_SHADOW_CSG, shadows), group.x, lane);
    let queries = select(1u, batch.shadow_rays, shadows);
// #else
    let shadows = false;
    let slot = wf_slot(Q_CSG, group.x, lane);
    let queries = 1u;
// #endif
    if (slot == WF_NONE) {
        return;
    }
    csg_use_slot(slot);
    var best = no_candidate();
    // The closest-hit ray's direction, for an escape (classify).
    var dir = vec3<f32>(0.0);
// #if WF_SHADOW_CSG
    let ri = field(F_RADIANCE, slot);
    var radiance = paths_get(ri).xyz;
// #endif
    for (var q = 0u; q < queries; q++) {
        var ray: Ray;
        var record = deferred_record(slot, 0u);
// #if WF_SHADOW_CSG
        var value = vec3<f32>(0.0);
        if (shadows) {
            // Shadow ray q, when the shadow stage left its trees to evaluate.
            let s = load_shadow_ray(slot, q);
            if (!s.present) {
                break;
            }
            record = deferred_record(slot, 1u + q);
            if (deferred_refs[record] == 0u) {
                continue;
            }
            ray = s.ray;
            value = s.value;
            best = no_candidate();
        } else {
            ray = load_ray(slot);
            best = load_hit(slot);
            dir = ray.dir;
        }
// #else
        ray = load_ray(slot);
        best = load_hit(slot);
        dir = ray.dir;
// #endif
        ray.tmax = min(ray.tmax, end_past(best.c.t));
        let count = deferred_refs[record];
        for (var k = 0u; k < count; k++) {
            let r = deferred_refs[record + 1u + k];
            let cand = csg_first(r & ~CSG_NODE_BIT, ray, r);
            if (cand.c.t < ray.tmax && replaces(cand, best)) {
                best = cand;
                ray.tmax = end_past(cand.c.t);
                if (shadows) {
                    break;
                }
            }
        }
// #if WF_SHADOW_CSG
        if (shadows && best.c.t >= OPEN) {
            radiance += value;
        }
// #endif
    }
// #if WF_SHADOW_CSG
    if (shadows) {
        paths_set(ri, vec4<f32>(radiance, 0.0));
        return;
    }
// #endif
    classify(slot, best, false, dir, atomicLoad(&control[CTRL_BOUNCE]));
}
