// #requires wf_path world wf_counting
// Shadow stage: for every path that queued shadow rays this bounce, trace them in order
// (any-hit) and add the contribution of each one nothing blocks. One invocation per path,
// so a path's radiance is only ever written by one invocation, in a fixed order.

@compute @workgroup_size(64)
fn shadow_stage(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let slot = wf_slot(Q_SHADOW, wf_index(gid, nwg));
    if (slot == WF_NONE) {
        return;
    }
// #if CSG
    csg_use_slot(slot);
// #endif
    let ri = field(F_RADIANCE, slot);
    var radiance = paths[ri].xyz;
    for (var k = 0u; k < batch.shadow_rays; k++) {
        let i = 3u * (slot * batch.shadow_rays + k);
        let value = shadow[i + 2u];
        if (value.w == 0.0) {
            break;
        }
        let o = shadow[i];
        let d = shadow[i + 1u];
        if (!occluded(Ray(o.xyz, d.xyz, o.w, d.w))) {
            radiance += value.xyz;
        }
    }
    paths[ri] = vec4<f32>(radiance, 0.0);
    flush_rays_traced();
}
