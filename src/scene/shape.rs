//! Shapes: unit primitives placed by a transformation, CSG trees of them, and triangle
//! meshes.

use std::sync::Arc;

use glam::DVec3;

use super::{Aabb, MaterialId, Transform, TriangleMesh};

/// The four unit primitives of SceneLang (see SCENELANG.md for their extents and uv).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ShapeKind {
    /// Radius 1 at the origin.
    Sphere,
    /// z = 0 with normal +z; the half-space z ≤ 0 inside CSG.
    Plane,
    /// [−0.5, 0.5]³.
    Cube,
    /// Axis z, radius 0.5, z ∈ [−0.5, 0.5], capped.
    Cylinder,
}

impl ShapeKind {
    /// Every kind, in declaration order (the order of `lumen check`'s primitive counts).
    pub const ALL: [ShapeKind; 4] = [ShapeKind::Sphere, ShapeKind::Plane, ShapeKind::Cube, ShapeKind::Cylinder];

    /// Lower-case name for messages and `lumen check`: `sphere`, `plane`, `cube`, `cylinder`.
    pub fn name(self) -> &'static str {
        match self {
            ShapeKind::Sphere => "sphere",
            ShapeKind::Plane => "plane",
            ShapeKind::Cube => "cube",
            ShapeKind::Cylinder => "cylinder",
        }
    }

    /// Object-space bounds. The plane's is the infinite slab z = 0 (its CSG half-space
    /// is unbounded below; see [`Shape::bounds`]).
    pub fn object_bounds(self) -> Aabb {
        match self {
            ShapeKind::Sphere => Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0)),
            ShapeKind::Plane => Aabb::new(
                DVec3::new(f64::NEG_INFINITY, f64::NEG_INFINITY, 0.0),
                DVec3::new(f64::INFINITY, f64::INFINITY, 0.0),
            ),
            ShapeKind::Cube | ShapeKind::Cylinder => Aabb::new(DVec3::splat(-0.5), DVec3::splat(0.5)),
        }
    }

    /// Bounds of the solid (the region "inside" for CSG).
    pub fn solid_bounds(self) -> Aabb {
        match self {
            ShapeKind::Plane => {
                Aabb::new(DVec3::splat(f64::NEG_INFINITY), DVec3::new(f64::INFINITY, f64::INFINITY, 0.0))
            }
            k => k.object_bounds(),
        }
    }
}

/// Most primitives a scene may expand to, CSG leaves counted once per use (a name used
/// twice in a CSG counts twice: the renderers get the expanded tree). At 2²¹ primitives
/// `lumen check` takes about 1.7 GB and a CPU render 2.5 GB (measured on one 2²¹-leaf
/// INTERSECT); scripts beyond it are refused at load time.
pub const MAX_PRIMITIVES: u64 = 1 << 21;

/// Deepest CSG tree (a CSG node over primitives is depth 1). Names let a script nest CSG
/// without limit, while every consumer of the tree (bounds, the CPU's evaluation, the GPU's
/// packing) walks it recursively and the GPU sizes its stacks by the depth.
pub const MAX_CSG_DEPTH: usize = 256;

/// One placed unit primitive.
#[derive(Debug, Clone, PartialEq)]
pub struct Primitive {
    /// Which unit shape is placed.
    pub kind: ShapeKind,
    /// Object to world.
    pub transform: Transform,
    /// Material of its surface, including the parts of it that carve another CSG operand.
    pub material: MaterialId,
}

/// CSG operations, with POV-Ray's semantics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum CsgOp {
    /// Union keeping every surface (POV-Ray `union`): inner surfaces stay visible through
    /// transparent materials.
    Unite,
    /// Points inside every child (POV-Ray `intersection`).
    Intersect,
    /// Points inside the first child and outside all the others (POV-Ray `difference`).
    Diff,
    /// Union without the inner surfaces (POV-Ray `merge`).
    Fuse,
}

impl CsgOp {
    /// The SceneLang command (`UNITE`, `INTERSECT`, `DIFF`, `FUSE`), for DUMP and messages.
    pub fn keyword(self) -> &'static str {
        match self {
            CsgOp::Unite => "UNITE",
            CsgOp::Intersect => "INTERSECT",
            CsgOp::Diff => "DIFF",
            CsgOp::Fuse => "FUSE",
        }
    }
}

