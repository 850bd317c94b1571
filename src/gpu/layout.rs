//! The packed scene: `#[repr(C)]` Pod structs uploaded as-is, each mirrored byte for byte
//! by a struct of `shaders/layout.wgsl`.
//!
//! Only `u32`, `f32` and 16-byte-aligned `vec4` members are used, so the Rust and WGSL
//! layouts agree without hidden padding; the unit test below parses the WGSL with naga
//! and checks every struct's size and member offsets against Rust's, so they cannot drift.
//! All positions are relative to the camera (see `pack`), which keeps f32 precise for
//! scenes far from the origin.

use bytemuck::{Pod, Zeroable};
use glam::DMat4;

/// WGSL source of the packed structs.
pub const LAYOUT_WGSL: &str = include_str!("../../shaders/layout.wgsl");

/// "No index" marker (for example, a shape that is not an area light).
pub const NONE: u32 = u32::MAX;
/// Set in an object reference (BVH leaf, plane list) when it names a CSG tree (its index
/// in `csg_trees`) rather than a shape.
pub const CSG_NODE_BIT: u32 = 0x8000_0000;

/// `Shape::kind` values (the order of `ShapeKind::ALL`).
pub mod shape_kind {
    /// The unit sphere: radius 1 at the origin.
    pub const SPHERE: u32 = 0;
    /// The plane z = 0 with normal +z (the half-space z ≤ 0 inside CSG).
    pub const PLANE: u32 = 1;
    /// The unit cube [−0.5, 0.5]³.
    pub const CUBE: u32 = 2;
    /// The capped cylinder of axis z, radius 0.5, z ∈ [−0.5, 0.5].
    pub const CYLINDER: u32 = 3;
    /// A triangle mesh instance: `Shape::mesh` says where its bottom-level BVH starts.
    pub const MESH: u32 = 4;
}
/// `Shape::mesh` of a mesh instance: the index of its bottom-level BVH's root in
/// `bvh_nodes` (low bits) and two flags.
pub mod mesh_bits {
    /// Shading interpolates the file's vertex normals.
    pub const SMOOTH: u32 = 0x8000_0000;
    /// The file has uvs (else uv = the barycentric (b1, b2)).
    pub const UVS: u32 = 0x4000_0000;
    /// The root node index.
    pub const NODE_MASK: u32 = 0x3FFF_FFFF;
}
/// Per triangle, in `tri_positions`: three vec4 (the vertices, object space); in
/// `tri_shading`: five vec4 (three vertex normals, then uv0 uv1 and uv2).
pub const TRI_POSITION_VEC4S: u32 = 3;
/// Per triangle, the vec4 in `tri_shading`: three vertex normals (zero when the file has
/// none), then (u0, v0, u1, v1) and (u2, v2, 0, 0).
pub const TRI_SHADING_VEC4S: u32 = 5;
/// CSG operations, as the program's BEGIN instructions carry them.
pub mod csg_op {
    /// Union keeping every child's surfaces (`CsgOp::Unite`).
    pub const UNITE: u32 = 0;
    /// Points inside every child.
    pub const INTERSECT: u32 = 1;
    /// Points inside the first child and outside all the others.
    pub const DIFF: u32 = 2;
    /// Union without the inner surfaces (`CsgOp::Fuse`).
    pub const FUSE: u32 = 3;
}
/// A CSG tree's program (`CsgTree::program`): its nodes and leaves depth first, one
/// instruction of `BITS` bits each, `32 / BITS` to a word from the low bits up. BEGIN + op
/// opens a node, END closes the innermost open one, LEAF stands for the next leaf (leaves
/// are shapes `first_leaf`, `first_leaf + 1`, ... in program order).
pub mod csg_instr {
    /// The next leaf shape of the tree.
    pub const LEAF: u32 = 0;
    /// Closes the innermost open node.
    pub const END: u32 = 1;
    /// Opens a node; the instruction is `BEGIN + op`, `op` a `csg_op` value.
    pub const BEGIN: u32 = 2;
    /// Width of one instruction in a program word.
    pub const BITS: u32 = 4;
    /// Instructions per program word.
    pub const PER_WORD: u32 = 32 / BITS;
}
/// A CSG tree's sweep table (`CsgTree::sweep`), for trees of more than `MIN_LEAVES`
/// leaves, whose rays can pass so many hidden crossings that walking the whole program for
/// each would cost O(n²) (shaders/csg.wgsl, cpu::csg's sweeps). Its nodes are numbered in
/// program order (each BEGIN and LEAF starts one), two words each: the parent's number
/// (`NO_PARENT` at the root), then the node's own operation (`csg_op`, for inner nodes)
/// in the low `OP_BITS`, `FIRST_CHILD` when it is its parent's first child, and its child
/// count from `CHILDREN_SHIFT` up. After the nodes, one word per leaf: its node's number.
pub mod csg_sweep {
    /// Trees of more leaves than this get a sweep table; smaller ones are only walked.
    pub const MIN_LEAVES: u32 = 64;
    /// The parent word of the root node.
    pub const NO_PARENT: u32 = 0xFFFF_FFFF;
    /// Mask of the node's `csg_op` in its second word (0 for a leaf).
    pub const OP_BITS: u32 = 0x3;
    /// Set in the second word of a node that is its parent's first child.
    pub const FIRST_CHILD: u32 = 0x4;
    /// Shift of the child count in the second word.
    pub const CHILDREN_SHIFT: u32 = 3;
}
/// `Material::brdf` values.
pub mod brdf_kind {
    /// Lambertian.
    pub const DIFFUSE: u32 = 0;
    /// Perfect mirror tinted by the pigment.
    pub const SPECULAR: u32 = 1;
    /// Smooth dielectric: delta Fresnel reflection and refraction (roughness 0).
    pub const DIELECTRIC: u32 = 2;
    /// GGX conductor, rough or smooth (α = 0: a delta reflection with its Fresnel).
    pub const CONDUCTOR: u32 = 3;
    /// GGX dielectric of roughness > 0 (smooth glass is `DIELECTRIC`).
    pub const ROUGH_DIELECTRIC: u32 = 4;
    /// Diffuse base under a dielectric coat, rough or smooth.
    pub const PLASTIC: u32 = 5;
    /// Number of kinds (one shading queue each; a scene's kinds share one kernel).
    pub const COUNT: u32 = 6;

