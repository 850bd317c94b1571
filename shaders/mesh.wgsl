// #requires bindings ray
// #if TRAVERSE
// #requires triangle
// #endif
// #if SHADING
// #requires triangle
// #endif
// Triangle mesh instances (mirrors cpu::mesh and accel::triangle in f32): the ray moves into
// object space (t is unchanged: the direction is not normalised), descends the instance's
// bottom-level BVH (its root in bvh_nodes at shapes[i].mesh & MESH_NODE_MASK, leaves
// indexing tri_positions directly) and meets triangles with the watertight test of Woop,
// Benthin and Wald 2013. A hit records the triangle in the crossing's face; the shading
// stages recompute its barycentrics with the same test.

// #if TRAVERSE
// The first crossing of mesh instance `i` with t in (tmin, tmax): t = OPEN when none, the
// face the triangle.
fn mesh_first_crossing(i: u32, ray: Ray) -> Crossing {
    let s = shape_at(i);
    let o = affine_point(s.to_object, ray.origin);
    let d = affine_vector(s.to_object, ray.dir);
    let r = sheared_ray(o, d);
    let inv_dir = safe_inverse(d);
    let root = s.mesh & MESH_NODE_MASK;
    var best = Crossing(OPEN, 0u);
    var tmax = ray.tmax;
    // The second stack region: this walk runs inside a leaf of the scene's walk.
    var walk = bvh_walk(root, BVH_STACK_SIZE);
    var more = true;
    while (more) {
        if (bvh_descend(&walk, o, inv_dir, ray.tmin, tmax)) {
            let first = leaf_first(walk);
            for (var k = 0u; k < leaf_count(walk); k++) {
                let tri = first + k;
                let h = triangle_crossing(r, tri, ray.tmin, tmax);
                if (h.x < tmax) {
                    tmax = h.x;
                    best = Crossing(h.x, tri);
                }
            }
        }
        more = bvh_pop(&walk, tmax);
    }
    return best;
}
// #endif

// #if SHADING
// The hit on triangle c.face of mesh instance `i`: point from the barycentrics, the facet's
// normal (sidedness and offsets; the winding's normal is the outside), the shading normal
// (vertex normals interpolated when MESH_SMOOTH, turned to the facet's side) and uv (the
// file's when MESH_UVS, else the barycentric (b1, b2)).
fn mesh_surface_hit(s: Shape, ray: Ray, c: Crossing, object: u32) -> Hit {
    let o = affine_point(s.to_object, ray.origin);
    let d = affine_vector(s.to_object, ray.dir);
    let tri = c.face;
    // The same test the traversal ran, on the one triangle: the same t and weights.
    let h = triangle_crossing(sheared_ray(o, d), tri, -OPEN, OPEN);
    let b = h.yzw;
    let base = MESH_POSITION_VEC4S * tri;
    let p0 = tri_position_at(base).xyz;
    let p1 = tri_position_at(base + 1u).xyz;
    let p2 = tri_position_at(base + 2u).xyz;
    let p_obj = b.x * p0 + b.y * p1 + b.z * p2;
    let point = affine_point(s.to_world, p_obj);
    let scale = affine_error_scale(s.to_world, max(max(abs(p0), abs(p1)), abs(p2)));
    let outward = normalize_or(affine_normal(s.to_object, cross(p1 - p0, p2 - p0)), vec3<f32>(0.0, 0.0, 1.0));
    let front_face = dot(outward, ray.dir) < 0.0;
    let geometric = select(-outward, outward, front_face);
    var normal = geometric;
    let sh = MESH_SHADING_VEC4S * tri;
    if ((s.mesh & MESH_SMOOTH) != 0u) {
        let n = b.x * tri_shading_at(sh).xyz + b.y * tri_shading_at(sh + 1u).xyz + b.z * tri_shading_at(sh + 2u).xyz;
        let ns = normalize_or(affine_normal(s.to_object, n), vec3<f32>(0.0));
        if (any(ns != vec3<f32>(0.0))) {
            normal = select(ns, -ns, dot(ns, geometric) < 0.0);
        }
    }
    var uv = vec2<f32>(b.y, b.z);
    if ((s.mesh & MESH_UVS) != 0u) {
        let uv01 = tri_shading_at(sh + 3u);
        let uv2 = tri_shading_at(sh + 4u).xy;
        uv = b.x * uv01.xy + b.y * uv01.zw + b.z * uv2;
    }
    return Hit(c.t, point, scale, normal, geometric, front_face, uv, s.material, object);
}
// #endif
