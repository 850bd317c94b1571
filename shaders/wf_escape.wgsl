// #requires wf_path mis environment
// Escape stage: rays of this bounce that hit nothing add the environment's radiance,
// MIS-weighted against NEE (cpu::path_tracer), and their paths end.

@compute @workgroup_size(64)
fn escape_stage(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let slot = wf_slot(Q_ESCAPE, wf_index(gid, nwg));
    if (slot == WF_NONE) {
        return;
    }
    let ray = load_ray(slot);
    let beta = paths[field(F_BETA, slot)];
    let e = beta.xyz * pt_escaped(load_previous(slot, beta), normalize(ray.dir));
    // A black sky adds nothing: skip the read-modify-write (as in wf_shade.wgsl).
    if (any(e != vec3<f32>(0.0))) {
        let i = field(F_RADIANCE, slot);
        paths[i] = vec4<f32>(paths[i].xyz + e, 0.0);
    }
}