    /// The kind of `brdf`: the one mapping, for the packer and the kernels' features.
    ///
    /// ```
    /// use lumen::gpu::layout::brdf_kind;
    /// use lumen::scene::{Brdf, Pigment};
    /// let glass = |roughness| Brdf::Dielectric { pigment: Pigment::default(), ior: 1.5, roughness, multiple_scattering: true };
    /// assert_eq!((brdf_kind::of(&glass(0.0)), brdf_kind::of(&glass(0.3))), (brdf_kind::DIELECTRIC, brdf_kind::ROUGH_DIELECTRIC));
    /// ```
    pub fn of(brdf: &crate::scene::Brdf) -> u32 {
        use crate::scene::Brdf;
        match brdf {
            Brdf::Diffuse { .. } => DIFFUSE,
            Brdf::Specular { .. } => SPECULAR,
            Brdf::Dielectric { roughness, .. } if *roughness == 0.0 => DIELECTRIC,
            Brdf::Dielectric { .. } => ROUGH_DIELECTRIC,
            Brdf::Conductor { .. } => CONDUCTOR,
            Brdf::Plastic { .. } => PLASTIC,
        }
    }
}
/// `Pigment::kind` values.
pub mod pigment_kind {
    /// One colour, `Pigment::a`.
    pub const UNIFORM: u32 = 0;
    /// `n × n` squares per unit of uv alternating `a` and `b`.
    pub const CHECKERED: u32 = 1;
    /// An image texture in `floats`.
    pub const IMAGE: u32 = 2;
}
/// `Environment::kind` values. A scene without an environment is packed as a `UNIFORM` one
/// of the renderer's background colour, so every kernel has one; 0, a zeroed struct's kind,
/// names none.
pub mod environment_kind {
    /// One radiance in every direction, `Environment::a`.
    pub const UNIFORM: u32 = 1;
    /// Blend of zenith, horizon and nadir colours by the direction's z.
    pub const GRADIENT: u32 = 2;
    /// An equirectangular image in `floats`, with its importance-sampling tables.
    pub const IMAGE: u32 = 3;
}
/// `Settings::renderer` values.
pub mod renderer_kind {
    /// One colour where the camera ray hits anything, another elsewhere.
    pub const ON_OFF: u32 = 0;
    /// Emitted plus pigment colour at the first hit.
    pub const FLAT: u32 = 1;
    /// Direct light from the point lights plus an ambient term.
    pub const POINT_LIGHT: u32 = 2;
    /// The wavefront path tracer.
    pub const PATH_TRACER: u32 = 3;
}
/// `Settings::jitter` values: how camera sample j is placed in its pixel.
pub mod jitter_mode {
    /// One sample at the pixel centre, no draws.
    pub const CENTRE: u32 = 0;
    /// s×s strata, s = `samples_per_side`.
    pub const STRATIFIED: u32 = 1;
    /// Jittered over the whole pixel.
    pub const WHOLE_PIXEL: u32 = 2;
}

