// Orthonormal basis about a unit vector (Duff et al. 2017): mirrors cpu::onb.

struct Onb {
    t: vec3<f32>,
    b: vec3<f32>,
}

fn onb(n: vec3<f32>) -> Onb {
    let sign = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    return Onb(vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), vec3<f32>(b, sign + n.y * n.y * a, -n.y));
}
