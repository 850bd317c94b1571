//! Packing a [`Scene`] into the Pod buffers of [`super::layout`].
//!
//! Precision: the GPU works in f32, whose 24-bit mantissa leaves only ~1 cm of resolution
//! at 10⁵ units from the origin. So the whole scene is first moved, in f64, so that the
//! camera sits at the origin ([`camera_origin`]); every transformation, light position and
//! BVH bound is computed in that frame and only then rounded to f32. Geometry near the
//! camera (what is seen in detail) keeps full f32 precision however far the scene lies
//! from the world origin. Rays are moved into object space with the f32 world→object map
//! (computed as an f64 inverse, then rounded), never by inverting in f32.

use std::collections::{HashMap, HashSet};
use std::sync::Arc;

use bytemuck::Zeroable;

use glam::DVec3;

use super::features::FeatureSet;
use super::layout::{self, Affine, NONE};
use super::tables::Table;
use super::traversal::Unrolled;
use crate::accel::{quantized, QuantizedNode};
use crate::color::Color;
use crate::image::HdrImage;
use crate::optics::compensation::{conductor_ms, dielectric_lobes, plastic_coat};
use crate::optics::energy_tables::{energy_tables, CONDUCTOR_NODES, DIELECTRIC_NODES};
use crate::optics::ggx::alpha_of;
use crate::prepare::image_distribution;
use crate::prepare::pixel_samples::PixelSamples;
use crate::prepare::{AreaLight, LightSurface};
use crate::sampling::distribution::Distribution2D;
use crate::scene::{Brdf, CsgOp, Environment, Pigment, Projection, Renderer, Scene, Shape, ShapeKind, Transform};

/// A scene ready for upload: every buffer of `shaders/bindings.wgsl`.
#[derive(Debug, Clone)]
pub struct PackedScene {
    /// What the kernels are specialised on: `FeatureSet::of` the scene's render form, with
    /// the object lists the kernels may unroll (`listed`, `planes_listed`) set by the packer.
    pub features: FeatureSet,
    /// The `settings` uniform: renderer, sampling and the ranges of the tables.
    pub settings: layout::Settings,
    /// The `camera` uniform, in the camera frame.
    pub camera: layout::Camera,
    /// The `environment` uniform.
    pub environment: layout::Environment,
    /// Top-level primitives and mesh instances, and each CSG tree's leaves (contiguous,
    /// depth first), in scene order; an object reference without `CSG_NODE_BIT` indexes it.
    pub shapes: Vec<layout::Shape>,
    /// BVH leaf objects, then planes and CSG children (see `Settings`).
    pub indices: Vec<u32>,
    /// The scene's BVH, then each distinct mesh's, in the GPU's quantized form.
    pub bvh_nodes: Vec<QuantizedNode>,
    /// The top-level CSG trees, indexed by object references with `CSG_NODE_BIT` set.
    pub csg_trees: Vec<layout::CsgTree>,
    /// One per scene material, in the scene's order (`layout::Shape::material` indexes it).
    pub materials: Vec<layout::Material>,
    /// Each material's BSDF pigment, then its emitted one (`layout::Material::pigment` and
    /// `emitted` index them).
    pub pigments: Vec<layout::Pigment>,
    /// Texels, the environment's importance-sampling tables and mesh lights' CDFs.
    pub floats: Vec<f32>,
    /// The microfacet materials' energy rows (`layout::Material::rows` indexes them): a
    /// table of its own, small enough for a uniform buffer where `floats` is not (an image
    /// environment makes it megabytes).
    pub rows: Vec<f32>,
    /// The scene's point lights, in the camera frame.
    pub point_lights: Vec<layout::PointLight>,
    /// The emissive spheres, cubes and mesh instances that next-event estimation samples,
    /// in `Scene::area_lights` order (`layout::Shape::light` indexes it).
    pub area_lights: Vec<layout::AreaLight>,
    /// Triangles of every distinct mesh, in bottom-level BVH leaf order
    /// (`layout::TRI_POSITION_VEC4S` vec4 each, object space).
    pub tri_positions: Vec<[f32; 4]>,
    /// Their vertex normals and uvs (`layout::TRI_SHADING_VEC4S` vec4 each).
    pub tri_shading: Vec<[f32; 4]>,
    /// The world point that the packed coordinates are relative to.
    pub origin: DVec3,
}

/// Whether `count` primitives fit the ranges a GPU walk carries (accel::quantized::LEAF_REF:
/// 2^28, far beyond what the storage buffers hold).
fn leaf_range_fits(what: &'static str, count: usize) -> Result<(), PackError> {
    let limit = quantized::MAX_LEAF_FIRST as usize;
    if count > limit {
        return Err(PackError::TooMany { what, count, limit });
    }
    Ok(())
}

/// Most CSG pool entries one path may need on the GPU (8 bytes each, so 4 MiB;
/// `wavefront::csg_pool_entries`: for a tree of more than 64 leaves three per leaf and one
/// per node, about five per leaf, so about 100,000 leaves). The pool bounds a batch's paths
/// by its memory budget (256 MiB on a software adapter), so beyond this a batch would hold
/// too few paths to be worth running. SceneLang allows larger trees (up to
/// `scene::MAX_PRIMITIVES` leaves): the GPU refuses them with this error, the CPU renders
/// them.
pub const MAX_CSG_POOL: usize = 1 << 19;

/// Why a scene cannot be packed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PackError {
    /// The scene has more of something than the GPU renderer's buffers or index encodings
    /// can address (shapes, BVH nodes, triangles, samples per pixel, CSG pool entries, ...).
    #[error("{what}: {count} exceeds the GPU renderer's limit of {limit}")]
    TooMany {
        /// What was counted, for the message.
        what: &'static str,
        /// How many the scene needs.
        count: usize,
        /// The most the GPU renderer allows.
        limit: usize,
    },
    /// The scene fails validation, or the packer meets what it cannot represent (a mesh as
    /// a CSG operand, an emissive surface of zero area).
    #[error("invalid scene: {0}")]
    Scene(#[from] crate::scene::SceneError),
    /// f32 cannot hold the shape's placement: rounding its transform would give ±∞ and a
    /// meaningless render, so the GPU refuses the scene (the CPU renders it in f64).
    /// `shape` counts the script's shapes in spawn order from 0 (a top-level UNITE, which the
    /// renderers split, is one shape; `part` says which of its parts), and `origin` where the
    /// script wrote it.
    #[error(
        "shape {} in spawn order{} ({what}{}): its transform reaches {magnitude:e} in the camera frame, beyond \
         f32's range (±3.4e38) that the GPU computes in",
        .shape + 1,
        part_text(*.part),
        .origin.as_ref().map(|o| format!(", written at {o}")).unwrap_or_default()
    )]
    OutOfRange {
        /// The shape's index in spawn order, from 0 (the message counts from 1).
        shape: usize,
        /// `file:line:column` of its SPAWN item ([`Scene::origins`]); `None` for a scene
        /// built in code.
        origin: Option<String>,
        /// Which part of a split top-level UNITE, from 0; `None` for a shape not split.
        part: Option<usize>,
        /// What overflowed: the shape's kind (`"sphere"`, ...), a CSG leaf's, or `"mesh instance"`.
        what: &'static str,
        /// The largest |entry| of its object-to-camera-frame matrix; ∞ for a shape other
        /// than a plane or CSG tree whose bounds are infinite.
        magnitude: f64,
    },
    /// A mesh file's vertex or texture coordinate beyond f32's range (the GPU stores the
    /// triangles in object space as f32; the file is finite in f64, so it loads).
    #[error("mesh {file}: a {what} reaches {magnitude:e}, beyond f32's range (±3.4e38) that the GPU stores meshes in")]
    MeshOutOfRange {
        /// The mesh file as the script named it.
        file: String,
        /// Which coordinate: a vertex coordinate (in object space or in the camera frame)
        /// or a texture coordinate.
        what: &'static str,
        /// The largest |coordinate| found.
        magnitude: f64,
    },
    /// A CSG tree whose spans (and sweep state) outgrow the pool one path holds
    /// ([`MAX_CSG_POOL`] entries): located like [`PackError::OutOfRange`].
    #[error(
        "shape {} in spawn order{} (a CSG tree of {leaves} leaves{}): one ray query of it needs {entries} entries \
         of the GPU's span pool (3 per leaf, and one per leaf and node its sweeps track), more than the {limit} a \
         path holds (about {} leaves); a large union spawned as separate shapes fits, and the BVH handles it far \
         better",
        .shape + 1,
        part_text(*.part),
        .origin.as_ref().map(|o| format!(", written at {o}")).unwrap_or_default(),
        .limit / 5
    )]
    CsgTooLarge {
        /// The tree's index in spawn order, from 0 (the message counts from 1).
        shape: usize,
        /// `file:line:column` of its SPAWN item; `None` for a scene built in code.
        origin: Option<String>,
        /// Which part of a split top-level UNITE, from 0; `None` for a shape not split.
        part: Option<usize>,
        /// Its leaves (primitives).
        leaves: usize,
        /// Pool entries a query of the scene's largest tree needs.
        entries: usize,
        /// [`MAX_CSG_POOL`].
        limit: usize,
    },
    /// A table outgrows what one binding of the adapter holds ([`TableLimit`]); `needed` is
    /// the table's size up to the part that would not fit, so a lower bound.
    #[error("{} needs {needed} bytes but this adapter allows at most {} bytes per {}", .table.described(), .limit.bytes, .limit.name)]
    TooLarge {
        /// The table that would not fit.
        table: Table,
        /// Its size in bytes up to the part refused (a lower bound).
        needed: u64,
        /// The adapter's limit it outgrew.
        limit: TableLimit,
    },
}