/// Three rows of a 3×4 affine matrix (last column: translation), in f32.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Affine {
    /// First row: the mapped x of a point p is `r0.xyz · p + r0.w`.
    pub r0: [f32; 4],
    /// Second row: the mapped y.
    pub r1: [f32; 4],
    /// Third row: the mapped z.
    pub r2: [f32; 4],
}

impl Affine {
    /// Rounds the top three rows of an affine f64 matrix to f32.
    pub fn from_dmat4(m: &DMat4) -> Self {
        let row = |i: usize| {
            let r = m.row(i);
            [r.x as f32, r.y as f32, r.z as f32, r.w as f32]
        };
        Self { r0: row(0), r1: row(1), r2: row(2) }
    }
}

/// One unit primitive or mesh instance placed in the camera frame: a top-level shape or a
/// CSG leaf (WGSL `Shape`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Shape {
    /// Camera frame to object space: the f64 inverse of `to_world`, rounded to f32.
    pub to_object: Affine,
    /// Object space to the camera frame.
    pub to_world: Affine,
    /// A `shape_kind` value.
    pub kind: u32,
    /// Index in `materials`.
    pub material: u32,
    /// Index in `area_lights` when the shape is emissive and sampled as a light, else [`NONE`].
    pub light: u32,
    /// Mesh instances: `mesh_bits` (root node and flags); 0 for primitives.
    pub mesh: u32,
}

/// A top-level CSG tree: its bounds, its program (`csg_instr`), its contiguous run of leaf
/// shapes and its optional sweep table (WGSL `CsgTree`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct CsgTree {
    /// The tree's bounds (f32, rounded outward): an object list hands a tree to the CSG
    /// stage only when the ray crosses them (`gpu::traversal`).
    pub min: [f32; 3],
    /// Index in `indices` of the program's first word.
    pub program: u32,
    /// Upper corner of the bounds (`min` is the lower one), camera frame.
    pub max: [f32; 3],
    /// Instructions in the program.
    pub length: u32,
    /// Shape index of the first leaf.
    pub first_leaf: u32,
    /// Number of leaves: shapes `first_leaf .. first_leaf + leaf_count`.
    pub leaf_count: u32,
    /// Index in `indices` of the tree's sweep table (`csg_sweep`), 0 when it has none.
    pub sweep: u32,
    /// Nodes (leaves included) in the sweep table; 0: the tree is only walked.
    pub node_count: u32,
}

