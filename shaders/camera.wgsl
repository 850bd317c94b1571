// #requires bindings random ray
// Camera rays: mirrors scene::Camera::ray and cpu::pixel_samples (DESIGN.md "Random
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

// Position (u_px, v_px) of camera sample j in pixel `pixel`, from its top-left corner:
// PixelSamples::position.
fn pixel_sample_position(pixel: u32, j: u32) -> vec2<f32> {
    if (settings.jitter == JITTER_CENTRE) {
        return vec2<f32>(0.5, 0.5);
    }
    var rng = stream(settings.tracer_seed.xy, settings.tracer_seed.zw, pixel, j, CAMERA_BOUNCE);
    let xi0 = pcg_next_f32(&rng);
    let xi1 = pcg_next_f32(&rng);
    if (settings.jitter == JITTER_STRATIFIED) {
        let s = settings.samples_per_side;
        return vec2<f32>((f32(j % s) + xi0) / f32(s), (f32(j / s) + xi1) / f32(s));
    }
    return vec2<f32>(xi0, xi1);
}

// The camera ray of sample j of pixel (col, row).
fn pixel_ray(col: u32, row: u32, j: u32) -> Ray {
    let pixel = row * settings.width + col;
    let px = pixel_sample_position(pixel, j);
    let u = (f32(col) + px.x) / f32(settings.width);
    let v = 1.0 - (f32(row) + px.y) / f32(settings.height);
    return camera_ray(u, v);
}
