//! What `DUMP` prints: a readable listing of variables, world, lights and settings.

use std::fmt::Write;

use super::interpreter::{Vars, World};
use super::value::{ImageValue, ShapeNode, ShapeValue, Value};
use crate::color::Color;
use crate::scene::{Brdf, Material, Pigment, Shape, Transform};

/// The sections `DUMP.section` accepts.
pub const SECTIONS: [&str; 9] =
    ["variables", "world", "lights", "image", "camera", "renderer", "tracer", "environment", "ALL"];

fn color(c: &Color) -> String {
    format!("<{}, {}, {}>", c.r, c.g, c.b)
}

fn transform(t: &Transform) -> String {
    let m = t.matrix().transpose().to_cols_array();
    format!("Transformation([{}])", m.map(|v| v.to_string()).join(", "))
}

/// A pigment in SceneLang syntax (images by size: their pixels would flood the output).
fn pigment(p: &Pigment) -> String {
    match p {
        Pigment::Uniform(c) => format!("Pigment.Uniform({})", color(c)),
        Pigment::Checkered { n, on, off } => format!("Pigment.Checkered({n}, {}, {})", color(on), color(off)),
        Pigment::Image { image, filter } => {
            format!("Pigment.Image(<{}×{} image>, .filter {filter:?})", image.width(), image.height())
        }
    }
}

fn brdf(b: &Brdf) -> String {
    match b {
        Brdf::Diffuse { pigment: p } => format!("Brdf.Diffuse({})", pigment(p)),
        Brdf::Specular { pigment: p, threshold_angle_rad } => {
            format!("Brdf.Specular({}, {threshold_angle_rad})", pigment(p))
        }
        Brdf::Dielectric { pigment: p, ior, roughness: r, .. } if *r == 0.0 => {
            format!("Brdf.Dielectric({}, {ior})", pigment(p))
        }
        Brdf::Dielectric { pigment: p, ior, roughness, multiple_scattering } => {
            format!("Brdf.Dielectric({}, {ior}, {roughness}{})", pigment(p), single_scattering(*multiple_scattering))
        }
        Brdf::Conductor { pigment: p, roughness, fresnel: None, multiple_scattering } => {
            format!("Brdf.Conductor({}, {roughness}{})", pigment(p), single_scattering(*multiple_scattering))
        }
        Brdf::Conductor { pigment: p, roughness, fresnel: Some((eta, k)), multiple_scattering } => format!(
            "Brdf.Conductor({}, {roughness}, {}, {}{})",
            pigment(p),
            color(eta),
            color(k),
            single_scattering(*multiple_scattering)
        ),
        Brdf::Plastic { pigment: p, ior, roughness } => format!("Brdf.Plastic({}, {ior}, {roughness})", pigment(p)),
    }
}

/// The `.multiple_scattering 0` of a single-scattering microfacet BRDF (named: it follows
/// optional arguments that may be absent).
fn single_scattering(multiple_scattering: bool) -> &'static str {
    if multiple_scattering {
        ""
    } else {
        ", .multiple_scattering 0"
    }
}

fn material(m: &Material) -> String {
    format!("Material({}, {})", brdf(&m.brdf), pigment(&m.emitted))
}

/// A one-value description, in SceneLang syntax where it has one.
pub fn describe(v: &Value) -> String {
    match v {
        Value::Number(n) => n.to_string(),
        Value::Str(s) => format!("{s:?}"),
        Value::Color(c) => color(c),
        Value::Point(p) => format!("{{{}, {}, {}}}", p.x, p.y, p.z),
        Value::List(l) => format!("[{}]", l.iter().map(f64::to_string).collect::<Vec<_>>().join(", ")),
        Value::Transformation(t) => transform(t),
        Value::Image(ImageValue::Blank { width, height }) => format!("Image({width}, {height})"),
        Value::Image(ImageValue::Loaded(i)) => format!("Image({}×{} pixels, loaded)", i.width(), i.height()),
        Value::Shape(s) => shape_value(s),
        Value::Pigment(p) => pigment(p),
        Value::Brdf(b) => brdf(b),
        Value::Material(m) => material(m),
        Value::Light(l) => format!("{l:?}"),
        Value::Pcg(p) => format!("Pcg(.state {}, .inc {})", p.state, p.inc),
        Value::Camera(c) => format!("{c:?}"),
        Value::Renderer(r) => format!("{r:?}"),
        Value::Tracer(t) => format!("{t:?}"),
        Value::Environment(e) => match e {
            crate::scene::Environment::Image { image, intensity, rotation_deg } => format!(
                "Environment.Image({}×{} pixels, .intensity {intensity}, .rotation {rotation_deg})",
                image.width(),
                image.height()
            ),
            other => format!("{other:?}"),
        },
    }
}

/// Largest CSG tree DUMP writes out in full; names shared many times stand for trees far
/// larger than their script (FUSE(a, a) doubles each line), so bigger ones are summarised.
const MAX_DUMPED_PRIMITIVES: u64 = 64;