/// A material: its BSDF kind and constants, and its pigments (WGSL `Material`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Material {
    /// A `brdf_kind` value.
    pub brdf: u32,
    /// Index in `pigments` of the colour that tints the BSDF.
    pub pigment: u32,
    /// Index in `pigments` of the emitted radiance.
    pub emitted: u32,
    /// Dielectrics and plastic: index of refraction, inside over outside; 1 for the others.
    pub ior: f32,
    /// GGX α of the microfacet kinds (0: smooth).
    pub alpha: f32,
    /// Offset in `floats` of the material's energy-table rows (`pack::pack_material`).
    pub rows: u32,
    /// Padding, so that `eta` starts on 16 bytes as WGSL's vec4 does.
    pub _pad0: u32,
    /// Padding (see `_pad0`).
    pub _pad1: u32,
    /// Conductor: complex index η and k per channel; `eta[3]` is 1 when given (else F = 1).
    pub eta: [f32; 4],
    /// Conductor: the extinction coefficient k per channel (rgb; w is 0).
    pub k: [f32; 4],
    /// Compensation constants (`optics::compensation`): conductor, the lobe scale per
    /// channel; rough dielectric entering (η = ior), (k_t, reflect, transmit); plastic,
    /// (internal, base).
    pub lobe: [f32; 4],
    /// Rough dielectric leaving (η = 1/ior): (k_t, reflect, transmit).
    pub lobe_back: [f32; 4],
}

/// A colour over a surface's uv: uniform, checkered or an image (WGSL `Pigment`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Pigment {
    /// Uniform: the colour; checkered: the `on` colour (rgb, w unused).
    pub a: [f32; 4],
    /// Checkered: the `off` colour.
    pub b: [f32; 4],
    /// A `pigment_kind` value.
    pub kind: u32,
    /// Checkered: squares per unit of u and of v.
    pub n: u32,
    /// Image: an `image_filter_kind` value.
    pub image_filter: u32,
    /// Image: offset in `floats` of the texels (rgb triples, row 0 at the top).
    pub tex_offset: u32,
    /// Image: width in texels.
    pub tex_width: u32,
    /// Image: height in texels.
    pub tex_height: u32,
    /// Padding to a multiple of 16 bytes (the WGSL struct's alignment).
    pub _pad0: u32,
    /// Padding (see `_pad0`).
    pub _pad1: u32,
}

/// An area light: `sphere` = world centre and radius when the light is a sphere placed by a
/// similarity (sampled by the cone it subtends), radius 0 otherwise (sampled by area).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct AreaLight {
    /// Centre (xyz, camera frame) and radius (w) of a sphere placed by a similarity; all 0
    /// otherwise.
    pub sphere: [f32; 4],
    /// Index in `shapes` of the emissive shape (a sphere, a cube or a mesh instance).
    pub shape: u32,
    /// Spheres: |determinant| of the linear part of the shape's object-to-world map
    /// (`LightSurface::Sphere::det`); 0 otherwise.
    pub det: f32,
    /// Meshes: the world surface area (`MeshLight::area`); 0 otherwise.
    pub area: f32,
    /// Meshes: offset in `floats` of the triangle CDF (file order; then each triangle's
    /// index in `tri_positions`, as bits).
    pub mesh_cdf: u32,
    /// Cubes: `LightSurface::Cube::face_areas` (one face of each pair, world area); 0 otherwise.
    pub face_areas: [f32; 3],
    /// Meshes: the triangle count; 0 for spheres and cubes.
    pub mesh_triangles: u32,
    /// Cubes: bit `axis` set where `LightSurface::Cube::rectangular_faces[axis]`; 0 otherwise.
    pub rectangular_faces: u32,
    /// Padding to a multiple of 16 bytes (the WGSL struct's alignment).
    pub _pad0: u32,
    /// Padding (see `_pad0`).
    pub _pad1: u32,
    /// Padding (see `_pad0`).
    pub _pad2: u32,
}

/// A point light (WGSL `PointLight`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct PointLight {
    /// Position (xyz, camera frame) and, in w, the light's `linear_radius`.
    pub position: [f32; 4],
    /// Emitted colour (rgb, w is 0).
    pub color: [f32; 4],
}

/// What escaping rays see (WGSL `Environment`); without a scene environment, a uniform one
/// of the renderer's background colour.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Environment {
    /// Uniform: the radiance; gradient: the zenith colour (rgb, w unused).
    pub a: [f32; 4],
    /// Gradient: the horizon colour.
    pub b: [f32; 4],
    /// Gradient: the nadir colour.
    pub c: [f32; 4],
    /// An `environment_kind` value.
    pub kind: u32,
    /// Image: width in texels.
    pub tex_width: u32,
    /// Image: height in texels.
    pub tex_height: u32,
    /// Image: offset in `floats` of the texels (rgb triples, row 0 at the top).
    pub tex_offset: u32,
    /// Image: the factor its texels are scaled by (1 for the other kinds).
    pub intensity: f32,
    /// Image: rotation of the map about the z axis, in radians.
    pub rotation_rad: f32,
    /// Image: offset in `floats` of the importance-sampling tables (`Distribution2D::packed`).
    pub dist_offset: u32,
    /// 1 when next-event estimation samples the environment (it is not black), else 0.
    pub is_light: u32,
}