/// The most bytes one table (one storage buffer) may take on the adapter a scene is packed
/// for, and the name of that limit. [`pack_within`] refuses a table as soon as an image,
/// a mesh or a sampling table would take it past this, before converting the rest: a
/// 16384×8192 sky needs 2.7 GB of floats, and lavapipe binds 128 MiB, so packing all of
/// it only to be refused at the upload cost ten seconds and gigabytes. Only the tables that
/// are storage buffers wherever a render reads them are checked (`floats`, `bvh_nodes`,
/// `tri_positions`: the BVH walks read the last two, and `floats` is binary-searched), and
/// only where textures do not replace them everywhere (`--tables texture`; the renderer
/// passes [`TableLimit::NONE`] then).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TableLimit {
    /// The most bytes one table may take.
    pub bytes: u64,
    /// The name of the adapter limit that sets it, for messages (e.g. "storage buffer
    /// binding").
    pub name: &'static str,
}

impl TableLimit {
    /// No limit ([`pack`]): the tables are checked where they are uploaded.
    pub const NONE: TableLimit = TableLimit { bytes: u64::MAX, name: "table" };

    /// Whether `table` still fits with `more` elements.
    fn room<T>(self, which: Table, table: &[T], more: usize) -> Result<(), PackError> {
        let needed = (table.len() as u64).saturating_add(more as u64).saturating_mul(std::mem::size_of::<T>() as u64);
        if needed > self.bytes {
            return Err(PackError::TooLarge { table: which, needed, limit: self });
        }
        Ok(())
    }
}

fn part_text(part: Option<usize>) -> String {
    part.map(|k| format!(", part {} of its top-level UNITE", k + 1)).unwrap_or_default()
}

impl PackError {
    /// The error with its shape located in `scene` (the script's shapes) rather than in
    /// the render form the packer walks (prepare::render_form).
    fn located_in(self, scene: &Scene) -> Self {
        match self {
            PackError::OutOfRange { shape, what, magnitude, .. } => {
                let (shape, part) = crate::prepare::source_shape(scene, shape).unwrap_or((shape, None));
                PackError::OutOfRange { shape, origin: scene.origins.of(shape), part, what, magnitude }
            }
            PackError::CsgTooLarge { shape, leaves, entries, limit, .. } => {
                let (shape, part) = crate::prepare::source_shape(scene, shape).unwrap_or((shape, None));
                PackError::CsgTooLarge { shape, origin: scene.origins.of(shape), part, leaves, entries, limit }
            }
            other => other,
        }
    }
}

/// The camera's position in the world: where the packed frame's origin goes. For a
/// perspective camera the eye, for an orthogonal one the centre of its ray plane.
pub fn camera_origin(scene: &Scene) -> DVec3 {
    let local = match scene.camera.projection {
        Projection::Perspective { screen_distance } => DVec3::new(-screen_distance, 0.0, 0.0),
        Projection::Orthogonal => DVec3::new(-1.0, 0.0, 0.0),
    };
    scene.camera.transform.point(local)
}

/// Camera samples per pixel and their placement: the tracer's, or `spp_override` (`--spp`).
pub fn pixel_samples(scene: &Scene, spp_override: Option<u32>) -> Result<(PixelSamples, u32), PackError> {
    let ps = PixelSamples::new(&scene.tracer, spp_override);
    let count = ps.count();
    let limit = u32::MAX as usize;
    let spp = u32::try_from(count).map_err(|_| PackError::TooMany {
        what: "samples per pixel",
        count: count as usize,
        limit,
    })?;
    Ok((ps, spp))
}

fn rgba(c: Color) -> [f32; 4] {
    [c.r as f32, c.g as f32, c.b as f32, 0.0]
}

fn count_u32(what: &'static str, n: usize) -> Result<u32, PackError> {
    // Leave the top bit free for CSG_NODE_BIT.
    let limit = (layout::CSG_NODE_BIT - 1) as usize;
    if n > limit {
        return Err(PackError::TooMany { what, count: n, limit });
    }
    Ok(n as u32)
}

/// Builds every buffer for `scene`; `spp_override` is the `--spp` option.
///
/// ```
/// use lumen::scene::*;
/// use lumen::color::Color;
/// use glam::DVec3;
/// let mut b = SceneBuilder::new(4, 3);
/// let m = b.diffuse(Color::gray(0.5));
/// b.sphere(Transform::translation(DVec3::new(1e5, 0.0, 0.0)), m)
///     .camera(Camera { transform: Transform::translation(DVec3::new(1e5 - 3.0, 0.0, 0.0)), ..Camera::default() });
/// let packed = lumen::gpu::pack::pack(&b.build().unwrap(), None).unwrap();
/// // In the camera frame (eye at the origin) the sphere is 4 units ahead.
/// assert_eq!(packed.shapes[0].to_world.r0[3], 4.0);
/// ```
pub fn pack(scene: &Scene, spp_override: Option<u32>) -> Result<PackedScene, PackError> {
    pack_within(scene, spp_override, TableLimit::NONE)
}

/// [`pack`] for an adapter whose tables may take at most `limit` bytes each: a table that
/// outgrows it is refused before the bulk of it (texels, sampling tables, triangles) is
/// converted.
///
/// ```
/// use lumen::scene::*;
/// use lumen::gpu::pack::{pack_within, PackError, TableLimit};
/// use lumen::gpu::tables::Table;
/// let mut b = SceneBuilder::new(4, 4);
/// let m = b.diffuse(lumen::color::Color::gray(0.5));
/// b.sphere(Transform::IDENTITY, m)
///     .environment(Environment::Image { image: std::sync::Arc::new(lumen::image::HdrImage::new(64, 32)), intensity: 1.0, rotation_deg: 0.0 });
/// let limit = TableLimit { bytes: 4096, name: "storage buffer binding" };
/// let err = pack_within(&b.build().unwrap(), None, limit).unwrap_err();
/// // Refused at the texels (64 × 32 × 3 floats), before the sampling tables.
/// assert_eq!(err, PackError::TooLarge { table: Table::Floats, needed: 64 * 32 * 12, limit });
/// ```
pub fn pack_within(scene: &Scene, spp_override: Option<u32>, limit: TableLimit) -> Result<PackedScene, PackError> {
    scene.validate()?;
    pack_form(scene, spp_override, limit).map_err(|e| e.located_in(scene))
}

/// What [`pack`] refuses on any adapter (a shape, CSG leaf or mesh beyond f32's range in
/// the camera frame, a CSG tree beyond the span pool; or an invalid scene), found without
/// building the BVHs and tables that `pack` builds after the same checks: `lumen check`
/// reports it.
///
/// ```
/// use glam::DVec3;
/// use lumen::scene::*;
/// use lumen::gpu::pack::{check_packable, PackError};
/// let mut b = SceneBuilder::new(4, 3);
/// let m = b.diffuse(lumen::color::Color::gray(0.5));
/// b.sphere(Transform::scaling(DVec3::splat(1e39)), m);
/// let err = check_packable(&b.build().unwrap()).unwrap_err();
/// assert!(matches!(err, PackError::OutOfRange { shape: 0, what: "sphere", .. }), "{err}");
/// ```
pub fn check_packable(scene: &Scene) -> Result<(), PackError> {
    scene.validate()?;
    let form = crate::prepare::render_form(scene);
    let shifted = camera_frame(&form);
    refuse(&form, &FeatureSet::of(&form), &shifted).map_err(|e| e.located_in(scene))
}

