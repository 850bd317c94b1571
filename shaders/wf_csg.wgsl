// #requires wf_classify csg
// CSG stage: the trees a closest-hit query deferred (in the order it met them, as
// cpu::World evaluates them), against the best candidate the traversal found; only the
// rays that met a tree run this code.

@compute @workgroup_size(64)
fn csg_stage(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let slot = wf_slot(Q_CSG, wf_index(gid, nwg));
    if (slot == WF_NONE) {
        return;
    }
    csg_use_slot(slot);
    var ray = load_ray(slot);
    var best = load_hit(slot);
    ray.tmax = min(ray.tmax, best.c.t);
    let base = slot * (CSG_DEFER_SLOTS + 1u);
    let count = deferred_refs[base];
    for (var k = 0u; k < count; k++) {
        let r = deferred_refs[base + 1u + k];
        let cand = csg_first(r & ~CSG_NODE_BIT, ray, r);
        if (cand.c.t < ray.tmax) {
            best = cand;
            ray.tmax = cand.c.t;
        }
    }
    classify(slot, best);
}