/// The camera (WGSL `Camera`), with `scene::Camera`'s conventions: it looks along +x of
/// its own space, z up.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Camera {
    /// Camera space to the camera frame (the packed coordinates, whose origin is the eye or
    /// the centre of the orthogonal ray plane).
    pub to_world: Affine,
    /// A `projection_kind` value.
    pub projection: u32,
    /// Screen width over height: the screen spans y ∈ [−aspect_ratio, aspect_ratio],
    /// z ∈ [−1, 1] in camera space.
    pub aspect_ratio: f32,
    /// Perspective: the eye's distance behind the screen (at x = 0); 0 for orthogonal.
    pub screen_distance: f32,
    /// Padding to a multiple of 16 bytes (the WGSL struct's alignment).
    pub _pad: u32,
}

/// `Camera::projection` values.
pub mod projection_kind {
    /// Rays from the eye at (−screen_distance, 0, 0) through the screen.
    pub const PERSPECTIVE: u32 = 0;
    /// Parallel rays along +x from the plane x = −1.
    pub const ORTHOGONAL: u32 = 1;
}

/// `Pigment::image_filter` values.
pub mod image_filter_kind {
    /// The texel containing (u, v).
    pub const NEAREST: u32 = 0;
    /// Bilinear between the four nearest texel centres, wrapping in u and clamping in v.
    pub const BILINEAR: u32 = 1;
}

/// The shape kinds by their names in WGSL (`SHAPE_` + name).
const SHAPE_KIND_NAMES: [(&str, u32); 5] = [
    ("SPHERE", shape_kind::SPHERE),
    ("PLANE", shape_kind::PLANE),
    ("CUBE", shape_kind::CUBE),
    ("CYLINDER", shape_kind::CYLINDER),
    ("MESH", shape_kind::MESH),
];

/// The WGSL constant naming shape kind `kind` (`SHAPE_CUBE`, ...), for generated code.
///
/// ```
/// use lumen::gpu::layout::{shape_kind, shape_kind_wgsl};
/// assert_eq!(shape_kind_wgsl(shape_kind::CUBE), "SHAPE_CUBE");
/// ```
pub fn shape_kind_wgsl(kind: u32) -> String {
    let name = SHAPE_KIND_NAMES.iter().find(|(_, k)| *k == kind).map_or("UNKNOWN", |(n, _)| n);
    format!("SHAPE_{name}")
}

