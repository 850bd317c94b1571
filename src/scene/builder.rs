//! Building scenes from Rust code: the low-level API under SceneLang.

use crate::color::Color;

use super::*;

/// Assembles a [`Scene`] step by step, with SceneLang's defaults for everything left out.
///
/// ```
/// use lumen::scene::*;
/// use lumen::color::Color;
/// use glam::DVec3;
///
/// let mut b = SceneBuilder::new(64, 48);
/// let red = b.material(Material::new(
///     Brdf::Diffuse { pigment: Pigment::Uniform(Color::new(0.8, 0.1, 0.1)) },
///     Pigment::Uniform(Color::BLACK),
/// ));
/// b.sphere(Transform::translation(DVec3::new(3.0, 0.0, 0.0)), red)
///     .point_light(PointLight { position: DVec3::new(0.0, 0.0, 5.0), ..Default::default() })
///     .renderer(Renderer::PointLight { background: Color::BLACK, ambient: Color::gray(1e-3) });
/// let scene = b.build().unwrap();
/// assert_eq!(scene.shapes.len(), 1);
/// assert_eq!(scene.width, 64);
/// ```
#[derive(Debug, Clone)]
pub struct SceneBuilder {
    scene: Scene,
}

impl SceneBuilder {
    /// An empty scene of `width × height` pixels with a default perspective camera (aspect
    /// ratio width/height), the path tracer with default settings and no environment.
    pub fn new(width: u32, height: u32) -> Self {
        let aspect = if height > 0 { f64::from(width) / f64::from(height) } else { 1.0 };
        Self {
            scene: Scene {
                shapes: Vec::new(),
                materials: Vec::new(),
                point_lights: Vec::new(),
                camera: Camera { aspect_ratio: aspect, ..Camera::default() },
                width,
                height,
                renderer: Renderer::PathTracer(PathTracerSettings::default()),
                tracer: Tracer::default(),
                environment: None,
                origins: ShapeOrigins::default(),
            },
        }
    }

    /// Adds a material (or finds an equal one already added) and returns its id.
    pub fn material(&mut self, m: Material) -> MaterialId {
        if let Some(i) = self.scene.materials.iter().position(|x| *x == m) {
            return MaterialId(i as u32);
        }
        self.scene.materials.push(m);
        MaterialId((self.scene.materials.len() - 1) as u32)
    }

    /// Shorthand for a diffuse material of the given colour.
    pub fn diffuse(&mut self, c: Color) -> MaterialId {
        self.material(Material::new(Brdf::Diffuse { pigment: Pigment::Uniform(c) }, Pigment::Uniform(Color::BLACK)))
    }

    /// Adds `s` as a top-level shape (a CSG tree is one shape).
    pub fn shape(&mut self, s: Shape) -> &mut Self {
        self.scene.shapes.push(s);
        self
    }
    /// Adds the unit sphere placed by `t` (object to world), made of `m`.
    pub fn sphere(&mut self, t: Transform, m: MaterialId) -> &mut Self {
        self.shape(Shape::primitive(ShapeKind::Sphere, t, m))
    }
    /// Adds the plane z = 0 placed by `t` (object to world), made of `m`.
    pub fn plane(&mut self, t: Transform, m: MaterialId) -> &mut Self {
        self.shape(Shape::primitive(ShapeKind::Plane, t, m))
    }
    /// Adds the cube [−0.5, 0.5]³ placed by `t` (object to world), made of `m`.
    pub fn cube(&mut self, t: Transform, m: MaterialId) -> &mut Self {
        self.shape(Shape::primitive(ShapeKind::Cube, t, m))
    }
    /// Adds the capped cylinder of radius 0.5 and height 1 along z, centred at the origin,
    /// placed by `t` (object to world), made of `m`.
    pub fn cylinder(&mut self, t: Transform, m: MaterialId) -> &mut Self {
        self.shape(Shape::primitive(ShapeKind::Cylinder, t, m))
    }
    /// Adds a point light (see [`PointLight`] for its falloff).
    pub fn point_light(&mut self, l: PointLight) -> &mut Self {
        self.scene.point_lights.push(l);
        self
    }
    /// Replaces the camera. Its aspect ratio is taken as given, not matched to the image
    /// size as [`Self::new`]'s default is.
    pub fn camera(&mut self, c: Camera) -> &mut Self {
        self.scene.camera = c;
        self
    }
    /// Replaces the integrator (by default the path tracer with default settings).
    pub fn renderer(&mut self, r: Renderer) -> &mut Self {
        self.scene.renderer = r;
        self
    }
    /// Replaces the pixel sampling (by default one ray through each pixel centre, seed
    /// `Pcg(.state 42, .inc 54)`).
    pub fn tracer(&mut self, t: Tracer) -> &mut Self {
        self.scene.tracer = t;
        self
    }
    /// Sets what escaping rays see (by default nothing: the renderer's background colour).
    pub fn environment(&mut self, e: Environment) -> &mut Self {
        self.scene.environment = Some(e);
        self
    }

    /// Validates and returns the scene.
    pub fn build(&self) -> Result<Scene, SceneError> {
        self.scene.validate()?;
        Ok(self.scene.clone())
    }

    /// [`Self::build`] without the copy, for a builder that is done.
    pub fn into_scene(self) -> Result<Scene, SceneError> {
        self.scene.validate()?;
        Ok(self.scene)
    }
}