/// A CSG node: an operation over two or more children, placed by its own transformation
/// (applied after the children's own).
#[derive(Debug, Clone, PartialEq)]
pub struct Csg {
    /// How the children combine.
    pub op: CsgOp,
    /// The operands, in script order (DIFF keeps the first and removes the rest), each
    /// placed by its own transformation in the node's space; never meshes in a valid scene.
    pub children: Vec<Shape>,
    /// Node to parent space (to world for a top-level node).
    pub transform: Transform,
}

/// A triangle mesh placed in the world (ext `Shape.Mesh`). Every instance of one file
/// shares the file's `Arc` (loaded and stored once; the renderers build one bottom-level
/// BVH per distinct mesh); only the transformation differs. One material per mesh; meshes
/// are not CSG operands.
#[derive(Clone, PartialEq)]
pub struct MeshInstance {
    /// The file's triangles, in object space; the same `Arc` for every use of the file.
    pub mesh: Arc<TriangleMesh>,
    /// The file as the script named it, for messages and `lumen check`.
    pub name: Arc<str>,
    /// Object to world.
    pub transform: Transform,
    /// The material of every triangle.
    pub material: MaterialId,
    /// Interpolate the file's vertex normals (flat facets when false or when the file has
    /// none).
    pub smooth: bool,
}

impl MeshInstance {
    /// Whether shading uses interpolated vertex normals.
    pub fn shades_smooth(&self) -> bool {
        self.smooth && self.mesh.normals().is_some()
    }
}

/// Triangles are summarised: a scene's Debug text (which `lumen merge` fingerprints hash)
/// would otherwise hold every vertex.
impl std::fmt::Debug for MeshInstance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MeshInstance")
            .field("name", &self.name)
            .field("triangles", &self.mesh.triangle_count())
            .field("vertices", &self.mesh.vertex_count())
            .field("transform", &self.transform)
            .field("material", &self.material)
            .field("smooth", &self.smooth)
            .finish()
    }
}

/// Anything that can be spawned into the world.
///
/// Primitives are stored inline (they are the common case, and scenes of 100k spheres
/// should not pay an allocation each); CSG nodes and meshes are boxed to keep the enum small.
#[derive(Debug, Clone, PartialEq)]
#[allow(clippy::large_enum_variant)]
pub enum Shape {
    /// One placed unit primitive.
    Primitive(Primitive),
    /// A CSG node over its children.
    Csg(Box<Csg>),
    /// A placed triangle mesh.
    Mesh(Box<MeshInstance>),
}

/// A UNITE without meshes: [`Shape::top_level_parts`] splits it.
fn unite_splits(c: &Csg) -> bool {
    c.op == CsgOp::Unite && !c.children.iter().any(Shape::holds_mesh)
}

impl Shape {
    /// The unit primitive `kind` placed by `transform` (object to world), made of `material`.
    pub fn primitive(kind: ShapeKind, transform: Transform, material: MaterialId) -> Self {
        Shape::Primitive(Primitive { kind, transform, material })
    }

    /// A CSG node applying `op` to `children`, placed by `transform`. Nothing is checked
    /// here: SceneLang enforces [`MAX_CSG_DEPTH`] and [`MAX_PRIMITIVES`], and
    /// [`crate::scene::Scene::validate`] refuses mesh operands.
    pub fn csg(op: CsgOp, children: Vec<Shape>, transform: Transform) -> Self {
        Shape::Csg(Box::new(Csg { op, children, transform }))
    }

    /// An instance of `mesh` placed by `transform`, made of `material`; `name` is the file as
    /// the script named it and `smooth` asks for interpolated vertex normals (see
    /// [`MeshInstance`]).
    pub fn mesh(mesh: Arc<TriangleMesh>, name: &str, transform: Transform, material: MaterialId, smooth: bool) -> Self {
        Shape::Mesh(Box::new(MeshInstance { mesh, name: name.into(), transform, material, smooth }))
    }

    /// The same shape placed by `t` after its own transformation.
    pub fn transformed(self, t: &Transform) -> Shape {
        match self {
            Shape::Primitive(p) => Shape::Primitive(Primitive { transform: *t * p.transform, ..p }),
            Shape::Csg(mut c) => {
                c.transform = *t * c.transform;
                Shape::Csg(c)
            }
            Shape::Mesh(mut m) => {
                m.transform = *t * m.transform;
                Shape::Mesh(m)
            }
        }
    }