/// Every tag above as WGSL constants (`SHAPE_SPHERE`, `BRDF_DIELECTRIC`, ...): the shaders
/// name tags only through these, so the two sides cannot disagree (a test scans the shaders
/// for bare tag literals).
pub fn tags_wgsl() -> String {
    let groups: [(&str, &[(&str, u32)]); 12] = [
        ("SHAPE", &SHAPE_KIND_NAMES),
        (
            "MESH",
            &[
                ("SMOOTH", mesh_bits::SMOOTH),
                ("UVS", mesh_bits::UVS),
                ("NODE_MASK", mesh_bits::NODE_MASK),
                ("POSITION_VEC4S", TRI_POSITION_VEC4S),
                ("SHADING_VEC4S", TRI_SHADING_VEC4S),
            ],
        ),
        (
            "BVH",
            &[
                ("LEFT_LEAF", crate::accel::quantized::LEFT_LEAF),
                ("RIGHT_LEAF", crate::accel::quantized::RIGHT_LEAF),
                ("GRID_BITS", crate::accel::quantized::GRID_BITS),
                ("LEFT_COUNT_SHIFT", crate::accel::quantized::LEFT_COUNT_SHIFT),
                ("RIGHT_COUNT_SHIFT", crate::accel::quantized::RIGHT_COUNT_SHIFT),
                ("COUNT_MASK", crate::accel::quantized::COUNT_MASK),
                ("LEAF_REF", crate::accel::quantized::LEAF_REF),
                ("REF_COUNT_SHIFT", crate::accel::quantized::REF_COUNT_SHIFT),
            ],
        ),
        (
            "CSG",
            &[
                ("UNITE", csg_op::UNITE),
                ("INTERSECT", csg_op::INTERSECT),
                ("DIFF", csg_op::DIFF),
                ("FUSE", csg_op::FUSE),
            ],
        ),
        (
            "CSG_INSTR",
            &[
                ("LEAF", csg_instr::LEAF),
                ("END", csg_instr::END),
                ("BEGIN", csg_instr::BEGIN),
                ("BITS", csg_instr::BITS),
                ("PER_WORD", csg_instr::PER_WORD),
            ],
        ),
        (
            "CSG_SWEEP",
            &[
                ("NO_PARENT", csg_sweep::NO_PARENT),
                ("OP_BITS", csg_sweep::OP_BITS),
                ("FIRST_CHILD", csg_sweep::FIRST_CHILD),
                ("CHILDREN_SHIFT", csg_sweep::CHILDREN_SHIFT),
            ],
        ),
        (
            "BRDF",
            &[
                ("DIFFUSE", brdf_kind::DIFFUSE),
                ("SPECULAR", brdf_kind::SPECULAR),
                ("DIELECTRIC", brdf_kind::DIELECTRIC),
                ("CONDUCTOR", brdf_kind::CONDUCTOR),
                ("ROUGH_DIELECTRIC", brdf_kind::ROUGH_DIELECTRIC),
                ("PLASTIC", brdf_kind::PLASTIC),
            ],
        ),
        (
            "PIGMENT",
            &[
                ("UNIFORM", pigment_kind::UNIFORM),
                ("CHECKERED", pigment_kind::CHECKERED),
                ("IMAGE", pigment_kind::IMAGE),
            ],
        ),
        (
            "ENV",
            &[
                ("UNIFORM", environment_kind::UNIFORM),
                ("GRADIENT", environment_kind::GRADIENT),
                ("IMAGE", environment_kind::IMAGE),
            ],
        ),
        ("PROJECTION", &[("PERSPECTIVE", projection_kind::PERSPECTIVE), ("ORTHOGONAL", projection_kind::ORTHOGONAL)]),
        (
            "JITTER",
            &[
                ("CENTRE", jitter_mode::CENTRE),
                ("STRATIFIED", jitter_mode::STRATIFIED),
                ("WHOLE_PIXEL", jitter_mode::WHOLE_PIXEL),
            ],
        ),
        ("FILTER", &[("NEAREST", image_filter_kind::NEAREST), ("BILINEAR", image_filter_kind::BILINEAR)]),
    ];
    let mut out = String::from("// #provides tags\n// Tags of the packed structs, generated by src/gpu/layout.rs.\n");
    for (prefix, tags) in groups {
        for (name, value) in tags {
            out.push_str(&format!("const {prefix}_{name}: u32 = {value}u;\n"));
        }
    }
    out.push_str(&format!("const CAMERA_STRATA_SALT: u32 = {}u;\n", crate::prepare::CAMERA_STRATA_SALT));
    // The camera's bounce number in the (pixel, sample, bounce) stream rule, and the
    // packed references' "no index" marker.
    out.push_str(&format!("const CAMERA_BOUNCE: u32 = {}u;\n", crate::sampling::CAMERA_BOUNCE));
    out.push_str(&format!("const NONE: u32 = {NONE}u;\n"));
    // Not a tag, but a threshold both renderers must share exactly (an f32 too).
    let reach = 0.5 + crate::prepare::CUBE_FACE_MARGIN;
    assert_eq!(f64::from(reach as f32), reach);
    out.push_str(&format!("const CUBE_FACE_REACH: f32 = {reach:?};\n"));
    // The packed layout of a 1-D distribution's table (sampling::distribution::packed), as
    // the linear functions of its cell count that WGSL evaluates (shaders/env_light.wgsl).
    {
        use crate::sampling::distribution::packed;
        let per_cell = packed::len(1) - packed::len(0);
        assert!(
            (0..64).all(|n| packed::len(n) == packed::len(0) + per_cell * n && packed::cdf(n) == packed::cdf(0) + n)
        );
        for (name, value) in [
            ("DIST1D_INTEGRAL", packed::INTEGRAL),
            ("DIST1D_VALUES", packed::VALUES),
            ("DIST1D_CDF", packed::cdf(0)),
            ("DIST1D_WORDS", packed::len(0)),
            ("DIST1D_WORDS_PER_CELL", per_cell),
        ] {
            out.push_str(&format!("const {name}: u32 = {value}u;\n"));
        }
    }
    for (name, value) in [
        ("SOLID_ANGLE_MIN", crate::prepare::SOLID_ANGLE_MIN),
        ("SOLID_ANGLE_MAX", crate::prepare::SOLID_ANGLE_MAX),
        ("PLANE_PARALLEL_SLOPE", crate::prepare::PLANE_PARALLEL_SLOPE),
    ] {
        assert_eq!(f64::from(value as f32), value);
        out.push_str(&format!("const {name}: f32 = {value:?};\n"));
    }
    out
}

