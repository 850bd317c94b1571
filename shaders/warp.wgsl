// Cosine-weighted hemisphere about +z: cpu::warp::cosine_hemisphere and its density.
fn cosine_hemisphere(xi0: f32, xi1: f32) -> vec3<f32> {
    let r = sqrt(xi0);
    let phi = TAU * xi1;
    return vec3<f32>(r * cos(phi), r * sin(phi), sqrt(max(1.0 - xi0, 0.0)));
}

fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    return max(cos_theta, 0.0) * INV_PI;
}
