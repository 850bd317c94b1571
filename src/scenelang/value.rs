//! The values a SceneLang script computes, before they are placed into a [`Scene`](crate::scene::Scene).

use std::sync::Arc;

use glam::DVec3;

use crate::color::Color;
use crate::image::HdrImage;
use crate::scene::{
    Brdf, Camera, CsgOp, Environment, Material, PcgSeed, Pigment, PointLight, Renderer, ShapeKind, Tracer, Transform,
};

/// An image value. `Image(w, h)` stays a size until its pixels are needed, so that a huge
/// `USING Image(...)` never allocates.
#[derive(Debug, Clone, PartialEq)]
pub enum ImageValue {
    Blank { width: u32, height: u32 },
    Loaded(Arc<HdrImage>),
}

impl ImageValue {
    pub fn size(&self) -> (u32, u32) {
        match self {
            ImageValue::Blank { width, height } => (*width, *height),
            ImageValue::Loaded(img) => (img.width() as u32, img.height() as u32),
        }
    }
}

/// A shape as a script holds it: materials inline (they become [`crate::scene::MaterialId`]s
/// when the shape is spawned).
///
/// Shared, not copied: `SET b FUSE(a, a)` points at `a` twice, so a chain of such names
/// costs memory linear in its length although the tree it stands for doubles each line.
/// Each node caches the size of the tree it expands to, so that limits are checked where a
/// script crosses them, before anything is expanded.
#[derive(Debug, Clone)]
pub struct ShapeValue(Arc<ShapeNode>);

#[derive(Debug)]
pub enum ShapeNode {
    Primitive {
        kind: ShapeKind,
        transform: Transform,
        material: Material,
    },
    Csg {
        op: CsgOp,
        children: Vec<ShapeValue>,
        transform: Transform,
        size: TreeSize,
    },
    /// A triangle mesh (ext `Shape.Mesh`): `file` as the script wrote it, the mesh shared
    /// by every use of the same file.
    Mesh {
        file: Arc<str>,
        mesh: Arc<crate::scene::TriangleMesh>,
        transform: Transform,
        material: Material,
        smooth: bool,
    },
}

/// How limit errors explain the count of primitives.
pub const PER_USE: &str = "a CSG leaf counts once per use: FUSE(a, a) holds the primitives of `a` twice";

/// What a shape expands to: primitives (counted once per use) and CSG depth.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TreeSize {
    pub primitives: u64,
    pub depth: usize,
}

impl ShapeValue {
    pub fn primitive(kind: ShapeKind, transform: Transform, material: Material) -> Self {
        Self(Arc::new(ShapeNode::Primitive { kind, transform, material }))
    }

    pub fn mesh(
        file: &str,
        mesh: Arc<crate::scene::TriangleMesh>,
        transform: Transform,
        material: Material,
        smooth: bool,
    ) -> Self {
        Self(Arc::new(ShapeNode::Mesh { file: file.into(), mesh, transform, material, smooth }))
    }

    /// A CSG node; its size comes from its children's in O(number of children).
    pub fn csg(op: CsgOp, children: Vec<ShapeValue>, transform: Transform) -> Self {
        let sizes: Vec<TreeSize> = children.iter().map(ShapeValue::size).collect();
        let size = TreeSize {
            primitives: sizes.iter().fold(0u64, |n, s| n.saturating_add(s.primitives)),
            depth: 1 + sizes.iter().map(|s| s.depth).max().unwrap_or(0),
        };
        Self(Arc::new(ShapeNode::Csg { op, children, transform, size }))
    }

    pub fn node(&self) -> &ShapeNode {
        &self.0
    }

    /// Identifies the shared node (two uses of one name give the same key).
    pub fn key(&self) -> *const ShapeNode {
        Arc::as_ptr(&self.0)
    }

    pub fn size(&self) -> TreeSize {
        match &*self.0 {
            ShapeNode::Primitive { .. } => TreeSize { primitives: 1, depth: 0 },
            ShapeNode::Csg { size, .. } => *size,
            // Not a CSG operand: the size is never combined.
            ShapeNode::Mesh { .. } => TreeSize { primitives: 1, depth: 0 },
        }
    }
}

impl PartialEq for ShapeValue {
    /// Shared nodes are equal without walking them (a walk of a doubled chain is exponential).
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
            || match (&*self.0, &*other.0) {
                (
                    ShapeNode::Primitive { kind: k1, transform: t1, material: m1 },
                    ShapeNode::Primitive { kind: k2, transform: t2, material: m2 },
                ) => k1 == k2 && t1 == t2 && m1 == m2,
                (
                    ShapeNode::Csg { op: o1, children: c1, transform: t1, .. },
                    ShapeNode::Csg { op: o2, children: c2, transform: t2, .. },
                ) => o1 == o2 && t1 == t2 && c1 == c2,
                (
                    ShapeNode::Mesh { mesh: a, transform: t1, material: m1, smooth: s1, .. },
                    ShapeNode::Mesh { mesh: b, transform: t2, material: m2, smooth: s2, .. },
                ) => Arc::ptr_eq(a, b) && t1 == t2 && m1 == m2 && s1 == s2,
                _ => false,
            }
    }
}

/// Every SceneLang value.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Number(f64),
    Str(String),
    Color(Color),
    Point(DVec3),
    /// Shared like shapes: a long list used many times is not copied each time.
    List(Arc<[f64]>),
    Transformation(Transform),
    Image(ImageValue),
    Pigment(Pigment),
    Brdf(Brdf),
    Material(Material),
    Shape(ShapeValue),
    Light(PointLight),
    Pcg(PcgSeed),
    Camera(Camera),
    Renderer(Renderer),
    Tracer(Tracer),
    Environment(Environment),
}