/// The shapes of `scene` moved into the camera frame (as f64), where the GPU stores them.
fn camera_frame(scene: &Scene) -> Vec<Shape> {
    let shift = Transform::translation(-camera_origin(scene));
    scene.shapes.iter().map(|s| shifted_shape(s, &shift)).collect()
}

/// The refusals of [`check_packable`] in `scene`'s render form, whose features are
/// `features` and whose shapes in the camera frame are `shifted`.
fn refuse(scene: &Scene, features: &FeatureSet, shifted: &[Shape]) -> Result<(), PackError> {
    if features.csg {
        // The pool a render switched to the sweeps needs.
        let swept = FeatureSet { csg_sweeps: true, ..*features };
        let pool = usize::try_from(crate::gpu::wavefront::csg_pool_entries(&swept)).unwrap_or(usize::MAX);
        if pool > MAX_CSG_POOL {
            // The tree with the most leaves (the pool is sized by it).
            let shape = scene.shapes.iter().position(|s| {
                matches!(s, Shape::Csg(_))
                    && u32::try_from(s.leaf_count()).unwrap_or(u32::MAX) == features.csg_max_leaves
            });
            return Err(PackError::CsgTooLarge {
                shape: shape.unwrap_or(0),
                origin: None,
                part: None,
                leaves: features.csg_max_leaves as usize,
                entries: pool,
                limit: MAX_CSG_POOL,
            });
        }
    }
    let mut meshes = HashSet::new();
    for (i, s) in shifted.iter().enumerate() {
        let what = match s {
            Shape::Mesh(m) => {
                // Each distinct mesh in object space, as the GPU stores it (vertices and
                // texture coordinates; normals are unit vectors by then).
                if meshes.insert(Arc::as_ptr(&m.mesh) as usize) {
                    check_mesh_range(&m.name, "vertex coordinate", extent(m.mesh.bounds()))?;
                    let uv =
                        m.mesh.uvs().map_or(0.0, |uvs| uvs.iter().fold(0.0, |a, uv| uv.abs().max_element().max(a)));
                    check_mesh_range(&m.name, "texture coordinate", uv)?;
                }
                check_range(i, "mesh instance", &m.transform)?;
                check_mesh_range(
                    &m.name,
                    "vertex coordinate in the camera frame",
                    extent(m.mesh.bounds().transformed(&m.transform)),
                )?;
                "mesh instance"
            }
            Shape::Primitive(prim) => {
                check_range(i, prim.kind.name(), &prim.transform)?;
                if prim.kind == ShapeKind::Plane {
                    continue;
                }
                prim.kind.name()
            }
            Shape::Csg(_) => {
                check_leaves(i, s, &Transform::IDENTITY)?;
                continue;
            }
        };
        // The kernels test an unbounded-list entry that is not a CSG tree as a plane
        // (shaders/world.wgsl, nearer_unbounded). Nothing else has infinite bounds unless
        // its transform overflows f32 (refused above); refuse it here too rather than
        // render it wrongly.
        if crate::prepare::Placement::of(s) == crate::prepare::Placement::Unbounded {
            return Err(PackError::OutOfRange { shape: i, origin: None, part: None, what, magnitude: f64::INFINITY });
        }
    }
    Ok(())
}

/// [`check_range`] for every leaf of top-level CSG tree `top` (subtree `s`, under `parent`).
fn check_leaves(top: usize, s: &Shape, parent: &Transform) -> Result<(), PackError> {
    match s {
        Shape::Primitive(prim) => check_range(top, prim.kind.name(), &(*parent * prim.transform)),
        Shape::Csg(c) => c.children.iter().try_for_each(|ch| check_leaves(top, ch, &(*parent * c.transform))),
        // Scene::validate refuses a mesh operand.
        Shape::Mesh(_) => Ok(()),
    }
}

/// [`pack_within`] once the scene is valid; shapes are located in its render form.
fn pack_form(scene: &Scene, spp_override: Option<u32>, limit: TableLimit) -> Result<PackedScene, PackError> {
    let form = crate::prepare::render_form(scene);
    let scene = &*form;
    let features = FeatureSet::of(scene);
    let shifted = camera_frame(scene);
    // What no adapter takes, refused before the BVHs and tables are built (and not
    // checked again below).
    refuse(scene, &features, &shifted)?;
    let origin = camera_origin(scene);
    let shift = Transform::translation(-origin);
    let world = crate::prepare::SceneBvh::from_shapes(&shifted);
    let area_lights = scene.area_lights();
    let mut area_of_shape = vec![NONE; scene.shapes.len()];
    for (i, l) in area_lights.iter().enumerate() {
        area_of_shape[l.shape] = i as u32;
    }

    let mut p = PackedScene {
        features,
        settings: bytemuck::Zeroable::zeroed(),
        camera: bytemuck::Zeroable::zeroed(),
        environment: bytemuck::Zeroable::zeroed(),
        shapes: Vec::new(),
        indices: Vec::new(),
        bvh_nodes: quantized::quantize(world.bvh.nodes()),
        csg_trees: Vec::new(),
        materials: Vec::new(),
        pigments: Vec::new(),
        floats: Vec::new(),
        rows: Vec::new(),
        point_lights: Vec::new(),
        area_lights: Vec::new(),
        tri_positions: Vec::new(),
        tri_shading: Vec::new(),
        origin,
    };
    limit.room(Table::BvhNodes, &p.bvh_nodes, 0)?;
    let top_nodes = p.bvh_nodes.len();
    let mesh_roots = pack_meshes(&shifted, &mut p, limit)?;

    // Objects in scene order: a top-level primitive is one shape, a CSG tree one tree
    // record and its leaves (depth first).
    let mut object_ref = vec![0u32; shifted.len()];
    let mut csg_programs: Vec<CsgProgram> = Vec::new();
    for (i, s) in shifted.iter().enumerate() {
        object_ref[i] = match s {
            Shape::Mesh(m) => {
                let mut shape = packed_shape(ShapeKind::Cube, &m.transform, m.material.0, area_of_shape[i]);
                shape.kind = layout::shape_kind::MESH;
                let flags = if m.shades_smooth() { layout::mesh_bits::SMOOTH } else { 0 }
                    | if m.mesh.uvs().is_some() { layout::mesh_bits::UVS } else { 0 };
                shape.mesh = mesh_roots[&(std::sync::Arc::as_ptr(&m.mesh) as usize)].root | flags;
                p.shapes.push(shape);
                count_u32("shapes", p.shapes.len())? - 1
            }
            Shape::Primitive(prim) => {
                p.shapes.push(packed_shape(prim.kind, &prim.transform, prim.material.0, area_of_shape[i]));
                count_u32("shapes", p.shapes.len())? - 1
            }
            Shape::Csg(_) => pack_csg(s, &mut p, &mut csg_programs)? | layout::CSG_NODE_BIT,
        };
    }
    leaf_range_fits("objects in the BVH", world.bvh.prim_indices().len())?;
    p.indices.extend(world.bvh.prim_indices().iter().map(|&i| object_ref[i as usize]));
    let plane_offset = count_u32("indices", p.indices.len())?;
    p.indices.extend(world.unbounded.iter().map(|&i| object_ref[i as usize]));
    let plane_count = count_u32("infinite shapes", world.unbounded.len())?;
    // The lists the kernels may test unrolled, each entry under a constant reference.
    p.features.listed = Unrolled::of(&p.indices[..plane_offset as usize], &p.shapes);
    p.features.planes_listed = Unrolled::of(&p.indices[plane_offset as usize..], &p.shapes);
    for CsgProgram { tree, words, sweep } in csg_programs {
        p.csg_trees[tree].program = count_u32("indices", p.indices.len())?;
        p.indices.extend(words);
        if !sweep.is_empty() {
            let leaves = p.csg_trees[tree].leaf_count as usize;
            p.csg_trees[tree].sweep = count_u32("indices", p.indices.len())?;
            p.csg_trees[tree].node_count = count_u32("CSG nodes", (sweep.len() - leaves) / 2)?;
            p.indices.extend(sweep);
            count_u32("indices", p.indices.len())?;
        }
    }
    for l in &area_lights {
        let light = packed_area_light(scene, l.shape, object_ref[l.shape], origin, &mesh_roots, &mut p.floats, limit)?;
        p.area_lights.push(light);
    }

    // Appearance.
    let mut textures: HashMap<*const HdrImage, u32> = HashMap::new();
    for m in &scene.materials {
        let pigment = push_pigment(&mut p, &mut textures, m.brdf.pigment(), limit)?;
        let emitted = push_pigment(&mut p, &mut textures, &m.emitted, limit)?;
        let material = pack_material(&m.brdf, pigment, emitted, &mut p.rows);
        p.materials.push(material);
    }
    p.environment = pack_environment(scene, &mut p.floats, &mut textures, limit)?;

    for l in &scene.point_lights {
        let pos = l.position - origin;
        p.point_lights.push(layout::PointLight {
            position: [pos.x as f32, pos.y as f32, pos.z as f32, l.linear_radius as f32],
            color: rgba(l.color),
        });
    }

    let cam = &scene.camera;
    let (projection, screen_distance) = match cam.projection {
        Projection::Perspective { screen_distance } => (layout::projection_kind::PERSPECTIVE, screen_distance),
        Projection::Orthogonal => (layout::projection_kind::ORTHOGONAL, 0.0),
    };
    p.camera = layout::Camera {
        to_world: Affine::from_dmat4(&(shift * cam.transform).matrix()),
        projection,
        aspect_ratio: cam.aspect_ratio as f32,
        screen_distance: screen_distance as f32,
        _pad: 0,
    };

    let (ps, spp) = pixel_samples(scene, spp_override)?;
    let (jitter, samples_per_side) = match ps {
        PixelSamples::Centre => (layout::jitter_mode::CENTRE, 0),
        PixelSamples::Strata(s) => (layout::jitter_mode::STRATIFIED, s),
        PixelSamples::Jittered(_) => (layout::jitter_mode::WHOLE_PIXEL, 0),
    };
    let seed = scene.tracer.rng;
    let (renderer, color0, color1) = match &scene.renderer {
        Renderer::OnOff { on, off } => (layout::renderer_kind::ON_OFF, *on, *off),
        Renderer::Flat { background } => (layout::renderer_kind::FLAT, *background, Color::BLACK),
        Renderer::PointLight { background, ambient } => (layout::renderer_kind::POINT_LIGHT, *background, *ambient),
        Renderer::PathTracer(pt) => (layout::renderer_kind::PATH_TRACER, pt.background, Color::BLACK),
    };
    let (paths_per_sample, max_depth, roulette_depth, nee) = match &scene.renderer {
        Renderer::PathTracer(pt) => (pt.n, pt.max_depth, pt.roulette_depth, u32::from(pt.nee)),
        _ => (1, 0, 0, 0),
    };
    p.settings = layout::Settings {
        color0: rgba(color0),
        color1: rgba(color1),
        tracer_seed: seed.words(),
        width: scene.width,
        height: scene.height,
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
        strata_bits: ps.strata_bits(u64::from(paths_per_sample)),
        area_light_count: count_u32("area lights", area_lights.len())?,
        point_light_count: count_u32("point lights", scene.point_lights.len())?,
        bvh_node_count: count_u32("BVH nodes", top_nodes)?,
        strata_seed: crate::sampling::seed_word(seed),
        _pad1: 0,
        _pad2: 0,
        _pad3: 0,
    };
    Ok(p)
}