    /// The top-level shapes that render as this one: a UNITE's children (under its
    /// transformation, recursively), anything else itself. A UNITE keeps every child's
    /// surface, so its closest hit along any ray is the closest of its children's and its
    /// occlusion theirs: as separate shapes they go into the BVH one by one instead of being
    /// evaluated as one CSG tree ([`crate::prepare::render_form()`], DESIGN.md
    /// "Top-level UNITEs"). A UNITE holding a mesh stays whole, so that
    /// [`crate::scene::Scene::validate`] still refuses it.
    pub fn top_level_parts(self) -> Vec<Shape> {
        fn walk(s: Shape, out: &mut Vec<Shape>) {
            match s {
                Shape::Csg(c) if unite_splits(&c) => {
                    let t = c.transform;
                    for child in c.children {
                        walk(child.transformed(&t), out);
                    }
                }
                other => out.push(other),
            }
        }
        let mut out = Vec::new();
        walk(self, &mut out);
        out
    }

    /// Whether [`Self::top_level_parts`] splits this shape (a UNITE without meshes).
    pub fn splits_at_top_level(&self) -> bool {
        matches!(self, Shape::Csg(c) if unite_splits(c))
    }

    fn holds_mesh(&self) -> bool {
        match self {
            Shape::Mesh(_) => true,
            Shape::Primitive(_) => false,
            Shape::Csg(c) => c.children.iter().any(Shape::holds_mesh),
        }
    }

    /// World-space bounds of the visible surface. A lone plane is infinite. CSG: union of
    /// the children for UNITE/FUSE, their intersection for INTERSECT (planes' half-spaces
    /// make this finite where a bounded child cuts them), the first child's for DIFF.
    /// A mesh: its vertices' box, transformed.
    pub fn bounds(&self) -> Aabb {
        match self {
            Shape::Primitive(p) => p.kind.object_bounds().transformed(&p.transform),
            Shape::Csg(c) => c.solid_bounds_local().transformed(&c.transform),
            Shape::Mesh(m) => m.mesh.bounds().transformed(&m.transform),
        }
    }

    /// Visits the material of every surface: primitives (CSG leaves included) and meshes.
    pub fn for_each_material(&self, f: &mut impl FnMut(MaterialId)) {
        match self {
            Shape::Mesh(m) => f(m.material),
            s => s.for_each_primitive(&mut |p, _| f(p.material)),
        }
    }

    /// Bounds of the solid this shape encloses, for use inside a CSG parent.
    fn solid_bounds(&self) -> Aabb {
        match self {
            Shape::Primitive(p) => p.kind.solid_bounds().transformed(&p.transform),
            Shape::Csg(c) => c.solid_bounds_local().transformed(&c.transform),
            // Not a CSG operand (SceneLang refuses it); its surface's box.
            Shape::Mesh(_) => self.bounds(),
        }
    }

    /// Depth of the CSG tree (0 for a primitive or a mesh).
    pub fn csg_depth(&self) -> usize {
        match self {
            Shape::Primitive(_) | Shape::Mesh(_) => 0,
            Shape::Csg(c) => 1 + c.children.iter().map(Shape::csg_depth).max().unwrap_or(0),
        }
    }

    /// Visits every primitive with its full object-to-world transformation (meshes are not
    /// primitives).
    pub fn for_each_primitive(&self, f: &mut impl FnMut(&Primitive, &Transform)) {
        fn walk(s: &Shape, parent: &Transform, f: &mut impl FnMut(&Primitive, &Transform)) {
            match s {
                Shape::Primitive(p) => f(p, &(*parent * p.transform)),
                Shape::Csg(c) => {
                    let t = *parent * c.transform;
                    for ch in &c.children {
                        walk(ch, &t, f);
                    }
                }
                Shape::Mesh(_) => {}
            }
        }
        walk(self, &Transform::IDENTITY, f);
    }

    /// Number of primitives in this tree: a CSG tree's leaves (0 for a mesh).
    pub fn leaf_count(&self) -> usize {
        match self {
            Shape::Primitive(_) => 1,
            Shape::Mesh(_) => 0,
            Shape::Csg(c) => c.children.iter().map(Shape::leaf_count).sum(),
        }
    }

