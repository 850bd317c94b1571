// #requires wf_path camera
// Camera stage of the path tracer: one invocation per path slot of the batch writes its
// camera ray and the start of its path state (throughput 1, the camera as a delta
// "previous vertex"; the host has cleared the radiance), and queues it for the closest-hit
// stage of bounce 0.

@compute @workgroup_size(64)
fn camera_stage(@builtin(global_invocation_id) gid: vec3<u32>) {
    let slot = wf_index(gid);
    if (slot >= batch.path_count) {
        return;
    }
    let id = path_id(slot);
    let col = id.pixel % settings.width;
    let row = id.pixel / settings.width;
    store_ray(slot, pixel_ray(col, row, id.j));
    // The camera is a delta vertex (a negative density), whose point and object nothing reads.
    paths[field(F_BETA, slot)] = vec4<f32>(1.0, 1.0, 1.0, -1.0);
    queues[Q_RAY * batch.capacity + slot] = slot;
}
