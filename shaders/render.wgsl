// #requires pass camera integrators
// #if PATHTRACER
// #requires path_tracer
// #endif
// #if LOOP_LIMITER
// #requires resume
// #endif
// #if COUNT_RAYS
// #requires ray_count
// #endif
// The render kernel: one invocation per pixel of the pass's tile sums the estimates of
// camera samples [sample_begin, sample_end) (the pass contract of shaders/pass.wgsl). With
// LOOP_LIMITER the pass is resumable and path-granular (shaders/resume.wgsl); the sums and
// their order are the same either way.

// Whether any channel is NaN or infinite (by bits: immune to fast-math folding).
fn non_finite(v: vec3<f32>) -> bool {
    let e = bitcast<vec3<u32>>(v) & vec3<u32>(0x7F800000u);
    return any(e == vec3<u32>(0x7F800000u));
}

// #if !LOOP_LIMITER
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
// #if COUNT_RAYS
    flush_ray_count();
// #endif
    pass_write(gid, sum);
}
// #endif

// #if LOOP_LIMITER
// Paths per camera sample (a renderer other than the path tracer has one "path": the sample).
fn paths_per_sample() -> u32 {
// #if PATHTRACER
    return settings.paths_per_sample;
// #else
    return 1u;
// #endif
}

// Path i of camera sample j of pixel (col, row), before the NaN check.
fn path_estimate(col: u32, row: u32, pixel: u32, j: u32, i: u32) -> vec3<f32> {
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
    return radiance_path(ray, pixel, j * settings.paths_per_sample + i);
// #endif
}

@compute @workgroup_size(8, 8)
fn render(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pass_in_tile(gid)) {
        return;
    }
    let k = pass_index(gid);
    let solo = pass_params.solo_pixel != RESUME_NO_SOLO;
    if (solo && k != pass_params.solo_pixel) {
        return;
    }
    let state = pass_state[k];
    if ((state.w & RESUME_DONE) != 0u) {
        return;
    }
    let px = pass_pixel(gid);
    let pixel = pass_pixel_index(gid);
    let n = paths_per_sample();
    let total = (pass_params.sample_end - pass_params.sample_begin) * n;
    var done = state.w & RESUME_PROGRESS;
    var flags = 0u;
    var pass_sum = vec3<f32>(0.0);
    var sample_sum = vec3<f32>(0.0);
    if (done != 0u) {
        pass_sum = pass_out[k].xyz;
        sample_sum = bitcast<vec3<f32>>(state.xyz);
    }
    var ran = 0u;
    loop {
        if (done >= total || (solo && ran == 1u) || (pass_params.path_budget != 0u && ran >= pass_params.path_budget)) {
            break;
        }
        let j = pass_params.sample_begin + done / n;
        let i = done % n;
// #if COUNT_RAYS
        let rays_before = rays_traced;
// #endif
        var value = path_estimate(px.x, px.y, pixel, j, i);
        if (loop_limiter_fired()) {
            // The limiter ended some loop of this path: its value is unreliable.
            if (ran != 0u || !solo) {
// #if COUNT_RAYS
                rays_traced = rays_before; // the path runs again: count its rays then
// #endif
            }
            if (ran != 0u) {
                break; // the next dispatch starts with it, on a fresh limiter
            }
            if (!solo) {
                flags |= RESUME_NEEDS_SOLO; // cut with a fresh limiter: the host runs it alone
                break;
            }
            flags |= RESUME_LIMITED; // alone and still cut: dropped (as 0) and counted
            value = vec3<f32>(0.0);
        }
        ran += 1u;
        done += 1u;
// #if PATHTRACER
        if (non_finite(value)) {
            atomicAdd(&nan_count, 1u);
            value = vec3<f32>(0.0);
        }
// #endif
        sample_sum += value;
        if (i + 1u == n) {
            var mean = sample_sum / f32(n);
            if (non_finite(mean)) {
                atomicAdd(&nan_count, 1u);
                mean = vec3<f32>(0.0);
            }
            pass_sum += mean;
            sample_sum = vec3<f32>(0.0);
        }
    }
    if (done >= total) {
        flags |= RESUME_DONE;
    }
    pass_state[k] = vec4<u32>(bitcast<vec3<u32>>(sample_sum), done | flags);
// #if COUNT_RAYS
    flush_ray_count();
// #endif
    pass_write(gid, pass_sum);
}
// #endif
