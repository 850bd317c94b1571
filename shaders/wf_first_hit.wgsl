// #requires wf_path camera integrators wf_counting paths_set
// The first-hit integrators (OnOff, Flat, PointLight) in one stage: their work per camera
// sample is one closest-hit query and a few shadow rays, too little to gain from queues.
// One invocation per camera sample writes its estimate to the path's radiance.

@compute @workgroup_size(WF_WORKGROUP)
fn first_hit_stage(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_id) local: vec3<u32>) {
    let lane = local.x; // not local_invocation_index (wf_path.wgsl)
    let slot = wf_direct_slot(group.x, lane);
    if (slot == WF_NONE) {
        return;
    }
// #if CSG
    csg_use_slot(slot);
// #endif
    let id = path_id(slot);
    let ray = pixel_ray(id.pixel, id.j);
// #if ONOFF
    let value = radiance_onoff(ray);
// #endif
// #if FLAT
    let value = radiance_flat(ray);
// #endif
// #if POINTLIGHT
    let value = radiance_point_light(ray);
// #endif
    paths_set(field(F_RADIANCE, slot), vec4<f32>(value, 0.0));
    flush_rays_traced(slot);
}