    /// Number of CSG nodes in this tree.
    pub fn csg_node_count(&self) -> usize {
        match self {
            Shape::Primitive(_) | Shape::Mesh(_) => 0,
            Shape::Csg(c) => 1 + c.children.iter().map(Shape::csg_node_count).sum::<usize>(),
        }
    }
}

impl Csg {
    fn solid_bounds_local(&self) -> Aabb {
        let mut it = self.children.iter().map(Shape::solid_bounds);
        let first = it.next().unwrap_or(Aabb::EMPTY);
        match self.op {
            CsgOp::Unite | CsgOp::Fuse => it.fold(first, |a, b| a.union(&b)),
            CsgOp::Intersect => it.fold(first, |a, b| a.intersection(&b)),
            CsgOp::Diff => first,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn m() -> MaterialId {
        MaterialId(0)
    }

    #[test]
    fn plane_is_infinite_but_intersected_with_a_sphere_is_bounded() {
        let plane = Shape::primitive(ShapeKind::Plane, Transform::IDENTITY, m());
        assert!(!plane.bounds().is_finite());
        let sphere = Shape::primitive(ShapeKind::Sphere, Transform::translation(DVec3::new(0.0, 0.0, 0.5)), m());
        let cut = Shape::csg(CsgOp::Intersect, vec![sphere, plane], Transform::IDENTITY);
        let b = cut.bounds();
        assert!(b.is_finite());
        assert_eq!(b.max.z, 0.0);
        assert_eq!(b.min.z, -0.5);
    }

    #[test]
    fn top_level_unites_split_into_their_parts() {
        let s = |x: f64| Shape::primitive(ShapeKind::Sphere, Transform::translation(DVec3::new(x, 0.0, 0.0)), m());
        let fuse = Shape::csg(CsgOp::Fuse, vec![s(1.0), s(2.0)], Transform::IDENTITY);
        let up = Transform::translation(DVec3::Z);
        let inner = Shape::csg(CsgOp::Unite, vec![s(3.0), fuse.clone()], Transform::scaling(DVec3::splat(2.0)));
        let parts = Shape::csg(CsgOp::Unite, vec![s(0.0), inner], up).top_level_parts();
        // Nested UNITEs flatten, their transformations applied outside-in; other nodes stay.
        let want = [
            s(0.0).transformed(&up),
            s(3.0).transformed(&(up * Transform::scaling(DVec3::splat(2.0)))),
            fuse.clone().transformed(&(up * Transform::scaling(DVec3::splat(2.0)))),
        ];
        assert_eq!(parts, want);
        let Shape::Primitive(p) = &parts[1] else { panic!() };
        assert!((p.transform.point(DVec3::ZERO) - DVec3::new(6.0, 0.0, 1.0)).length() < 1e-12);
        assert_eq!(fuse.clone().top_level_parts(), [fuse]);
        // A UNITE holding a mesh stays whole (Scene::validate refuses it).
        let mesh = TriangleMesh::from_parts(
            "t",
            super::super::mesh::MeshParts {
                positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y],
                normals: None,
                uvs: None,
                triangles: vec![[0, 1, 2]],
                dropped_faces: 0,
            },
        )
        .unwrap();
        let with_mesh = Shape::csg(
            CsgOp::Unite,
            vec![s(0.0), Shape::mesh(Arc::new(mesh), "t", Transform::IDENTITY, m(), false)],
            Transform::IDENTITY,
        );
        assert_eq!(with_mesh.clone().top_level_parts(), [with_mesh]);
    }

    #[test]
    fn csg_depth_and_counts() {
        let s = || Shape::primitive(ShapeKind::Sphere, Transform::IDENTITY, m());
        let inner = Shape::csg(CsgOp::Diff, vec![s(), s()], Transform::IDENTITY);
        let outer = Shape::csg(CsgOp::Unite, vec![inner, s()], Transform::translation(DVec3::X));
        assert_eq!(outer.csg_depth(), 2);
        assert_eq!(outer.csg_node_count(), 2);
        let mut n = 0;
        outer.for_each_primitive(&mut |_, t| {
            n += 1;
            assert_eq!(t.point(DVec3::ZERO), DVec3::X);
        });
        assert_eq!(n, 3);
    }
}
