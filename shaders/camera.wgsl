// #requires bindings random permute ray divide
// Camera rays: mirrors scene::Camera::ray and prepare::pixel_samples (DESIGN.md "Random
// numbers"). camera.to_world places the camera relative to its own position.

// The ray through screen coordinates (u, v) ∈ [0, 1]²; it starts at t = 1 (the screen).
fn camera_ray(u: f32, v: f32) -> Ray {
    var o: vec3<f32>;
    var d: vec3<f32>;
    if (camera.projection == PROJECTION_PERSPECTIVE) {
        let sd = camera.screen_distance;
        o = vec3<f32>(-sd, 0.0, 0.0);
        d = vec3<f32>(sd, (1.0 - 2.0 * u) * camera.aspect_ratio, 2.0 * v - 1.0);
    } else {
        o = vec3<f32>(-1.0, (1.0 - 2.0 * u) * camera.aspect_ratio, 2.0 * v - 1.0);
        d = vec3<f32>(1.0, 0.0, 0.0);
    }
    return Ray(affine_point(camera.to_world, o), affine_vector(camera.to_world, d), 1.0, OPEN);
}

// prepare::camera_strata_key: the key of pixel `pixel`'s sub-column permutation (its
// sub-row permutation's is this hashed once more).
fn camera_strata_key(seed_word: u32, pixel: u32) -> u32 {
    return hash32(hash32(pixel ^ seed_word) ^ CAMERA_STRATA_SALT);
}

// Position (u_px, v_px) of camera sample j in pixel `pixel`, from its top-left corner:
// PixelSamples::position (multi-jittered s × s strata).
fn pixel_sample_position(pixel: u32, j: u32) -> vec2<f32> {
    if (settings.jitter == JITTER_CENTRE) {
        return vec2<f32>(0.5, 0.5);
    }
    var rng = stream(settings.tracer_seed.xy, settings.tracer_seed.zw, pixel, j, CAMERA_BOUNCE);
    let xi0 = pcg_next_f32(&rng);
    let xi1 = pcg_next_f32(&rng);
    if (settings.jitter == JITTER_STRATIFIED) {
        // Multi-jittered: cell (c, r), sub-column π_x(r), sub-row π_y(c).
        let s = settings.samples_per_side;
        let r = div_u32(j, s);
        let c = j - r * s;
        let key = camera_strata_key(settings.strata_seed, pixel);
        let sub_col = permute_below(r, s, key);
        let sub_row = permute_below(c, s, hash32(key));
        let n = f32(s) * f32(s);
        return vec2<f32>((f32(c * s + sub_col) + xi0) / n, (f32(r * s + sub_row) + xi1) / n);
    }
    return vec2<f32>(xi0, xi1);
}

// The camera ray of sample j of pixel `pixel` (row-major).
fn pixel_ray(pixel: u32, j: u32) -> Ray {
    let row = div_u32(pixel, settings.width);
    let col = pixel - row * settings.width;
    let px = pixel_sample_position(pixel, j);
    let u = (f32(col) + px.x) / f32(settings.width);
    let v = 1.0 - (f32(row) + px.y) / f32(settings.height);
    return camera_ray(u, v);
}
