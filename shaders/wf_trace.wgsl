// #requires wf_classify world
// #if SHADOWS
// #requires wf_path wf_counting wf_shadow_ray
// #endif
// Trace stage: a bounce's closest-hit queries and its shadow rays, through one call of the
// traversal (Mesa inlines every call site, so a second kernel or call site would compile the
// BVH walk, every shape's intersection and meshes' bottom-level walks a second time).
// Launched twice per bounce:
// - over the ray queue of the bounce's parity: the closest hit of each ray, classified for
//   the escape or shading stages; with CSG_QUEUE, the CSG trees the traversal met are handed
//   to the CSG stage with the best candidate so far instead of being evaluated here;
// - after the shading stages, over Q_SHADOW: per path, its shadow rays in order (any-hit),
//   adding the contribution of each one nothing blocks, so a path's radiance is only ever
//   written by one invocation, in a fixed order. With CSG_QUEUE, a ray that meets CSG trees
//   and nothing else leaves them in its deferred record and the path goes to Q_SHADOW_CSG:
//   the CSG stage evaluates them next and adds those rays' contributions (in ray order,
//   after the ones added here).
// Only the shading stages push to Q_SHADOW and `advance` empties it, so it holds entries
// exactly while the second launch runs: that is how an invocation knows its role.

@compute @workgroup_size(WF_WORKGROUP)
fn trace_stage(@builtin(global_invocation_id) gid: vec3<u32>) {
    let index = wf_index(gid);
    var slot = WF_NONE;
    var queries = 1u;
// #if SHADOWS
    let shadows = atomicLoad(&control[CTRL_COUNT + Q_SHADOW]) != 0u;
    if (shadows) {
        slot = wf_slot(Q_SHADOW, index);
        queries = batch.shadow_rays;
    } else {
// #else
    let shadows = false;
    {
// #endif
        let bounce = atomicLoad(&control[CTRL_BOUNCE]);
        // Bounce 0's queue is every slot in order: the camera stage writes no entries.
        if (bounce == 0u) {
            if (index < batch.path_count) {
                slot = index;
            }
        } else {
            slot = wf_slot(Q_RAY + (bounce & 1u), index);
        }
    }
    if (slot == WF_NONE) {
        return;
    }
// #if CSG
// #if !CSG_QUEUE
    csg_use_slot(slot);
// #endif
// #endif
// #if SHADOWS
    let ri = field(F_RADIANCE, slot);
    var radiance = vec3<f32>(0.0);
    if (shadows) {
        radiance = paths[ri].xyz;
    }
// #if CSG_QUEUE
    var pending = false;
// #endif
// #endif
    for (var k = 0u; k < queries; k++) {
        var ray: Ray;
// #if SHADOWS
        var value = vec3<f32>(0.0);
        if (shadows) {
            let s = load_shadow_ray(slot, k);
            if (!s.present) {
                break;
            }
            ray = s.ray;
            value = s.value;
        } else {
            ray = load_ray(slot);
        }
// #else
        ray = load_ray(slot);
// #endif
// #if CSG_QUEUE
// #if WF_COUNT
        rays_traced += 1u;
// #endif
        let best = traverse(ray, shadows);
        // The trees to hand over: those a closest-hit query met, or, for a shadow ray, those
        // it met when nothing else blocks it.
        var record = deferred_record(slot, 0u);
        var trees = deferred.count;
// #if SHADOWS
        if (shadows) {
            record = deferred_record(slot, 1u + k);
            trees = select(0u, deferred.count, best.c.t >= OPEN);
            pending = pending || trees > 0u;
        }
// #endif
        deferred_refs[record] = trees;
        for (var j = 0u; j < trees; j++) {
            deferred_refs[record + 1u + j] = deferred.refs[j];
        }
// #else
        let best = world_first(ray, shadows);
        let trees = 0u;
// #endif
// #if SHADOWS
        if (shadows) {
            if (best.c.t >= OPEN && trees == 0u) {
                radiance += value;
            }
            continue;
        }
// #endif
// #if CSG_QUEUE
        if (trees > 0u) {
            store_hit(slot, best);
            wf_push(Q_CSG, slot);
            return;
        }
// #endif
        classify(slot, best);
    }
// #if SHADOWS
    if (shadows) {
        paths[ri] = vec4<f32>(radiance, 0.0);
// #if CSG_QUEUE
        if (pending) {
            wf_push(Q_SHADOW_CSG, slot);
        }
// #endif
        flush_rays_traced();
    }
// #endif
}