/// The rows of a single-scattering lobe: an albedo of 1 everywhere makes the kernels choose
/// single scattering with probability 1 and return nothing through the (zero-scaled)
/// compensating lobes, which is exactly the uncompensated BSDF.
const UNCOMPENSATED: [f64; CONDUCTOR_NODES] = [1.0; CONDUCTOR_NODES];

/// Appends each distinct mesh's bottom-level BVH to `bvh_nodes` (after the top-level ones)
/// and its triangles, in leaf order, to `tri_positions` and `tri_shading`, so that a leaf's
/// range indexes the triangles directly. Returns the root node of each mesh (by the
/// address of its `Arc`).
fn pack_meshes(
    shapes: &[Shape],
    p: &mut PackedScene,
    limit: TableLimit,
) -> Result<HashMap<usize, PackedMesh>, PackError> {
    let mut distinct = HashSet::new();
    let mut triangles = 0;
    for s in shapes {
        if let Shape::Mesh(m) = s {
            if distinct.insert(Arc::as_ptr(&m.mesh) as usize) {
                triangles += m.mesh.triangle_count();
            }
        }
    }
    // Each distinct mesh's triangles are stored once: refused here, before the BVHs are
    // built (seconds for millions of triangles), if they cannot fit. (Their normals and uvs
    // are not: on a software adapter the path tracer reads them from a texture, which
    // holds more than a storage binding; the upload checks them.)
    limit.room(Table::TriPositions, &p.tri_positions, triangles * layout::TRI_POSITION_VEC4S as usize)?;
    let bvhs = crate::prepare::MeshBvhs::of(shapes);
    let mut roots = HashMap::new();
    for mesh in &bvhs.meshes {
        let Some(bvh) = bvhs.get(mesh) else { continue };
        let node_base = count_u32("BVH nodes", p.bvh_nodes.len())?;
        let tri_base = count_u32("triangles", p.tri_positions.len() / layout::TRI_POSITION_VEC4S as usize)?;
        let nodes = quantized::quantize(bvh.nodes());
        if (node_base as usize + nodes.len()) > layout::mesh_bits::NODE_MASK as usize {
            return Err(PackError::TooMany {
                what: "BVH nodes (top level and meshes)",
                count: node_base as usize + nodes.len(),
                limit: layout::mesh_bits::NODE_MASK as usize,
            });
        }
        leaf_range_fits("triangles (all meshes)", tri_base as usize + bvh.prim_indices().len())?;
        limit.room(Table::BvhNodes, &p.bvh_nodes, nodes.len())?;
        p.bvh_nodes.extend(nodes.iter().map(|&n| n.moved(node_base, tri_base)));
        let mut leaf_of = vec![0u32; mesh.triangle_count()];
        for (k, &t) in bvh.prim_indices().iter().enumerate() {
            leaf_of[t as usize] = tri_base + k as u32;
        }
        let v4 = |v: glam::DVec3| [v.x as f32, v.y as f32, v.z as f32, 0.0];
        for &t in bvh.prim_indices() {
            let t = t as usize;
            let [i0, i1, i2] = mesh.triangles()[t].map(|i| i as usize);
            p.tri_positions.extend(mesh.triangle(t).map(v4));
            match mesh.normals() {
                Some(n) => p.tri_shading.extend([v4(n[i0]), v4(n[i1]), v4(n[i2])]),
                None => p.tri_shading.extend([[0.0; 4]; 3]),
            }
            let uv = |i: usize| mesh.uvs().map_or([0.0, 0.0], |uv| [uv[i].x as f32, uv[i].y as f32]);
            let (a, b, c) = (uv(i0), uv(i1), uv(i2));
            p.tri_shading.extend([[a[0], a[1], b[0], b[1]], [c[0], c[1], 0.0, 0.0]]);
        }
        count_u32("triangles", p.tri_positions.len() / layout::TRI_POSITION_VEC4S as usize)?;
        roots.insert(std::sync::Arc::as_ptr(mesh) as usize, PackedMesh { root: node_base, leaf_of });
    }
    Ok(roots)
}

/// Where a mesh went: its bottom-level root in `bvh_nodes`, and for each of its triangles
/// (file order) its index in `tri_positions`.
struct PackedMesh {
    root: u32,
    leaf_of: Vec<u32>,
}