/// Render parameters (a uniform).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Settings {
    /// On-off: the colour where the camera ray hits (`on`); flat, point-light and path
    /// tracer: the background, which escaping rays read from `Environment` instead.
    pub color0: [f32; 4],
    /// On-off: the colour where it misses (`off`); point-light: the ambient term added at
    /// every hit; black for the others.
    pub color1: [f32; 4],
    /// The tracer's PCG seed as `PcgSeed::words` (state lo, state hi, inc lo, inc hi): the
    /// camera's jitter and the path tracer's streams derive from it.
    pub tracer_seed: [u32; 4],
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// A `renderer_kind` value.
    pub renderer: u32,
    /// Stratified jitter: s of the s×s strata per pixel; 0 for the other modes.
    pub samples_per_side: u32,
    /// A `jitter_mode` value.
    pub jitter: u32,
    /// Path tracer: independent paths per camera sample; 1 for the other renderers.
    pub paths_per_sample: u32,
    /// Path tracer: the last bounce (the camera hit is bounce 0), so a path has at most
    /// `max_depth + 1` surface hits; 0 for the other renderers.
    pub max_depth: u32,
    /// Path tracer: Russian roulette applies at bounces ≥ this.
    pub roulette_depth: u32,
    /// 1 when the path tracer uses next-event estimation with MIS, else 0.
    pub nee: u32,
    /// Camera samples per pixel of the whole render.
    pub spp: u32,
    /// Ranges of the `indices` buffer (BVH leaf objects start at 0).
    pub plane_offset: u32,
    /// Entries of the unbounded list at `plane_offset` (planes and unbounded CSG trees).
    pub plane_count: u32,
    /// log₂ of the strata per dimension of a path vertex (`sampling::strata_bits` of the
    /// pixel's samples: camera samples times paths per sample).
    pub strata_bits: u32,
    /// Entries of `area_lights`.
    pub area_light_count: u32,
    /// Entries of `point_lights`.
    pub point_light_count: u32,
    /// Nodes of the top-level BVH at the start of `bvh_nodes` (the meshes' follow); 0 when
    /// no bounded object is in it.
    pub bvh_node_count: u32,
    /// `sampling::seed_word` of the tracer's seed, for the strata's permutation keys.
    pub strata_seed: u32,
    /// Padding to a multiple of 16 bytes (the WGSL struct's alignment).
    pub _pad1: u32,
    /// Padding (see `_pad1`).
    pub _pad2: u32,
    /// Padding (see `_pad1`).
    pub _pad3: u32,
}

#[cfg(test)]
mod tests {
    use std::mem::{offset_of, size_of};

    use naga::proc::Layouter;
    use naga::TypeInner;

    use super::*;

