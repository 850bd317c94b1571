//! A summary of a loaded scene (what `lumen check` prints), computed here so it can be tested.

use std::fmt;

use crate::scene::{Aabb, Brdf, Environment, Projection, Renderer, Scene, Shape, ShapeKind};

/// Counts and settings of a [`Scene`], for `lumen check`.
///
/// ```
/// use lumen::scenelang::{load_str, LoadOptions, SceneSummary};
/// let src = "SPAWN Shape.Sphere() UNITE(Shape.Cube(), Shape.Plane())
///            USING Camera.Perspective() Image(64, 32) Renderer.Flat() Tracer()";
/// let scene = load_str(src, "x.sl", std::path::Path::new("."), &LoadOptions::default()).unwrap();
/// let s = SceneSummary::of(&scene);
/// assert_eq!((s.count(lumen::scene::ShapeKind::Sphere), s.csg_nodes, s.infinite_shapes), (1, 1, 1));
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct SceneSummary {
    /// Shapes spawned at the top level (a CSG tree counts once).
    pub top_level_shapes: usize,
    /// Primitives of each kind, inside CSG trees or not, in [`ShapeKind::ALL`] order.
    pub primitives: [usize; 4],
    /// CSG operations (UNITE, INTERSECT, …) over all trees, nested ones included.
    pub csg_nodes: usize,
    /// Deepest CSG tree (0 when there is none).
    pub csg_max_depth: usize,
    /// Mesh instances, and per distinct mesh (file): its name, triangles, vertices,
    /// degenerate triangles dropped, and its object-space bounds.
    pub mesh_instances: usize,
    /// One entry per distinct mesh, in the order of its first instance.
    pub meshes: Vec<MeshSummary>,
    /// Point lights (SceneLang's `Light`).
    pub point_lights: usize,
    /// Emissive top-level spheres, cubes and mesh instances ([`Scene::area_lights`]).
    pub area_lights: usize,
    /// Entries of the scene's material table, used or not.
    pub materials: usize,
    /// Materials with a Lambertian (`Brdf::Diffuse`) BRDF.
    pub diffuse_materials: usize,
    /// Materials with a perfect-mirror (`Brdf::Specular`) BRDF.
    pub specular_materials: usize,
    /// Materials with a glass-like (`Brdf::Dielectric`) BSDF.
    pub dielectric_materials: usize,
    /// Materials with a GGX metal (`Brdf::Conductor`) BRDF.
    pub conductor_materials: usize,
    /// Materials with a coated diffuse (`Brdf::Plastic`) BRDF.
    pub plastic_materials: usize,
    /// Materials with a non-black emitted radiance, whatever their BRDF.
    pub emissive_materials: usize,
    /// "perspective" or "orthogonal".
    pub camera_kind: &'static str,
    /// The camera's screen width over height, as the scene gives it (not taken from the image size).
    pub aspect_ratio: f64,
    /// Full opening angle in degrees (perspective cameras only).
    pub aperture_deg: Option<f64>,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Renderer name and its settings, as one line.
    pub renderer: String,
    /// The tracer's s for s×s jittered samples per pixel; 0 for one ray through each pixel centre.
    pub samples_per_side: u32,
    /// The tracer's PCG seed as (state, inc).
    pub tracer_seed: (u64, u64),
    /// The environment, as one line ("none" when escaping rays see the background).
    pub environment: String,
    /// Bounds of the finite shapes.
    pub bounds: Option<Aabb>,
    /// Top-level shapes with infinite bounds (planes, or CSG trees that keep a plane's extent).
    pub infinite_shapes: usize,
}

