// #requires wf_path
// Film stage: one invocation per pixel of the batch sums its paths' radiance in a fixed
// order (camera sample j, then path i), whatever order the queues ran them in, so images
// are bitwise reproducible: the pixel's value is the sum over its camera samples of the
// mean of their n paths. NaN/∞ estimates are counted and add 0 (DESIGN.md "Pixel estimate").

// Whether any channel is NaN or infinite (by bits: immune to fast-math folding).
fn non_finite(v: vec3<f32>) -> bool {
    let e = bitcast<vec3<u32>>(v) & vec3<u32>(0x7F800000u);
    return any(e == vec3<u32>(0x7F800000u));
}

@compute @workgroup_size(64)
fn film_stage(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = wf_index(gid, nwg);
    if (p >= batch.pixel_count) {
        return;
    }
    let n = batch.paths_per_sample;
    let first = p * batch.samples * n;
    var sum = vec3<f32>(0.0);
    var bad = 0u;
    for (var j = 0u; j < batch.samples; j++) {
        var sample_sum = vec3<f32>(0.0);
        for (var i = 0u; i < n; i++) {
            var value = paths[field(F_RADIANCE, first + j * n + i)].xyz;
            if (non_finite(value)) {
                bad++;
                value = vec3<f32>(0.0);
            }
            sample_sum += value;
        }
        var mean = sample_sum / f32(n);
        if (non_finite(mean)) {
            bad++;
            mean = vec3<f32>(0.0);
        }
        sum += mean;
    }
    if (bad > 0u) {
        atomicAdd(&control[CTRL_NAN], bad);
    }
    film[p] = vec4<f32>(sum, 0.0);
}
