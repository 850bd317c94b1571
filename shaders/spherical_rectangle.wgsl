// #requires angles
// A rectangle drawn uniformly in the solid angle it subtends from a point (Ureña, Fajardo
// and King 2013): cpu::spherical_rectangle in the same steps, which says why and how.
// The solid angle is a sum of four corner terms, each an atan2 of two products, so
// atan2_precise keeps it to f32 precision (lavapipe's own atan2 is off by ~1e-4).

struct SphericalRectangle {
    x0: f32,
    x1: f32,
    y0: f32,
    y1: f32,
    // The rectangle's height in the frame at the shading point (negative).
    z0: f32,
    // z of the unit normals of the planes through the point and the edges along x.
    b0: f32,
    b1: f32,
    // Where the angle φ that u sweeps over the solid angle starts.
    phi0: f32,
    solid_angle: f32,
}

// A corner's term of the solid angle, atan2(x·y, |z0|·r) (r: the corner's distance).
fn corner_term(x: f32, y: f32, z: f32) -> f32 {
    return atan2_precise(x * y, z * sqrt(x * x + y * y + z * z));
}

// SphericalRectangle::new: the rectangle corner + s·ea + t·eb (s, t in [0, 1], ea ⟂ eb)
// seen from o.
fn spherical_rectangle(o: vec3<f32>, corner: vec3<f32>, ea: vec3<f32>, eb: vec3<f32>) -> SphericalRectangle {
    let la = length(ea);
    let lb = length(eb);
    let ex = ea / la;
    let ey = eb / lb;
    let d = corner - o;
    let x0 = dot(d, ex);
    let y0 = dot(d, ey);
    let z = abs(dot(d, cross(ex, ey)));
    let x1 = x0 + la;
    let y1 = y0 + lb;
    let f00 = corner_term(x0, y0, z);
    let f01 = corner_term(x0, y1, z);
    let f10 = corner_term(x1, y0, z);
    let f11 = corner_term(x1, y1, z);
    let z0 = -z;
    return SphericalRectangle(
        x0,
        x1,
        y0,
        y1,
        z0,
        -y0 / sqrt(z0 * z0 + y0 * y0),
        y1 / sqrt(z0 * z0 + y1 * y1),
        f01 - f00,
        (f11 - f10) - (f01 - f00),
    );
}

// spherical_rectangle::may_subtend: whether the rectangle may subtend omega or more from
// o (Ω ≤ A/z², tested as A³ ≥ ω·(d·(ea × eb))²), before any corner term.
fn may_subtend(o: vec3<f32>, corner: vec3<f32>, ea: vec3<f32>, eb: vec3<f32>, omega: f32) -> bool {
    let c = cross(ea, eb);
    let a2 = dot(c, c);
    let za = dot(corner - o, c);
    return a2 * sqrt(a2) >= omega * za * za;
}

// #if SHADOWS
// SphericalRectangle::sample: the fractions (s, t) along ea and eb of the point that (u, v)
// maps to, uniform in solid angle.
fn spherical_rectangle_sample(r: SphericalRectangle, u: f32, v: f32) -> vec2<f32> {
    let phi = u * r.solid_angle + r.phi0;
    let fu = (cos(phi) * r.b0 + r.b1) / sin(phi);
    let cu = clamp(select(1.0, -1.0, fu < 0.0) / sqrt(fu * fu + r.b0 * r.b0), -0.99999994, 0.99999994);
    let xu = clamp(-(cu * r.z0) / sqrt(1.0 - cu * cu), r.x0, r.x1);
    let dd = sqrt(xu * xu + r.z0 * r.z0);
    let h0 = r.y0 / sqrt(dd * dd + r.y0 * r.y0);
    let h1 = r.y1 / sqrt(dd * dd + r.y1 * r.y1);
    let hv = h0 + v * (h1 - h0);
    let hv2 = hv * hv;
    var yv = r.y1;
    if (hv2 < 1.0 - 1e-6) {
        yv = hv * dd / sqrt(1.0 - hv2);
    }
    let s = clamp((xu - r.x0) / (r.x1 - r.x0), 0.0, 1.0);
    let t = clamp((yv - r.y0) / (r.y1 - r.y0), 0.0, 1.0);
    return vec2<f32>(s, t);
}
// #endif