/// One distinct mesh of a scene, for `lumen check`.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshSummary {
    /// The file as the script named it.
    pub name: String,
    /// Top-level shapes that place this mesh (each with its own transformation and material).
    pub instances: usize,
    /// Triangles kept after loading.
    pub triangles: usize,
    /// Vertices as loaded from the file, whether a kept triangle uses them or not.
    pub vertices: usize,
    /// Triangles dropped while loading as degenerate (repeated indices, zero area, short faces).
    pub dropped_degenerate: usize,
    /// True when the file had usable vertex normals (whether instances interpolate them is
    /// each instance's `smooth` setting).
    pub smooth_normals: bool,
    /// True when the file had usable texture coordinates.
    pub uvs: bool,
    /// Object-space bounds of the triangles' vertices, before any instance's transformation.
    pub bounds: Aabb,
}

fn rgb(c: crate::color::Color) -> String {
    format!("<{}, {}, {}>", c.r, c.g, c.b)
}

impl SceneSummary {
    /// Counts and describes everything in `scene`.
    pub fn of(scene: &Scene) -> Self {
        let mut primitives = [0; 4];
        for s in &scene.shapes {
            s.for_each_primitive(&mut |p, _| {
                primitives[ShapeKind::ALL.iter().position(|k| *k == p.kind).unwrap_or(0)] += 1;
            });
        }
        let mut meshes: Vec<(std::sync::Arc<crate::scene::TriangleMesh>, MeshSummary)> = Vec::new();
        for s in &scene.shapes {
            if let Shape::Mesh(m) = s {
                match meshes.iter_mut().find(|(x, _)| std::sync::Arc::ptr_eq(x, &m.mesh)) {
                    Some((_, summary)) => summary.instances += 1,
                    None => meshes.push((
                        m.mesh.clone(),
                        MeshSummary {
                            name: m.name.to_string(),
                            instances: 1,
                            triangles: m.mesh.triangle_count(),
                            vertices: m.mesh.vertex_count(),
                            dropped_degenerate: m.mesh.dropped_degenerate(),
                            smooth_normals: m.mesh.normals().is_some(),
                            uvs: m.mesh.uvs().is_some(),
                            bounds: m.mesh.bounds(),
                        },
                    )),
                }
            }
        }
        let count_brdf = |f: fn(&Brdf) -> bool| scene.materials.iter().filter(|m| f(&m.brdf)).count();
        let (camera_kind, aperture_deg) = match scene.camera.projection {
            Projection::Perspective { .. } => ("perspective", scene.camera.aperture_deg()),
            Projection::Orthogonal => ("orthogonal", None),
        };
        let renderer = match &scene.renderer {
            Renderer::OnOff { on, off } => format!("OnOff (on {}, off {})", rgb(*on), rgb(*off)),
            Renderer::Flat { background } => format!("Flat (background {})", rgb(*background)),
            Renderer::PointLight { background, ambient } => {
                format!("PointLight (background {}, ambient {})", rgb(*background), rgb(*ambient))
            }
            Renderer::PathTracer(p) => format!(
                "PathTracer (n {}, max_depth {}, roulette_depth {}, nee {}, background {}, rng state {} inc {})",
                p.n,
                p.max_depth,
                p.roulette_depth,
                if p.nee { "on" } else { "off" },
                rgb(p.background),
                p.rng.state,
                p.rng.inc
            ),
        };
        let environment = match &scene.environment {
            None => "none (escaping rays see the renderer's background)".to_string(),
            Some(Environment::Uniform(c)) => format!("uniform {}", rgb(*c)),
            Some(Environment::Gradient { zenith, horizon, nadir }) => {
                format!("gradient (zenith {}, horizon {}, nadir {})", rgb(*zenith), rgb(*horizon), rgb(*nadir))
            }
            Some(Environment::Image { image, intensity, rotation_deg }) => {
                format!("image {}×{} (intensity {intensity}, rotation {rotation_deg}°)", image.width(), image.height())
            }
        };
        Self {
            top_level_shapes: scene.shapes.len(),
            primitives,
            csg_nodes: scene.shapes.iter().map(Shape::csg_node_count).sum(),
            csg_max_depth: scene.shapes.iter().map(Shape::csg_depth).max().unwrap_or(0),
            mesh_instances: scene.shapes.iter().filter(|s| matches!(s, Shape::Mesh(_))).count(),
            meshes: meshes.into_iter().map(|(_, s)| s).collect(),
            point_lights: scene.point_lights.len(),
            area_lights: scene.area_lights().len(),
            materials: scene.materials.len(),
            diffuse_materials: count_brdf(|b| matches!(b, Brdf::Diffuse { .. })),
            specular_materials: count_brdf(|b| matches!(b, Brdf::Specular { .. })),
            dielectric_materials: count_brdf(|b| matches!(b, Brdf::Dielectric { .. })),
            conductor_materials: count_brdf(|b| matches!(b, Brdf::Conductor { .. })),
            plastic_materials: count_brdf(|b| matches!(b, Brdf::Plastic { .. })),
            emissive_materials: scene.materials.iter().filter(|m| m.is_emissive()).count(),
            camera_kind,
            aspect_ratio: scene.camera.aspect_ratio,
            aperture_deg,
            width: scene.width,
            height: scene.height,
            renderer,
            samples_per_side: scene.tracer.samples_per_side,
            tracer_seed: (scene.tracer.rng.state, scene.tracer.rng.inc),
            environment,
            bounds: scene.finite_bounds(),
            infinite_shapes: scene.shapes.iter().filter(|s| !s.bounds().is_finite()).count(),
        }
    }