/// A material's kind and constants. The microfacet kinds get what depends on their α and η
/// only, computed here in f64 once (the CPU reference computes the same per query through
/// the same functions): the compensation constants, and the energy tables' rows at the
/// material's α and η, appended to `rows`, so the kernel interpolates in μ alone.
fn pack_material(brdf: &Brdf, pigment: u32, emitted: u32, rows: &mut Vec<f32>) -> layout::Material {
    let mut m = layout::Material { pigment, emitted, ior: 1.0, rows: rows.len() as u32, ..Zeroable::zeroed() };
    // Generated on first use (a few tenths of a second), so only for the microfacet kinds.
    let tables = energy_tables;
    let mut push_row = |row: &[f64]| rows.extend(row.iter().map(|&v| v as f32));
    let three = |c: Color, w: f64| [c.r as f32, c.g as f32, c.b as f32, w as f32];
    m.brdf = layout::brdf_kind::of(brdf);
    match *brdf {
        Brdf::Diffuse { .. } | Brdf::Specular { .. } => {}
        Brdf::Dielectric { ior, roughness, multiple_scattering, .. } => {
            m.ior = ior as f32;
            if roughness != 0.0 {
                let alpha = alpha_of(roughness);
                m.alpha = alpha as f32;
                for eta in [ior, 1.0 / ior] {
                    let [r, t] = tables().dielectric_rows(alpha, eta);
                    let total: Vec<f64> = r.iter().zip(&t).map(|(r, t)| r + t).collect();
                    push_row(if multiple_scattering { &total } else { &UNCOMPENSATED[..DIELECTRIC_NODES] });
                }
                let side = |eta: f64| {
                    let l = dielectric_lobes(tables(), alpha, eta);
                    [l.k_t as f32, l.reflect as f32, l.transmit as f32, 0.0]
                };
                if multiple_scattering {
                    (m.lobe, m.lobe_back) = (side(ior), side(1.0 / ior));
                }
            }
        }
        Brdf::Conductor { roughness, fresnel, multiple_scattering, .. } => {
            if let Some((eta, k)) = fresnel {
                (m.eta, m.k) = (three(eta, 1.0), three(k, 0.0));
            }
            if roughness > 0.0 {
                let alpha = alpha_of(roughness);
                m.alpha = alpha as f32;
                if multiple_scattering {
                    push_row(&tables().conductor_row(alpha));
                    m.lobe = three(conductor_ms(tables(), alpha, fresnel), 0.0);
                } else {
                    push_row(&UNCOMPENSATED);
                }
            }
        }
        Brdf::Plastic { ior, roughness, .. } => {
            m.ior = ior as f32;
            let alpha = (roughness > 0.0).then(|| alpha_of(roughness));
            if let Some(a) = alpha {
                m.alpha = a as f32;
                push_row(&tables().dielectric_rows(a, ior)[0]);
            }
            let coat = plastic_coat(tables(), alpha, ior);
            m.lobe = [coat.internal as f32, coat.base as f32, 0.0, 0.0];
        }
    }
    m
}

/// Area light data as `cpu::area_light::AreaLight` computes it, in the camera frame.
///
/// A mesh light's triangle CDF (file order, as the CPU samples it) goes into `floats`,
/// followed by each triangle's index in `tri_positions` (as bits).
fn packed_area_light(
    scene: &Scene,
    shape: usize,
    shape_ref: u32,
    origin: DVec3,
    meshes: &HashMap<usize, PackedMesh>,
    floats: &mut Vec<f32>,
    limit: TableLimit,
) -> Result<layout::AreaLight, PackError> {
    let light = AreaLight::new(scene, shape)
        .ok_or_else(|| crate::scene::SceneError::Invalid(format!("shape {shape}: an emissive surface of zero area")))?;
    let (mut mesh_cdf, mut mesh_triangles) = (0, 0);
    if let (LightSurface::Mesh(m), Shape::Mesh(instance)) = (&light.surface, &scene.shapes[shape]) {
        let packed = &meshes[&(std::sync::Arc::as_ptr(&instance.mesh) as usize)];
        mesh_cdf = count_u32("floats", floats.len())?;
        mesh_triangles = count_u32("emissive triangles", m.cdf.len())?;
        limit.room(Table::Floats, floats, m.cdf.len() + packed.leaf_of.len())?;
        floats.extend(m.cdf.iter().map(|&c| c as f32));
        floats.extend(packed.leaf_of.iter().map(|&i| f32::from_bits(i)));
    }
    // Each kind fills its own fields; the others stay 0.
    let (mut sphere, mut det, mut area, mut face_areas, mut rectangular_faces) = ([0.0; 4], 0.0, 0.0, [0.0; 3], 0);
    match &light.surface {
        LightSurface::Sphere { round, det: d } => {
            if let Some((c, r)) = round {
                let c = *c - origin;
                sphere = [c.x as f32, c.y as f32, c.z as f32, *r as f32];
            }
            det = *d as f32;
        }
        LightSurface::Cube { face_areas: areas, rectangular_faces: rectangular } => {
            face_areas = areas.map(|a| a as f32);
            rectangular_faces = (0..3).filter(|&axis| rectangular[axis]).map(|axis| 1 << axis).sum();
        }
        LightSurface::Mesh(m) => area = m.area as f32,
    }
    Ok(layout::AreaLight {
        sphere,
        shape: shape_ref,
        det,
        area,
        mesh_cdf,
        face_areas,
        mesh_triangles,
        rectangular_faces,
        _pad0: 0,
        _pad1: 0,
        _pad2: 0,
    })
}

/// `s` with `shift` applied after its own transformation.
fn shifted_shape(s: &Shape, shift: &Transform) -> Shape {
    match s {
        Shape::Primitive(p) => Shape::primitive(p.kind, *shift * p.transform, p.material),
        Shape::Csg(c) => Shape::csg(c.op, c.children.clone(), *shift * c.transform),
        Shape::Mesh(m) => Shape::mesh(m.mesh.clone(), &m.name, *shift * m.transform, m.material, m.smooth),
    }
}

/// Refuses top-level shape `shape` when `to_world` (of it, or of a part called `what`), in
/// the camera frame, has an entry beyond f32's range. A shape too *small* for f32 (its
/// inverse overflows) is kept: its rays become non-finite in object space and miss, as they
/// would at the resolution f32 has for any coordinate it could be seen from.
fn check_range(shape: usize, what: &'static str, to_world: &Transform) -> Result<(), PackError> {
    let magnitude = to_world.matrix().to_cols_array().iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if magnitude > f64::from(f32::MAX) {
        return Err(PackError::OutOfRange { shape, origin: None, part: None, what, magnitude });
    }
    Ok(())
}

/// Refuses mesh `file` when a coordinate of `what` reaches `magnitude` beyond f32's range:
/// cast, it would be ±∞, and the triangles vanish or the textures go NaN without a word.
/// Checked once per distinct mesh in object space, as the GPU stores it (vertices and
/// texture coordinates; normals are unit vectors by then), and for each instance with its
/// vertices placed in the camera frame.
fn check_mesh_range(file: &str, what: &'static str, magnitude: f64) -> Result<(), PackError> {
    if magnitude > f64::from(f32::MAX) {
        return Err(PackError::MeshOutOfRange { file: file.to_string(), what, magnitude });
    }
    Ok(())
}

/// The largest |coordinate| of a box.
fn extent(b: crate::scene::Aabb) -> f64 {
    b.min.abs().max(b.max.abs()).max_element()
}

fn packed_shape(kind: ShapeKind, to_world: &Transform, material: u32, light: u32) -> layout::Shape {
    let kind = match kind {
        ShapeKind::Sphere => layout::shape_kind::SPHERE,
        ShapeKind::Plane => layout::shape_kind::PLANE,
        ShapeKind::Cube => layout::shape_kind::CUBE,
        ShapeKind::Cylinder => layout::shape_kind::CYLINDER,
    };
    layout::Shape {
        to_object: Affine::from_dmat4(&to_world.inverse_matrix()),
        to_world: Affine::from_dmat4(&to_world.matrix()),
        kind,
        material,
        light,
        mesh: 0,
    }
}