fn shape_value(s: &ShapeValue) -> String {
    match s.node() {
        ShapeNode::Primitive { kind, transform: t, material: m } => {
            format!("Shape.{kind:?}(.material {}, .transformation {})", material(m), transform(t))
        }
        ShapeNode::Mesh { file, mesh, transform: t, material: m, smooth } => format!(
            "Shape.Mesh(.file {file:?}, .material {}, .transformation {}, .smooth {}) ({} triangles)",
            material(m),
            transform(t),
            u8::from(*smooth),
            mesh.triangle_count()
        ),
        ShapeNode::Csg { op, children, transform: t, size } => {
            let inner = if size.primitives > MAX_DUMPED_PRIMITIVES {
                format!("<{} shapes: {} primitives, depth {}>", children.len(), size.primitives, size.depth)
            } else {
                children.iter().map(shape_value).collect::<Vec<_>>().join(", ")
            };
            format!("{}({inner}, .transformation {})", op.keyword(), transform(t))
        }
    }
}

fn shape(s: &Shape, out: &mut String, indent: usize) {
    let pad = "  ".repeat(indent);
    match s {
        Shape::Primitive(p) => {
            let _ = writeln!(out, "{pad}{:?} material #{} {}", p.kind, p.material.0, transform(&p.transform));
        }
        Shape::Csg(c) => {
            let _ = writeln!(out, "{pad}{} {}", c.op.keyword(), transform(&c.transform));
            for ch in &c.children {
                shape(ch, out, indent + 1);
            }
        }
        Shape::Mesh(m) => {
            let _ = writeln!(
                out,
                "{pad}Mesh {:?} ({} triangles) material #{} {}",
                m.name,
                m.mesh.triangle_count(),
                m.material.0,
                transform(&m.transform)
            );
        }
    }
}

/// The text of `DUMP.section`, or `None` for an unknown section.
pub fn section(name: &str, vars: &Vars, world: &World) -> Option<String> {
    let mut out = String::new();
    // A snapshot of what SPAWN has added so far (DUMP is for debugging: a copy is fine).
    let settings = match world.builder.build() {
        Ok(s) => s,
        Err(e) => return Some(format!("(world not available: {e})\n")),
    };
    let opt = |o: Option<String>| o.unwrap_or_else(|| "(not set)".to_string());
    match name {
        "variables" => {
            let mut names: Vec<_> = vars.iter().collect();
            names.sort_by(|a, b| a.0.cmp(b.0));
            let _ = writeln!(out, "variables ({}):", names.len());
            for (n, v) in names {
                let _ = writeln!(out, "  {n} = {}  [{}]", describe(&v.value), v.origin);
            }
        }
        "world" => {
            let _ = writeln!(out, "world ({} shapes):", settings.shapes.len());
            for s in &settings.shapes {
                shape(s, &mut out, 1);
            }
            let _ = writeln!(out, "materials ({}):", settings.materials.len());
            for (i, m) in settings.materials.iter().enumerate() {
                let _ = writeln!(out, "  #{i} {}", material(m));
            }
        }
        "lights" => {
            let _ = writeln!(out, "lights ({}):", settings.point_lights.len());
            for l in &settings.point_lights {
                let _ = writeln!(
                    out,
                    "  Light(.position {{{}, {}, {}}}, .color {}, .linear_radius {})",
                    l.position.x,
                    l.position.y,
                    l.position.z,
                    color(&l.color),
                    l.linear_radius
                );
            }
        }
        "image" => {
            let _ =
                writeln!(out, "image: {}", opt(world.image.as_ref().map(|(i, _)| describe(&Value::Image(i.clone())))));
        }
        "camera" => {
            let _ = writeln!(out, "camera: {}", opt(world.camera.as_ref().map(|(c, _)| format!("{c:?}"))));
        }
        "renderer" => {
            let _ = writeln!(out, "renderer: {}", opt(world.renderer.as_ref().map(|(r, _)| format!("{r:?}"))));
        }
        "tracer" => {
            let _ = writeln!(out, "tracer: {}", opt(world.tracer.as_ref().map(|(t, _)| format!("{t:?}"))));
        }
        "environment" => {
            let _ = writeln!(
                out,
                "environment: {}",
                opt(world.environment.as_ref().map(|(e, _)| describe(&Value::Environment(e.clone()))))
            );
        }
        "ALL" => {
            for s in SECTIONS.iter().take(SECTIONS.len() - 1) {
                out.push_str(&section(s, vars, world)?);
            }
        }
        _ => return None,
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::scene::Shape;
    use crate::scenelang::{load_str, LoadOptions};

    fn brdfs(src: &str) -> Vec<Brdf> {
        let src = format!("{src}\nUSING Camera.Perspective() Image(4, 2) Renderer.Flat() Tracer()\n");
        let s = load_str(&src, "t.sl", Path::new("."), &LoadOptions::default()).unwrap();
        s.shapes
            .iter()
            .map(|sh| match sh {
                Shape::Primitive(p) => s.materials[p.material.0 as usize].brdf.clone(),
                _ => unreachable!(),
            })
            .collect()
    }

    /// The rough materials are written in a form that loads back to the same model.
    #[test]
    fn rough_materials_round_trip() {
        let all = brdfs(
            "SPAWN Shape.Sphere(Material(Brdf.Conductor(<1, 0.8, 0.6>, 0.3, <0.2, 0.4, 1.4>, <3.9, 2.4, 1.6>)))
                   Shape.Sphere(Material(Brdf.Conductor(.roughness 0.7)))
                   Shape.Sphere(Material(Brdf.Dielectric(.roughness 0.5, .ior 1.3)))
                   Shape.Sphere(Material(Brdf.Plastic(<0.5, 0.1, 0.1>, 1.6, 0.25)))",
        );
        for b in all {
            let text = brdf(&b);
            assert_eq!(brdfs(&format!("SPAWN Shape.Sphere(Material({text}))")), vec![b], "{text}");
        }
    }
}