    /// (struct name, Rust size, [(member, Rust offset)]).
    type Expected = (&'static str, usize, Vec<(&'static str, usize)>);

    macro_rules! expect {
        ($t:ty, $name:literal, [$($f:ident),* $(,)?]) => {
            ($name, size_of::<$t>(), vec![$((stringify!($f), offset_of!($t, $f))),*])
        };
    }

    fn expected() -> Vec<Expected> {
        vec![
            expect!(Affine, "Affine", [r0, r1, r2]),
            expect!(Shape, "Shape", [to_object, to_world, kind, material, light, mesh]),
            expect!(CsgTree, "CsgTree", [min, program, max, length, first_leaf, leaf_count, sweep, node_count]),
            expect!(
                Material,
                "Material",
                [brdf, pigment, emitted, ior, alpha, rows, _pad0, _pad1, eta, k, lobe, lobe_back]
            ),
            expect!(Pigment, "Pigment", [a, b, kind, n, image_filter, tex_offset, tex_width, tex_height, _pad0, _pad1]),
            expect!(PointLight, "PointLight", [position, color]),
            expect!(
                AreaLight,
                "AreaLight",
                [
                    sphere,
                    shape,
                    det,
                    area,
                    mesh_cdf,
                    face_areas,
                    mesh_triangles,
                    rectangular_faces,
                    _pad0,
                    _pad1,
                    _pad2
                ]
            ),
            expect!(
                Environment,
                "Environment",
                [a, b, c, kind, tex_width, tex_height, tex_offset, intensity, rotation_rad, dist_offset, is_light]
            ),
            expect!(Camera, "Camera", [to_world, projection, aspect_ratio, screen_distance, _pad]),
            expect!(
                Settings,
                "Settings",
                [
                    color0,
                    color1,
                    tracer_seed,
                    width,
                    height,
                    renderer,
                    samples_per_side,
                    jitter,
                    paths_per_sample,
                    max_depth,
                    roulette_depth,
                    nee,
                    spp,
                    plane_offset,
                    plane_count,
                    strata_bits,
                    area_light_count,
                    point_light_count,
                    bvh_node_count,
                    strata_seed,
                    _pad1,
                    _pad2,
                    _pad3,
                ]
            ),
            expect!(crate::accel::QuantizedNode, "QuantizedNode", [corner, scales, grid, link]),
        ]
    }

    #[test]
    fn wgsl_structs_match_rust_byte_for_byte() {
        let module = naga::front::wgsl::parse_str(LAYOUT_WGSL).expect("layout.wgsl parses");
        let mut layouter = Layouter::default();
        layouter.update(module.to_ctx()).unwrap();
        let expected = expected();
        let mut seen = 0;
        for (handle, ty) in module.types.iter() {
            let (Some(name), TypeInner::Struct { members, span }) = (&ty.name, &ty.inner) else { continue };
            let (_, size, fields) = expected
                .iter()
                .find(|e| e.0 == name)
                .unwrap_or_else(|| panic!("WGSL struct {name} has no Rust mirror in the test"));
            seen += 1;
            assert_eq!(*span as usize, *size, "size of {name}");
            let align = layouter[handle].alignment.round_up(1) as usize;
            assert_eq!(size % align, 0, "{name}: array stride would differ (WGSL alignment {align})");
            let wgsl: Vec<(String, usize)> =
                members.iter().map(|m| (m.name.clone().unwrap_or_default(), m.offset as usize)).collect();
            let rust: Vec<(String, usize)> = fields.iter().map(|(f, o)| (f.to_string(), *o)).collect();
            assert_eq!(wgsl, rust, "members of {name}");
            for m in members {
                let a = layouter[m.ty].alignment.round_up(1) as usize;
                assert_eq!(m.offset as usize % a, 0, "{name}.{:?} misaligned for WGSL", m.name);
            }
        }
        assert_eq!(seen, expected.len(), "every Rust struct has a WGSL mirror");
    }

    #[test]
    fn affine_rows_round_the_matrix() {
        let m = DMat4::from_translation(glam::DVec3::new(1.0, 2.0, 3.0));
        let a = Affine::from_dmat4(&m);
        assert_eq!(a.r0, [1.0, 0.0, 0.0, 1.0]);
        assert_eq!(a.r2, [0.0, 0.0, 1.0, 3.0]);
    }
}