/// Packs top-level CSG tree `s` as one [`layout::CsgTree`]: its leaves as shapes, depth
/// first (so contiguous, in the order the CPU's `CsgTree::leaves` lists them), and its
/// structure as a program (`layout::csg_instr`), which `programs` collects to append to
/// `indices` later. Returns the tree's index.
fn pack_csg(s: &Shape, p: &mut PackedScene, programs: &mut Vec<CsgProgram>) -> Result<u32, PackError> {
    fn emit(s: &Shape, parent: &Transform, p: &mut PackedScene, code: &mut Vec<u32>) -> Result<(), PackError> {
        match s {
            Shape::Mesh(_) => {
                return Err(PackError::Scene(crate::scene::SceneError::Invalid(
                    "a mesh cannot be a CSG operand".into(),
                )))
            }
            Shape::Primitive(prim) => {
                let to_world = *parent * prim.transform;
                p.shapes.push(packed_shape(prim.kind, &to_world, prim.material.0, NONE));
                count_u32("shapes", p.shapes.len())?;
                code.push(layout::csg_instr::LEAF);
            }
            Shape::Csg(c) => {
                let op = match c.op {
                    CsgOp::Unite => layout::csg_op::UNITE,
                    CsgOp::Intersect => layout::csg_op::INTERSECT,
                    CsgOp::Diff => layout::csg_op::DIFF,
                    CsgOp::Fuse => layout::csg_op::FUSE,
                };
                code.push(layout::csg_instr::BEGIN + op);
                let t = *parent * c.transform;
                for ch in &c.children {
                    emit(ch, &t, p, code)?;
                }
                code.push(layout::csg_instr::END);
            }
        }
        Ok(())
    }
    let first_leaf = count_u32("shapes", p.shapes.len())?;
    let mut code = Vec::new();
    emit(s, &Transform::IDENTITY, p, &mut code)?;
    let per_word = layout::csg_instr::PER_WORD as usize;
    let words = code
        .chunks(per_word)
        .map(|chunk| chunk.iter().enumerate().fold(0u32, |w, (k, &i)| w | i << (k as u32 * layout::csg_instr::BITS)))
        .collect();
    let bounds = crate::accel::BvhNode::from_bounds(&s.bounds());
    p.csg_trees.push(layout::CsgTree {
        min: bounds.min,
        program: 0,
        max: bounds.max,
        length: count_u32("CSG program instructions", code.len())?,
        first_leaf,
        leaf_count: count_u32("shapes", p.shapes.len())? - first_leaf,
        sweep: 0,
        node_count: 0,
    });
    let tree = count_u32("CSG trees", p.csg_trees.len())? - 1;
    let sweep = if p.csg_trees[tree as usize].leaf_count > layout::csg_sweep::MIN_LEAVES {
        sweep_table(&code)
    } else {
        Vec::new()
    };
    programs.push(CsgProgram { tree: tree as usize, words, sweep });
    Ok(tree)
}

/// A packed tree's program words and sweep table (empty if it has none), to append to
/// `indices` after the BVH's and the plane list's entries.
struct CsgProgram {
    tree: usize,
    words: Vec<u32>,
    sweep: Vec<u32>,
}

/// The sweep table (`layout::csg_sweep`) of the tree whose program is `code`: for each node
/// in program order its parent and its operation, place and child count, then each leaf's
/// node.
fn sweep_table(code: &[u32]) -> Vec<u32> {
    use layout::csg_sweep::{CHILDREN_SHIFT, FIRST_CHILD, NO_PARENT};
    // Per node: parent, flags; the open nodes' numbers.
    let mut nodes: Vec<[u32; 2]> = Vec::new();
    let mut leaf_node = Vec::new();
    let mut open: Vec<u32> = Vec::new();
    for &instr in code {
        if instr == layout::csg_instr::END {
            open.pop();
            continue;
        }
        let k = nodes.len() as u32;
        let parent = open.last().copied().unwrap_or(NO_PARENT);
        let mut flags = 0;
        if parent != NO_PARENT {
            let siblings = &mut nodes[parent as usize][1];
            if *siblings >> CHILDREN_SHIFT == 0 {
                flags |= FIRST_CHILD;
            }
            *siblings += 1 << CHILDREN_SHIFT;
        }
        if instr == layout::csg_instr::LEAF {
            leaf_node.push(k);
        } else {
            flags |= instr - layout::csg_instr::BEGIN;
            open.push(k);
        }
        nodes.push([parent, flags]);
    }
    nodes.into_iter().flatten().chain(leaf_node).collect()
}

/// Appends an image's texels (rgb triples, row 0 first) once per image; returns the offset.
fn push_texels(
    floats: &mut Vec<f32>,
    textures: &mut HashMap<*const HdrImage, u32>,
    image: &Arc<HdrImage>,
    limit: TableLimit,
) -> Result<u32, PackError> {
    if let Some(&o) = textures.get(&Arc::as_ptr(image)) {
        return Ok(o);
    }
    limit.room(Table::Floats, floats, 3 * image.pixels().len())?;
    let offset = count_u32("texel floats", floats.len())?;
    for px in image.pixels() {
        floats.extend([px.r, px.g, px.b]);
    }
    count_u32("texel floats", floats.len())?;
    textures.insert(Arc::as_ptr(image), offset);
    Ok(offset)
}

fn push_pigment(
    p: &mut PackedScene,
    textures: &mut HashMap<*const HdrImage, u32>,
    pigment: &Pigment,
    limit: TableLimit,
) -> Result<u32, PackError> {
    let mut out = layout::Pigment {
        a: [0.0; 4],
        b: [0.0; 4],
        kind: layout::pigment_kind::UNIFORM,
        n: 0,
        image_filter: 0,
        tex_offset: 0,
        tex_width: 0,
        tex_height: 0,
        _pad0: 0,
        _pad1: 0,
    };
    match pigment {
        Pigment::Uniform(c) => out.a = rgba(*c),
        Pigment::Checkered { n, on, off } => {
            out.kind = layout::pigment_kind::CHECKERED;
            out.n = *n;
            out.a = rgba(*on);
            out.b = rgba(*off);
        }
        Pigment::Image { image, filter } => {
            out.kind = layout::pigment_kind::IMAGE;
            out.image_filter = match filter {
                crate::scene::ImageFilter::Nearest => layout::image_filter_kind::NEAREST,
                crate::scene::ImageFilter::Bilinear => layout::image_filter_kind::BILINEAR,
            };
            out.tex_offset = push_texels(&mut p.floats, textures, image, limit)?;
            out.tex_width = image.width() as u32;
            out.tex_height = image.height() as u32;
        }
    }
    p.pigments.push(out);
    Ok(count_u32("pigments", p.pigments.len())? - 1)
}

