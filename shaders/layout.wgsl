// #requires tags
// The packed scene, mirrored byte for byte from src/gpu/layout.rs (a unit test parses
// this file with naga and compares every struct's size and member offsets with Rust's).
// Positions are relative to the camera (see DESIGN.md "GPU renderer").

// Object-to-world or world-to-object affine map: three rows of a 3×4 matrix, the last
// column being the translation.
struct Affine {
    r0: vec4<f32>,
    r1: vec4<f32>,
    r2: vec4<f32>,
}

// One unit primitive placed in the world (top-level or a CSG leaf).
struct Shape {
    to_object: Affine,
    to_world: Affine,
    kind: u32,
    material: u32,
    // Index into area_lights, or NONE.
    light: u32,
    // Mesh instances: the root of the bottom-level BVH in bvh_nodes and flags (MESH_*).
    mesh: u32,
}

// An object reference (a u32 in `indices`: BVH leaves, the plane list) is a shape index,
// or a CSG tree index with CSG_NODE_BIT set.
// A CSG tree: its program (layout::csg_instr) at indices[program..], `length` instructions,
// and its leaves, shapes first_leaf .. first_leaf + leaf_count.
struct CsgTree {
    min: vec3<f32>,
    program: u32,
    max: vec3<f32>,
    length: u32,
    first_leaf: u32,
    leaf_count: u32,
    // Its sweep table in `indices` (layout::csg_sweep) and the table's nodes; 0 nodes: none.
    sweep: u32,
    node_count: u32,
}

// The microfacet kinds' α, energy rows (offset in `floats`), conductor index and
// compensation constants: src/gpu/layout.rs.
struct Material {
    brdf: u32,
    pigment: u32,
    emitted: u32,
    ior: f32,
    alpha: f32,
    rows: u32,
    _pad0: u32,
    _pad1: u32,
    eta: vec4<f32>,
    k: vec4<f32>,
    lobe: vec4<f32>,
    lobe_back: vec4<f32>,
}

// Uniform: a = colour. Checkered: a = on, b = off, n. Image: texels at tex_offset
// (rgb triples, row 0 at the top) of tex_width × tex_height, image_filter.
struct Pigment {
    a: vec4<f32>,
    b: vec4<f32>,
    kind: u32,
    n: u32,
    image_filter: u32,
    tex_offset: u32,
    tex_width: u32,
    tex_height: u32,
    _pad0: u32,
    _pad1: u32,
}

// An area light (an emissive top-level sphere or cube, cpu::area_light): its shape, the
// |determinant| of its linear part, and for spheres placed by a similarity the world centre
// and radius (radius 0: sampled by area instead of by cone).
struct AreaLight {
    sphere: vec4<f32>,
    shape: u32,
    det: f32,
    area: f32,
    // Meshes: the offset in `floats` of the triangle CDF (then each triangle's index in
    // tri_positions, as bits).
    mesh_cdf: u32,
    // Cubes: the world area of one face of each pair (x, y, z).
    face_areas: vec3<f32>,
    // Meshes: the triangle count (0: not a mesh).
    mesh_triangles: u32,
    // Cubes: bit `axis` set where that pair's faces are rectangles (NEE may sample them by
    // solid angle).
    rectangular_faces: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// position.w = linear_radius.
struct PointLight {
    position: vec4<f32>,
    color: vec4<f32>,
}

// What escaping rays see; without a scene environment, Uniform with the background colour.
// Uniform: a. Gradient: a = zenith, b = horizon, c = nadir. Image: texels at tex_offset
// (in floats), importance-sampling arrays at dist_offset in floats.
struct Environment {
    a: vec4<f32>,
    b: vec4<f32>,
    c: vec4<f32>,
    kind: u32,
    tex_width: u32,
    tex_height: u32,
    tex_offset: u32,
    intensity: f32,
    rotation_rad: f32,
    dist_offset: u32,
    // 1 when next-event estimation samples the environment (it is not black).
    is_light: u32,
}

struct Camera {
    to_world: Affine,
    projection: u32,
    aspect_ratio: f32,
    screen_distance: f32,
    _pad: u32,
}

struct Settings {
    color0: vec4<f32>,
    color1: vec4<f32>,
    // state.lo, state.hi, inc.lo, inc.hi of the tracer's and the path tracer's seeds.
    tracer_seed: vec4<u32>,
    width: u32,
    height: u32,
    renderer: u32,
    samples_per_side: u32,
    jitter: u32,
    paths_per_sample: u32,
    max_depth: u32,
    roulette_depth: u32,
    nee: u32,
    // Camera samples per pixel of the whole render.
    spp: u32,
    // Ranges of `indices` (BVH leaf objects start at 0).
    plane_offset: u32,
    plane_count: u32,
    // log2 of the strata per dimension of a path vertex (sampling::strata_bits).
    strata_bits: u32,
    area_light_count: u32,
    point_light_count: u32,
    bvh_node_count: u32,
    // sampling::seed_word of the tracer's seed, for the strata's permutation keys.
    strata_seed: u32,
    _pad1: u32,
    _pad2: u32,
    _pad3: u32,
}

// accel::quantized's node (inner nodes only): each child's bounds are corner + q * 2^e,
// with the exponents (biased by 127) in the low three bytes of `scales` and, per axis, the
// grid coordinates q in `grid`'s bytes (left min, left max, right min, right max). An inner
// left child is the next node, an inner right child node `link`; a leaf child (BVH_*_LEAF,
// its count at BVH_*_COUNT_SHIFT) starts at `link`, the right one after a left leaf's
// primitives (accel::QuantizedNode::child).
struct QuantizedNode {
    corner: vec3<f32>,
    scales: u32,
    grid: vec3<u32>,
    link: u32,
}