    /// Primitives of one kind.
    pub fn count(&self, kind: ShapeKind) -> usize {
        self.primitives[ShapeKind::ALL.iter().position(|k| *k == kind).unwrap_or(0)]
    }
}

impl fmt::Display for SceneSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let kinds: Vec<String> =
            ShapeKind::ALL.iter().zip(self.primitives).map(|(k, n)| format!("{n} {}", k.name())).collect();
        writeln!(f, "shapes:       {} top-level; primitives: {}", self.top_level_shapes, kinds.join(", "))?;
        writeln!(f, "csg:          {} nodes, max depth {}", self.csg_nodes, self.csg_max_depth)?;
        if self.mesh_instances > 0 {
            let triangles: usize = self.meshes.iter().map(|m| m.triangles).sum();
            writeln!(
                f,
                "meshes:       {} instance(s) of {} mesh(es), {triangles} distinct triangles",
                self.mesh_instances,
                self.meshes.len()
            )?;
            for m in &self.meshes {
                let b = &m.bounds;
                writeln!(
                    f,
                    "  {}: {} triangles, {} vertices{}{}{}, ×{}, bounds {}",
                    m.name,
                    m.triangles,
                    m.vertices,
                    if m.smooth_normals { ", normals" } else { "" },
                    if m.uvs { ", uvs" } else { "" },
                    if m.dropped_degenerate > 0 {
                        format!(", {} degenerate dropped", m.dropped_degenerate)
                    } else {
                        String::new()
                    },
                    m.instances,
                    box_text(b)
                )?;
            }
        }
        writeln!(
            f,
            "lights:       {} point, {} area (emissive spheres, cubes, meshes)",
            self.point_lights, self.area_lights
        )?;
        writeln!(
            f,
            "materials:    {} ({} diffuse, {} specular, {} dielectric, {} conductor, {} plastic; {} emissive)",
            self.materials,
            self.diffuse_materials,
            self.specular_materials,
            self.dielectric_materials,
            self.conductor_materials,
            self.plastic_materials,
            self.emissive_materials
        )?;
        match self.aperture_deg {
            Some(a) => {
                writeln!(f, "camera:       {}, aspect ratio {}, aperture {a:.2}°", self.camera_kind, self.aspect_ratio)?
            }
            None => writeln!(f, "camera:       {}, aspect ratio {}", self.camera_kind, self.aspect_ratio)?,
        }
        writeln!(f, "image:        {}×{}", self.width, self.height)?;
        writeln!(f, "renderer:     {}", self.renderer)?;
        let spp = if self.samples_per_side == 0 {
            "1 ray through each pixel centre".to_string()
        } else {
            format!("{0}×{0} jittered samples per pixel", self.samples_per_side)
        };
        writeln!(f, "tracer:       {spp}, rng state {} inc {}", self.tracer_seed.0, self.tracer_seed.1)?;
        writeln!(f, "environment:  {}", self.environment)?;
        match &self.bounds {
            Some(b) => write!(f, "bounds:       {}", box_text(b))?,
            None => write!(f, "bounds:       no finite shapes")?,
        }
        if self.infinite_shapes > 0 {
            write!(f, "; plus {} infinite shape(s)", self.infinite_shapes)?;
        }
        Ok(())
    }
}

