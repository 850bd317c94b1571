// #requires pass camera integrators
// #if PATHTRACER
// #requires path_tracer
// #endif
// The render kernel: one invocation per pixel of the pass's tile sums the estimates of
// camera samples [sample_begin, sample_end) (the pass contract of shaders/pass.wgsl).

// Whether any channel is NaN or infinite (by bits: immune to fast-math folding).
fn non_finite(v: vec3<f32>) -> bool {
    let e = bitcast<vec3<u32>>(v) & vec3<u32>(0x7F800000u);
    return any(e == vec3<u32>(0x7F800000u));
}

// The estimate of camera sample j of pixel (col, row).
fn sample_estimate(col: u32, row: u32, pixel: u32, j: u32) -> vec3<f32> {
    let ray = pixel_ray(col, row, j);
// #if ONOFF
    return radiance_onoff(ray);
// #endif
// #if FLAT
    return radiance_flat(ray);
// #endif
// #if POINTLIGHT
    return radiance_point_light(ray);
// #endif
// #if PATHTRACER
    // The mean of n independent paths (sample index j·n + i of the stream rule).
    let n = settings.paths_per_sample;
    var sum = vec3<f32>(0.0);
    for (var i = 0u; i < n; i++) {
        var value = radiance_path(ray, pixel, j * n + i);
        if (non_finite(value)) {
            atomicAdd(&nan_count, 1u);
            value = vec3<f32>(0.0);
        }
        sum += value;
    }
    return sum / f32(n);
// #endif
}

@compute @workgroup_size(8, 8)
fn render(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pass_in_tile(gid)) {
        return;
    }
    let px = pass_pixel(gid);
    let pixel = pass_pixel_index(gid);
    var sum = vec3<f32>(0.0);
    for (var j = pass_params.sample_begin; j < pass_params.sample_end; j++) {
        var value = sample_estimate(px.x, px.y, pixel, j);
        if (non_finite(value)) {
            atomicAdd(&nan_count, 1u);
            value = vec3<f32>(0.0);
        }
        sum += value;
    }
    pass_write(gid, sum);
}