/// The type of a [`Value`], as messages name it; the capitalised ones are also the type
/// words a script writes (`Color`, `Shape.Sphere`, …), see [`Ty::WORDS`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ty {
    Number,
    Str,
    Color,
    Point,
    List,
    Transformation,
    Image,
    Pigment,
    Brdf,
    Material,
    Shape,
    Light,
    Pcg,
    Camera,
    Renderer,
    Tracer,
    Environment,
}

impl Ty {
    /// The types a script can name with a word (every type but number and string).
    pub const WORDS: [Ty; 15] = [
        Ty::Color,
        Ty::Point,
        Ty::List,
        Ty::Transformation,
        Ty::Image,
        Ty::Pigment,
        Ty::Brdf,
        Ty::Material,
        Ty::Shape,
        Ty::Light,
        Ty::Pcg,
        Ty::Camera,
        Ty::Renderer,
        Ty::Tracer,
        Ty::Environment,
    ];

    /// The type word `w` names, if any.
    pub fn from_word(w: &str) -> Option<Ty> {
        Self::WORDS.into_iter().find(|t| t.name() == w)
    }

    pub fn name(self) -> &'static str {
        match self {
            Ty::Number => "number",
            Ty::Str => "string",
            Ty::Color => "Color",
            Ty::Point => "Point",
            Ty::List => "List",
            Ty::Transformation => "Transformation",
            Ty::Image => "Image",
            Ty::Pigment => "Pigment",
            Ty::Brdf => "Brdf",
            Ty::Material => "Material",
            Ty::Shape => "Shape",
            Ty::Light => "Light",
            Ty::Pcg => "Pcg",
            Ty::Camera => "Camera",
            Ty::Renderer => "Renderer",
            Ty::Tracer => "Tracer",
            Ty::Environment => "Environment",
        }
    }
    /// "a number", "an Image", … for messages.
    pub fn article(self) -> String {
        let n = self.name();
        if n.starts_with(['a', 'e', 'i', 'o', 'u', 'A', 'E', 'I', 'O', 'U']) {
            format!("an {n}")
        } else {
            format!("a {n}")
        }
    }
}

impl Value {
    pub fn ty(&self) -> Ty {
        match self {
            Value::Number(_) => Ty::Number,
            Value::Str(_) => Ty::Str,
            Value::Color(_) => Ty::Color,
            Value::Point(_) => Ty::Point,
            Value::List(_) => Ty::List,
            Value::Transformation(_) => Ty::Transformation,
            Value::Image(_) => Ty::Image,
            Value::Pigment(_) => Ty::Pigment,
            Value::Brdf(_) => Ty::Brdf,
            Value::Material(_) => Ty::Material,
            Value::Shape(_) => Ty::Shape,
            Value::Light(_) => Ty::Light,
            Value::Pcg(_) => Ty::Pcg,
            Value::Camera(_) => Ty::Camera,
            Value::Renderer(_) => Ty::Renderer,
            Value::Tracer(_) => Ty::Tracer,
            Value::Environment(_) => Ty::Environment,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere() -> ShapeValue {
        ShapeValue::primitive(ShapeKind::Sphere, Transform::IDENTITY, Material::default())
    }

    #[test]
    fn shared_nodes_count_their_uses_without_copying() {
        // FUSE(c, c) doubled 70 times: the count saturates instead of overflowing, while the
        // value is 71 nodes (each child is the same shared node).
        let mut c = sphere();
        for i in 1..=70u32 {
            c = ShapeValue::csg(CsgOp::Fuse, vec![c.clone(), c], Transform::IDENTITY);
            let size = c.size();
            assert_eq!(size.depth, i as usize);
            let expect = 1u64.checked_shl(i).unwrap_or(u64::MAX);
            assert_eq!(size.primitives, expect, "{i}");
            let ShapeNode::Csg { children, .. } = c.node() else { panic!("not a CSG node") };
            assert_eq!(children[0].key(), children[1].key());
        }
        // Two roots built apart over the same shared children: equal after one level, where
        // a walk of the 2⁷⁰-leaf tree would never end (this test would hang, not pass).
        let ShapeNode::Csg { children, .. } = c.node() else { panic!("not a CSG node") };
        let twin = ShapeValue::csg(CsgOp::Fuse, vec![children[0].clone(), children[1].clone()], Transform::IDENTITY);
        assert!(!Arc::ptr_eq(&c.0, &twin.0));
        assert_eq!(c, twin);
        // Equal trees built apart still compare equal.
        let a = ShapeValue::csg(CsgOp::Unite, vec![sphere(), sphere()], Transform::IDENTITY);
        let b = ShapeValue::csg(CsgOp::Unite, vec![sphere(), sphere()], Transform::IDENTITY);
        assert_ne!(a.key(), b.key());
        assert_eq!(a, b);
        assert_ne!(a, ShapeValue::csg(CsgOp::Fuse, vec![sphere(), sphere()], Transform::IDENTITY));
        // A UNITE's pieces may overlap, so an INTERSECT of two of them multiplies: 2·2.
        let x = ShapeValue::csg(CsgOp::Intersect, vec![a.clone(), a], Transform::IDENTITY);
        assert_eq!(x.size(), TreeSize { primitives: 4, depth: 2 });
    }

    #[test]
    fn every_type_word_names_itself() {
        for t in Ty::WORDS {
            assert_eq!(Ty::from_word(t.name()), Some(t));
        }
        assert_eq!(Ty::WORDS.len(), 15);
        // Numbers and strings have no type word.
        for w in ["Number", "number", "Str", "string", "String"] {
            assert_eq!(Ty::from_word(w), None, "{w}");
        }
    }
}