/// The environment (a uniform one of the background colour when the scene has none), with
/// an image's texels and importance-sampling tables appended to `floats`.
///
/// The importance-sampling tables at `dist_offset` are `Distribution2D::packed`, in its
/// layout (`sampling::distribution::packed`).
fn pack_environment(
    scene: &Scene,
    floats: &mut Vec<f32>,
    textures: &mut HashMap<*const HdrImage, u32>,
    limit: TableLimit,
) -> Result<layout::Environment, PackError> {
    let mut e = layout::Environment {
        a: [0.0; 4],
        b: [0.0; 4],
        c: [0.0; 4],
        kind: layout::environment_kind::UNIFORM,
        tex_width: 0,
        tex_height: 0,
        tex_offset: 0,
        intensity: 1.0,
        rotation_rad: 0.0,
        dist_offset: 0,
        is_light: u32::from(crate::prepare::escape_light(scene).is_some()),
    };
    match &scene.environment {
        None => e.a = rgba(scene.renderer.background()),
        Some(Environment::Uniform(c)) => e.a = rgba(*c),
        Some(Environment::Gradient { zenith, horizon, nadir }) => {
            e.kind = layout::environment_kind::GRADIENT;
            e.a = rgba(*zenith);
            e.b = rgba(*horizon);
            e.c = rgba(*nadir);
        }
        Some(Environment::Image { image, intensity, rotation_deg }) => {
            e.kind = layout::environment_kind::IMAGE;
            e.tex_offset = push_texels(floats, textures, image, limit)?;
            e.tex_width = image.width() as u32;
            e.tex_height = image.height() as u32;
            e.intensity = *intensity as f32;
            e.rotation_rad = rotation_deg.to_radians() as f32;
            e.dist_offset = count_u32("environment floats", floats.len())?;
            // The tables' length, known before building them.
            let tables = Distribution2D::packed_len(image.width(), image.height());
            limit.room(Table::Floats, floats, tables)?;
            floats.reserve(tables);
            floats.extend(image_distribution(image).packed().map(|v| v as f32));
            debug_assert_eq!(floats.len() - e.dist_offset as usize, tables);
            count_u32("environment floats", floats.len())?;
        }
    }
    Ok(e)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::color::Color;
    use crate::scene::{CsgOp, SceneBuilder};

    fn sphere_at(x: f64, m: crate::scene::MaterialId) -> Shape {
        Shape::primitive(ShapeKind::Sphere, Transform::translation(DVec3::new(x, 0.0, 0.0)), m)
    }

    /// The sweep table of DIFF(a, UNITE(b, c), d), written out by hand: nodes in program
    /// order (DIFF, a, UNITE, b, c, d) with parent and operation | first child | children,
    /// then each leaf's node. Only trees of more than 64 leaves get one.
    #[test]
    fn sweep_tables_list_parents_places_and_leaf_nodes() {
        use layout::csg_instr::{BEGIN, END, LEAF};
        use layout::csg_op::{DIFF, UNITE};
        use layout::csg_sweep::{CHILDREN_SHIFT as C, FIRST_CHILD as F, NO_PARENT};
        let code = [BEGIN + DIFF, LEAF, BEGIN + UNITE, LEAF, LEAF, END, LEAF, END];
        #[rustfmt::skip]
        let expected = [
            NO_PARENT, DIFF | 3 << C, // the DIFF: root, three children
            0, F,                     // a: its first child
            0, UNITE | 2 << C,        // the UNITE: second child, two children
            2, F,                     // b
            2, 0,                     // c
            0, 0,                     // d
            1, 3, 4, 5,               // the leaves' nodes
        ];
        assert_eq!(sweep_table(&code), expected);

        let mut b = SceneBuilder::new(4, 4);
        let m = b.diffuse(Color::gray(0.5));
        let fuse =
            |n: u32| Shape::csg(CsgOp::Fuse, (0..n).map(|i| sphere_at(f64::from(i), m)).collect(), Transform::IDENTITY);
        b.shape(fuse(64)).shape(fuse(65));
        let p = pack(&b.build().unwrap(), None).unwrap();
        let (small, large) = (p.csg_trees[0], p.csg_trees[1]);
        assert_eq!((small.sweep, small.node_count), (0, 0));
        assert_eq!(large.node_count, 66);
        let table = &p.indices[large.sweep as usize..];
        assert_eq!(table[..4], [NO_PARENT, layout::csg_op::FUSE | 65 << C, 0, F]);
        assert_eq!(table[2 * 66..2 * 66 + 65], (1..66).collect::<Vec<u32>>());
        assert_eq!(p.indices.len(), large.sweep as usize + 2 * 66 + 65);
    }

    #[test]
    fn objects_reference_shapes_and_csg_trees_in_the_camera_frame() {
        let mut b = SceneBuilder::new(4, 4);
        let m = b.diffuse(Color::gray(0.5));
        let n = b.diffuse(Color::gray(0.25));
        let tree =
            Shape::csg(CsgOp::Diff, vec![sphere_at(0.0, m), sphere_at(0.5, n)], Transform::translation(DVec3::Z));
        b.sphere(Transform::translation(DVec3::new(5.0, 0.0, 0.0)), m)
            .shape(tree)
            .plane(Transform::IDENTITY, n)
            .camera(crate::scene::Camera {
                transform: Transform::translation(DVec3::new(0.0, 0.0, 2.0)),
                ..Default::default()
            });
        let p = pack(&b.build().unwrap(), None).unwrap();
        // Eye at (−1, 0, 2): everything is shifted by (1, 0, −2).
        assert_eq!(p.origin, DVec3::new(-1.0, 0.0, 2.0));
        assert_eq!(p.shapes.len(), 4);
        assert_eq!(p.shapes[0].to_world.r0[3], 6.0);
        assert_eq!(p.shapes[0].to_object.r0[3], -6.0);
        // CSG leaves carry the node's transformation and their materials.
        assert_eq!((p.shapes[1].to_world.r0[3], p.shapes[1].to_world.r2[3]), (1.0, -1.0));
        assert_eq!((p.shapes[2].to_world.r0[3], p.shapes[2].material), (1.5, 1));
        assert_eq!(p.csg_trees.len(), 1);
        let tree = p.csg_trees[0];
        assert_eq!((tree.first_leaf, tree.leaf_count, tree.length), (1, 2, 4));
        // BEGIN DIFF, LEAF, LEAF, END, four bits each from the low end.
        let begin = layout::csg_instr::BEGIN + layout::csg_op::DIFF;
        assert_eq!(p.indices[tree.program as usize], begin | layout::csg_instr::END << 12);
        // Two finite objects in the BVH, the plane in the unbounded list.
        let bvh_refs: Vec<u32> = p.indices[..p.settings.plane_offset as usize].to_vec();
        assert_eq!(bvh_refs.len(), 2);
        assert!(bvh_refs.contains(&0) && bvh_refs.contains(&layout::CSG_NODE_BIT));
        assert_eq!(p.settings.plane_count, 1);
        assert_eq!(p.indices[p.settings.plane_offset as usize], 3);
        // Each material pushes its BRDF pigment, then its emission.
        assert_eq!((p.materials[1].pigment, p.materials[1].emitted), (2, 3));
    }

    #[test]
    fn a_csg_tree_too_wide_for_the_span_pool_is_a_clear_error() {
        let mut b = SceneBuilder::new(4, 4);
        let m = b.diffuse(Color::gray(0.5));
        // A FUSE of n spheres needs 3n + n + 1 pool entries: 140,000 is past the limit (a
        // top-level UNITE would be stored as its spheres).
        let many = (0..140_000).map(|i| sphere_at(f64::from(i) * 0.1, m)).collect();
        b.shape(Shape::csg(CsgOp::Fuse, many, Transform::IDENTITY));
        let scene = b.build().unwrap();
        let err = pack(&scene, None).unwrap_err();
        assert_eq!(check_packable(&scene), Err(err.clone()), "lumen check's pre-pass finds the same");
        let want = PackError::CsgTooLarge {
            shape: 0,
            origin: None,
            part: None,
            leaves: 140_000,
            entries: 560_001,
            limit: MAX_CSG_POOL,
        };
        assert_eq!(err, want);
        let text = err.to_string();
        assert!(
            text.starts_with("shape 1 in spawn order (a CSG tree of 140000 leaves): ")
                && text.contains("about 104857 leaves"),
            "{text}"
        );
    }

    /// Microfacet materials get their kind, α and rows of the energy tables at their α and
    /// η, which read back the tables' own lookups; smooth ones get no rows.
    #[test]
    fn microfacet_materials_carry_their_table_rows() {
        use crate::optics::energy_tables::{row_value, CONDUCTOR_NODES, DIELECTRIC_NODES};
        let white = crate::scene::Pigment::Uniform(Color::WHITE);
        let fresnel = Some((Color::new(0.2, 0.9, 1.1), Color::new(3.9, 2.4, 1.6)));
        let brdfs = [
            Brdf::Conductor { pigment: white.clone(), roughness: 0.0, fresnel: None, multiple_scattering: true },
            Brdf::Conductor { pigment: white.clone(), roughness: 0.3, fresnel, multiple_scattering: true },
            Brdf::Dielectric { pigment: white.clone(), ior: 1.5, roughness: 0.2, multiple_scattering: true },
            Brdf::Plastic { pigment: white.clone(), ior: 1.4, roughness: 0.1 },
            Brdf::Plastic { pigment: white.clone(), ior: 1.4, roughness: 0.0 },
            Brdf::smooth_dielectric(white.clone(), 1.5),
        ];
        let mut b = SceneBuilder::new(4, 4);
        for brdf in &brdfs {
            let m = b.material(crate::scene::Material::new(brdf.clone(), crate::scene::Pigment::Uniform(Color::BLACK)));
            b.sphere(Transform::IDENTITY, m);
        }
        let p = pack(&b.build().unwrap(), None).unwrap();
        let kinds: Vec<u32> = p.materials.iter().map(|m| m.brdf).collect();
        use layout::brdf_kind::*;
        assert_eq!(kinds, [CONDUCTOR, CONDUCTOR, ROUGH_DIELECTRIC, PLASTIC, PLASTIC, DIELECTRIC]);
        let rows = |i: usize, n: usize| {
            let start = p.materials[i].rows as usize;
            p.rows[start..start + n].iter().map(|&v| f64::from(v)).collect::<Vec<f64>>()
        };
        let t = energy_tables();
        let (m0, m1) = (p.materials[0], p.materials[1]);
        assert_eq!((m0.alpha, m0.eta[3], m1.alpha, m1.eta[3]), (0.0, 0.0, 0.3, 1.0));
        // Rows are stored back to back: smooth materials add none.
        assert_eq!(m1.rows, m0.rows);
        assert_eq!(p.materials[2].rows as usize, m1.rows as usize + CONDUCTOR_NODES);
        assert_eq!(p.materials[3].rows as usize, p.materials[2].rows as usize + 2 * DIELECTRIC_NODES);
        for mu in [0.05, 0.5, 0.9] {
            let close = |a: f64, b: f64| (a - b).abs() < 1e-6;
            assert!(close(row_value(&rows(1, CONDUCTOR_NODES), mu), t.conductor_albedo(mu, 0.3)));
            let [r, tr] = t.dielectric_albedo(mu, 0.2, 1.0 / 1.5);
            let leaving = rows(2, 2 * DIELECTRIC_NODES)[DIELECTRIC_NODES..].to_vec();
            assert!(close(row_value(&leaving, mu), r + tr));
            assert!(close(row_value(&rows(3, DIELECTRIC_NODES), mu), t.dielectric_albedo(mu, 0.1, 1.4)[0]));
        }
        let lobes = dielectric_lobes(t, 0.2, 1.0 / 1.5);
        assert_eq!(p.materials[2].lobe_back[0], lobes.k_t as f32);
    }

    #[test]
    fn a_shape_beyond_f32_range_is_a_clear_error() {
        let mut b = SceneBuilder::new(4, 4);
        let m = b.diffuse(Color::gray(0.5));
        b.sphere(Transform::scaling(DVec3::splat(1e30)), m).sphere(Transform::scaling(DVec3::splat(1e-300)), m);
        assert!(pack(&b.build().unwrap(), None).is_ok(), "1e30 fits f32; 1e-300 is kept (and never hit)");
        let huge = Transform::scaling(DVec3::splat(1e300));
        b.shape(Shape::csg(CsgOp::Fuse, vec![sphere_at(0.0, m), Shape::primitive(ShapeKind::Cube, huge, m)], huge));
        let scene = b.build().unwrap();
        let err = pack(&scene, None).unwrap_err();
        assert_eq!(check_packable(&scene), Err(err.clone()));
        assert!(matches!(err, PackError::OutOfRange { shape: 2, part: None, what: "sphere", .. }), "{err}");
        assert!(err.to_string().starts_with("shape 3 in spawn order (sphere): "), "{err}");
        assert!(err.to_string().contains("beyond f32's range"), "{err}");
        // Located in the script's shapes: a top-level UNITE (split for rendering) is one
        // shape, and the message names the part.
        let mut b = SceneBuilder::new(4, 4);
        let m = b.diffuse(Color::gray(0.5));
        let far = Shape::primitive(ShapeKind::Cube, Transform::scaling(DVec3::splat(1e39)), m);
        b.shape(Shape::csg(CsgOp::Unite, vec![sphere_at(0.0, m), sphere_at(3.0, m)], Transform::IDENTITY))
            .shape(Shape::csg(CsgOp::Unite, vec![sphere_at(6.0, m), far], Transform::IDENTITY));
        let scene = b.build().unwrap();
        let err = pack(&scene, None).unwrap_err();
        assert_eq!(check_packable(&scene), Err(err.clone()));
        assert!(matches!(err, PackError::OutOfRange { shape: 1, part: Some(1), what: "cube", .. }), "{err}");
        assert!(err.to_string().starts_with("shape 2 in spawn order, part 2 of its top-level UNITE (cube)"), "{err}");
    }

    #[test]
    fn a_mesh_beyond_f32_range_is_a_clear_error() {
        use crate::scene::mesh::{MeshParts, TriangleMesh};
        use glam::DVec2;
        // One triangle whose second vertex or texture coordinate, or that vertex placed by
        // the instance, is finite in f64 (so the file loads) but ±∞ as f32 (found while
        // writing tests/fuzz_cli.rs's mesh files: the GPU drew the scene without it).
        let scene = |vertex: f64, uv: f64, scale: f64| {
            let parts = MeshParts {
                positions: vec![DVec3::ZERO, DVec3::new(vertex, 0.0, 1.0), DVec3::Y],
                uvs: Some(vec![DVec2::ZERO, DVec2::new(uv, 0.0), DVec2::Y]),
                triangles: vec![[0, 1, 2]],
                ..MeshParts::default()
            };
            let mesh = std::sync::Arc::new(TriangleMesh::from_parts("far.obj", parts).unwrap());
            let mut b = SceneBuilder::new(4, 4);
            let m = b.diffuse(Color::gray(0.5));
            let placed = Transform::scaling(DVec3::splat(scale));
            b.sphere(Transform::IDENTITY, m).shape(Shape::mesh(mesh, "far.obj", placed, m, false));
            b.build().unwrap()
        };
        assert!(pack(&scene(3e38, -3e38, 1.0), None).is_ok(), "3e38 fits f32");
        assert_eq!(check_packable(&scene(3e38, -3e38, 1.0)), Ok(()));
        let cases = [
            (1e39, 0.5, 1.0, "vertex coordinate"),
            (1.0, -1e39, 1.0, "texture coordinate"),
            (1e29, 0.5, 1e10, "vertex coordinate in the camera frame"),
        ];
        for (vertex, uv, scale, what) in cases {
            let err = pack(&scene(vertex, uv, scale), None).unwrap_err();
            assert_eq!(check_packable(&scene(vertex, uv, scale)), Err(err.clone()));
            assert!(matches!(&err, PackError::MeshOutOfRange { file, what: w, .. } if file == "far.obj" && *w == what));
            assert!(
                err.to_string().starts_with(&format!("mesh far.obj: a {what} reaches 1e39, beyond f32's")),
                "{err}"
            );
        }
    }

    #[test]
    fn a_mesh_beyond_the_binding_size_is_refused_by_its_triangle_count() {
        use crate::scene::mesh::{MeshParts, TriangleMesh};
        let parts = MeshParts {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z],
            triangles: vec![[0, 1, 2], [0, 1, 3], [0, 2, 3]],
            ..MeshParts::default()
        };
        let mesh = std::sync::Arc::new(TriangleMesh::from_parts("three.obj", parts).unwrap());
        let mut b = SceneBuilder::new(4, 4);
        let m = b.diffuse(Color::gray(0.5));
        // Two instances of one mesh store its triangles once.
        for x in [0.0, 2.0] {
            let placed = Transform::translation(DVec3::new(x, 5.0, 0.0));
            b.shape(Shape::mesh(mesh.clone(), "three.obj", placed, m, false));
        }
        let scene = b.build().unwrap();
        let positions = 3 * layout::TRI_POSITION_VEC4S as u64 * 16;
        let shading = 3 * layout::TRI_SHADING_VEC4S as u64 * 16;
        let fits = TableLimit { bytes: positions.max(shading) + 4096, name: "storage buffer binding" };
        let p = pack_within(&scene, None, fits).unwrap();
        assert_eq!(p.tri_positions.len() as u64 * 16, positions);
        let limit = TableLimit { bytes: positions - 1, ..fits };
        let err = pack_within(&scene, None, limit).unwrap_err();
        assert_eq!(err, PackError::TooLarge { table: Table::TriPositions, needed: positions, limit });
        let text = format!("the tri_positions table (mesh triangles' vertices) needs {positions} bytes but");
        assert!(err.to_string().starts_with(&text), "{err}");
    }

    #[test]
    fn a_handful_of_plain_objects_is_listed_and_padding_keeps_bindings_nonempty() {
        let mut b = SceneBuilder::new(4, 4);
        let m = b.diffuse(Color::gray(0.5));
        for i in 0..8 {
            b.shape(sphere_at(f64::from(i) * 3.0, m));
        }
        b.plane(Transform::IDENTITY, m);
        let eight = pack(&b.build().unwrap(), None).unwrap();
        assert!(eight.features.object_list && eight.settings.plane_offset == 8);
        b.shape(sphere_at(30.0, m));
        let p = pack(&b.build().unwrap(), None).unwrap();
        assert!(!p.features.object_list && p.settings.plane_offset == 9);
        // Padding: empty data becomes one zeroed element, other data is untouched.
        use crate::gpu::tables::{storage_contents, Table};
        assert_eq!(storage_contents(Table::PointLights, &p).len(), std::mem::size_of::<layout::PointLight>());
        assert_eq!(storage_contents(Table::Indices, &p).as_ref(), bytemuck::cast_slice::<u32, u8>(&p.indices));
    }

    /// The list's object count is the BVH's: a CSG tree with an unbounded solid is tested
    /// with the planes and one with an empty solid nowhere, so eight spheres beside them are
    /// still a list.
    #[test]
    fn only_the_objects_of_the_bvh_count_towards_a_list() {
        let mut b = SceneBuilder::new(4, 4);
        let m = b.diffuse(Color::gray(0.5));
        for i in 0..8 {
            b.shape(sphere_at(f64::from(i) * 3.0, m));
        }
        let plane = Shape::primitive(ShapeKind::Plane, Transform::IDENTITY, m);
        b.shape(Shape::csg(CsgOp::Diff, vec![plane, sphere_at(0.0, m)], Transform::IDENTITY));
        b.shape(Shape::csg(CsgOp::Intersect, vec![sphere_at(50.0, m), sphere_at(60.0, m)], Transform::IDENTITY));
        let p = pack(&b.build().unwrap(), None).unwrap();
        assert_eq!((p.settings.plane_offset, p.settings.plane_count), (8, 1));
        assert!(p.features.object_list);
    }
}
