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
#[derive(Debug, Clone, PartialEq)]
pub enum ShapeValue {
    Primitive { kind: ShapeKind, transform: Transform, material: Material },
    Csg { op: CsgOp, children: Vec<ShapeValue>, transform: Transform },
}

/// Every SceneLang value.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Number(f64),
    Str(String),
    Color(Color),
    Point(DVec3),
    List(Vec<f64>),
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

/// The type of a [`Value`], as messages name it.
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