/// A box as `[x, y, z] – [x, y, z]`, each coordinate to 4 decimals, or in scientific
/// notation where that would not show it (a mesh coordinate of 1e300 printed 300 digits).
fn box_text(b: &Aabb) -> String {
    let c = |v: f64| {
        if v != 0.0 && !(1e-4..1e6).contains(&v.abs()) {
            format!("{v:.4e}")
        } else {
            format!("{v:.4}")
        }
    };
    let p = |v: glam::DVec3| format!("[{}, {}, {}]", c(v.x), c(v.y), c(v.z));
    format!("{} – {}", p(b.min), p(b.max))
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::color::Color;
    use crate::scene::{CsgOp, Material, Pigment, SceneBuilder, Transform};

    #[test]
    fn boxes_read_at_any_scale() {
        let b = Aabb { min: DVec3::new(-3.5, 0.0, 1e-7), max: DVec3::new(1e300, 2.25, 123456.0) };
        assert_eq!(box_text(&b), "[-3.5000, 0.0000, 1.0000e-7] – [1.0000e300, 2.2500, 123456.0000]");
    }

    #[test]
    fn counts_and_bounds_of_a_built_scene() {
        let mut b = SceneBuilder::new(8, 4);
        let lamp = b.material(Material::new(Brdf::default(), Pigment::Uniform(Color::WHITE)));
        let glass = b.material(Material::new(
            Brdf::Dielectric { pigment: Pigment::default(), ior: 1.5, roughness: 0.0, multiple_scattering: true },
            Pigment::Uniform(Color::BLACK),
        ));
        let t = |x: f64| Transform::translation(DVec3::new(x, 0.0, 0.0));
        b.sphere(t(2.0), lamp).cube(t(-3.0), lamp).plane(Transform::IDENTITY, glass);
        let inner = Shape::csg(
            CsgOp::Diff,
            vec![
                Shape::primitive(ShapeKind::Cylinder, t(0.0), glass),
                Shape::primitive(ShapeKind::Sphere, t(0.0), glass),
            ],
            Transform::IDENTITY,
        );
        b.shape(Shape::csg(CsgOp::Unite, vec![inner, Shape::primitive(ShapeKind::Cube, t(0.0), glass)], t(5.0)));
        let s = SceneSummary::of(&b.build().unwrap());
        assert_eq!((s.top_level_shapes, s.primitives), (4, [2, 1, 2, 1]));
        assert_eq!((s.csg_nodes, s.csg_max_depth, s.area_lights, s.infinite_shapes), (2, 2, 2, 1));
        assert_eq!((s.materials, s.dielectric_materials, s.emissive_materials), (2, 1, 1));
        assert_eq!((s.diffuse_materials, s.conductor_materials, s.plastic_materials), (1, 0, 0));
        // Sphere at x = 2 (radius 1), cube at x = −3 (half-side 0.5), CSG tree at x = 5.
        let bounds = s.bounds.unwrap();
        assert_eq!((bounds.min, bounds.max), (DVec3::new(-3.5, -1.0, -1.0), DVec3::new(5.5, 1.0, 1.0)));
        assert_eq!(
            (s.camera_kind, s.aperture_deg, s.width, s.height),
            ("perspective", Some(2.0 * 1f64.atan2(2.0).to_degrees()), 8, 4)
        );
        let text = s.to_string();
        assert!(
            text.contains("2 sphere, 1 plane, 2 cube, 1 cylinder") && text.contains("plus 1 infinite shape"),
            "{text}"
        );
    }
}
