// #requires wf_path finite paths_get film_set
// Film stage: one invocation per pixel of the batch sums its paths' radiance in a fixed
// order (camera sample j, then path i), whatever order the queues ran them in, so images
// are bitwise reproducible: the pixel's value is the sum over its camera samples of the
// mean of their n paths. NaN/∞ estimates are counted and add 0 (DESIGN.md "Pixel estimate").
// The sum over camera samples is compensated (Knuth's TwoSum: `film[2p]` the rounded sum,
// `film[2p + 1]` its exact rounding error, added in f64 on the host), so a pixel's sum is
// the exact sum of its sample means to about 2⁻⁴⁸ whatever the round sizes: renders of
// sample ranges (shards) then merge into the one-render image to the last f32 bit.

// `x` as the compiler cannot know it: TwoSum's error term is (s + x) − s − x in exact terms,
// which reassociation (allowed for WGSL floats, done by lavapipe) folds to 0; XOR with the
// run-time zero `batch.zero` keeps each step as written.
fn unfolded(x: vec3<f32>) -> vec3<f32> {
    return bitcast<vec3<f32>>(bitcast<vec3<u32>>(x) ^ vec3<u32>(batch.zero));
}

@compute @workgroup_size(WF_WORKGROUP)
fn film_stage(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if (p >= batch.pixel_count) {
        return;
    }
    let n = batch.paths_per_sample;
    let first = p * batch.samples * n;
    var sum = vec3<f32>(0.0);
    var err = vec3<f32>(0.0);
    var bad = 0u;
    for (var j = 0u; j < batch.samples; j++) {
        var sample_sum = vec3<f32>(0.0);
        for (var i = 0u; i < n; i++) {
            var value = paths_get(field(F_RADIANCE, first + j * n + i)).xyz;
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
        let t = unfolded(sum + mean);
        let back = unfolded(t - sum);
        err += (sum - unfolded(t - back)) + (mean - back);
        sum = t;
    }
    if (bad > 0u) {
        atomicAdd(&control[CTRL_NAN], bad);
    }
    film_set(2u * p, vec4<f32>(sum, 0.0));
    film_set(2u * p + 1u, vec4<f32>(err, 0.0));
}
