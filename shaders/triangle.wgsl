// #requires bindings ray
// The watertight ray–triangle test of Woop, Benthin and Wald 2013 in f32 (mirrors
// accel::triangle): the ray is sheared to run along +z from the origin, and each edge is
// decided by the sign of a 2D edge function of the transformed vertices, which neighbours
// sharing the edge compute identically, so no ray passes between them.

// The ray sheared so that it runs along +z from the origin: axes kx, ky, kz (kz the largest
// |d|), shear (sx, sy, sz).
struct Sheared {
    origin: vec3<f32>,
    k: vec3<u32>,
    s: vec3<f32>,
}

fn sheared_ray(o: vec3<f32>, d: vec3<f32>) -> Sheared {
    let a = abs(d);
    var kz = 2u;
    if (a.x >= a.y && a.x >= a.z) {
        kz = 0u;
    } else if (a.y >= a.z) {
        kz = 1u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    if (d[kz] < 0.0) {
        let t = kx;
        kx = ky;
        ky = t;
    }
    return Sheared(o, vec3<u32>(kx, ky, kz), vec3<f32>(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]));
}

// a·b − c·d with Kahan's fma correction: exact in sign where the plain difference rounds to 0.
fn difference_of_products(a: f32, b: f32, c: f32, d: f32) -> f32 {
    let cd = c * d;
    let err = fma(-c, d, cd);
    return fma(a, b, -cd) + err;
}

// (t, b0, b1, b2) of the ray's crossing of triangle `tri` with t in (tmin, tmax), or t = OPEN.
// Both windings are hit; edges and vertices count as inside (no gaps between neighbours).
fn triangle_crossing(r: Sheared, tri: u32, tmin: f32, tmax: f32) -> vec4<f32> {
    let none = vec4<f32>(OPEN, 0.0, 0.0, 0.0);
    let base = MESH_POSITION_VEC4S * tri;
    let a = tri_position_at(base).xyz - r.origin;
    let b = tri_position_at(base + 1u).xyz - r.origin;
    let c = tri_position_at(base + 2u).xyz - r.origin;
    let k = r.k;
    let ax = a[k.x] - r.s.x * a[k.z];
    let ay = a[k.y] - r.s.y * a[k.z];
    let bx = b[k.x] - r.s.x * b[k.z];
    let by = b[k.y] - r.s.y * b[k.z];
    let cx = c[k.x] - r.s.x * c[k.z];
    let cy = c[k.y] - r.s.y * c[k.z];
    var u = cx * by - cy * bx;
    var v = ax * cy - ay * cx;
    var w = bx * ay - by * ax;
    if (u == 0.0 || v == 0.0 || w == 0.0) {
        u = difference_of_products(cx, by, cy, bx);
        v = difference_of_products(ax, cy, ay, cx);
        w = difference_of_products(bx, ay, by, ax);
    }
    let nonneg = u >= 0.0 && v >= 0.0 && w >= 0.0;
    let nonpos = u <= 0.0 && v <= 0.0 && w <= 0.0;
    let det = u + v + w;
    if (!(nonneg || nonpos) || det == 0.0) {
        return none;
    }
    // As accel::triangle: one reciprocal of the determinant scales t and the weights.
    let inv_det = 1.0 / det;
    let t = (u * r.s.z * a[k.z] + v * r.s.z * b[k.z] + w * r.s.z * c[k.z]) * inv_det;
    if (!(t > tmin && t < tmax)) {
        return none;
    }
    return vec4<f32>(t, u * inv_det, v * inv_det, w * inv_det);
}
