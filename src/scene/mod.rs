//! The scene model: the one description of a scene that every renderer consumes.
//!
//! SceneLang scripts evaluate to a [`Scene`]; the CPU reference reads it directly and the
//! GPU renderer packs it into buffers. Code can build the same scenes with
//! [`SceneBuilder`].

mod bounds;
mod brdf;
mod builder;
mod camera;
mod environment;
mod light;
mod material;
pub mod mesh;
mod origins;
mod pigment;
mod settings;
mod shape;
mod transform;

pub use bounds::Aabb;
pub use brdf::{Brdf, DEFAULT_THRESHOLD_ANGLE_RAD};
pub use builder::SceneBuilder;
pub use camera::{Camera, CameraRay, Projection, CAMERA_RAY_TMIN};
pub use environment::{equirect_uv, texel_radiance, Environment};
pub use light::PointLight;
pub use material::{Material, MaterialId};
pub use mesh::{MeshError, MeshErrorKind, MeshFormat, MeshLocation, MeshParts, TriangleMesh, MAX_MESH_ELEMENTS};
pub use origins::ShapeOrigins;
pub use pigment::{ImageFilter, Pigment};
pub use settings::{PathTracerSettings, PcgSeed, Renderer, Tracer};
pub use shape::{Csg, CsgOp, MeshInstance, Primitive, Shape, ShapeKind, MAX_CSG_DEPTH, MAX_PRIMITIVES};
pub use transform::Transform;

/// Largest image side lumen accepts; larger sizes are input errors, not allocations.
pub const MAX_IMAGE_SIDE: u32 = 32_768;

/// Most pixels a render may have: what lumen's image files take
/// ([`crate::image::MAX_PIXELS`], 16384² = 2²⁸), so that no render is refused only when its
/// output is written (a 32768×32768 script rendered, on a machine with the memory, for as
/// long as it took, and then could not be written).
pub const MAX_IMAGE_PIXELS: u64 = crate::image::MAX_PIXELS as u64;

/// Whether `width × height` can be rendered: each side 1..=[`MAX_IMAGE_SIDE`], at most
/// [`MAX_IMAGE_PIXELS`] in all.
///
/// ```
/// use lumen::scene::renderable_size;
/// assert!(renderable_size(32_768, 8_192));
/// assert!(!renderable_size(32_768, 32_768), "2³⁰ pixels");
/// assert!(!renderable_size(0, 4) && !renderable_size(40_000, 1));
/// ```
pub fn renderable_size(width: u32, height: u32) -> bool {
    (1..=MAX_IMAGE_SIDE).contains(&width)
        && (1..=MAX_IMAGE_SIDE).contains(&height)
        && crate::image::check_size(width as usize, height as usize).is_ok()
}

/// What [`renderable_size`] asks, in words, for messages.
pub fn renderable_size_rule() -> String {
    format!("each side from 1 to {MAX_IMAGE_SIDE}, and at most {MAX_IMAGE_PIXELS} pixels in all")
}

/// Problems that make a scene invalid (raised while building or loading it).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SceneError {
    /// A transformation has no usable inverse: a zero scale factor, or a matrix whose
    /// determinant is zero or negligible next to the scale of its linear part.
    #[error("transformation is singular (zero scale or degenerate matrix)")]
    SingularTransform,
    /// A transformation (or scale factor) has a NaN or infinite entry.
    #[error("transformation has a non-finite entry (NaN or infinity)")]
    NonFiniteTransform,
    /// A matrix's last row is not `0 0 0 1`: Raytracer.jl accepts projective matrices,
    /// lumen does not.
    #[error("transformation is not affine: only affine matrices (last row 0 0 0 1) are supported")]
    NotAffine,
    /// The image's width and height, in pixels, which [`renderable_size`] refuses.
    #[error("image size {0}×{1} cannot be rendered ({rule})", rule = renderable_size_rule())]
    BadImageSize(u32, u32),
    /// Any other invalid scene, with the message shown to the user: a material id out of
    /// range, a mesh inside CSG, a camera's non-positive aspect ratio or screen distance, or
    /// (from the GPU packer) an emissive surface of zero area.
    #[error("{0}")]
    Invalid(String),
}

/// A complete scene: geometry, appearance, lights, camera and render settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Top-level shapes (a CSG tree is one shape).
    pub shapes: Vec<Shape>,
    /// Materials referenced by [`MaterialId`].
    pub materials: Vec<Material>,
    /// Point lights (SceneLang's `Light`); area lights are emissive shapes instead (see
    /// [`Scene::area_lights`]).
    pub point_lights: Vec<PointLight>,
    /// The one camera the image is seen through.
    pub camera: Camera,
    /// Image width in pixels, 1..=[`MAX_IMAGE_SIDE`] ([`renderable_size`]) once
    /// [`Scene::validate`] has passed.
    pub width: u32,
    /// Image height in pixels, 1..=[`MAX_IMAGE_SIDE`] ([`renderable_size`]) once
    /// [`Scene::validate`] has passed.
    pub height: u32,
    /// The integrator that turns a camera ray into radiance, with its settings.
    pub renderer: Renderer,
    /// How many camera rays each pixel gets and where, and the seed of every random stream.
    pub tracer: Tracer,
    /// Radiance of escaping rays; `None` means the renderer's background colour.
    pub environment: Option<Environment>,
    /// Where the script wrote each shape (empty for a scene built in code): for messages
    /// only, never read by a renderer.
    pub origins: ShapeOrigins,
}

/// A top-level shape whose material emits, with a surface that can be sampled (a sphere,
/// a cube or a mesh): the path tracer's area lights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EmissiveShape {
    /// Index into [`Scene::shapes`].
    pub shape: usize,
}

impl Scene {
    /// The material `id` refers to. Panics if `id` is out of range, which a scene that
    /// passed [`Scene::validate`] rules out.
    pub fn material(&self, id: MaterialId) -> &Material {
        &self.materials[id.0 as usize]
    }

    /// Radiance for an escaping ray direction: the environment if any, else the
    /// renderer's background colour.
    pub fn escape_radiance(&self, dir: glam::DVec3) -> crate::color::Color {
        match &self.environment {
            Some(env) => env.radiance(dir),
            None => self.renderer.background(),
        }
    }

    /// Emissive top-level spheres, cubes and mesh instances, in shape order. Emitters inside
    /// CSG trees, planes and cylinders are not sampled directly; their emission still counts when a
    /// path hits them (with full weight, so the estimate stays unbiased).
    pub fn area_lights(&self) -> Vec<EmissiveShape> {
        self.shapes
            .iter()
            .enumerate()
            .filter_map(|(i, s)| match s {
                Shape::Primitive(p)
                    if matches!(p.kind, ShapeKind::Sphere | ShapeKind::Cube)
                        && self.material(p.material).is_emissive() =>
                {
                    Some(EmissiveShape { shape: i })
                }
                Shape::Mesh(m) if self.material(m.material).is_emissive() => Some(EmissiveShape { shape: i }),
                _ => None,
            })
            .collect()
    }

    /// World bounds of all finite shapes (infinite planes excluded), or `None` if there are
    /// none.
    pub fn finite_bounds(&self) -> Option<Aabb> {
        let b = self.shapes.iter().map(Shape::bounds).filter(Aabb::is_finite).fold(Aabb::EMPTY, |a, b| a.union(&b));
        (!b.is_empty()).then_some(b)
    }

    /// Checks invariants a renderer relies on: image size, material ids, finite settings.
    pub fn validate(&self) -> Result<(), SceneError> {
        if !renderable_size(self.width, self.height) {
            return Err(SceneError::BadImageSize(self.width, self.height));
        }
        let n = self.materials.len();
        let mut bad = None;
        for s in &self.shapes {
            s.for_each_material(&mut |m| {
                if m.0 as usize >= n {
                    bad = Some(m.0);
                }
            });
        }
        if let Some(id) = bad {
            return Err(SceneError::Invalid(format!(
                "shape refers to material #{id}, but the scene has {n} materials"
            )));
        }
        fn mesh_in_csg(s: &Shape) -> bool {
            match s {
                Shape::Csg(c) => c.children.iter().any(|c| matches!(c, Shape::Mesh(_)) || mesh_in_csg(c)),
                _ => false,
            }
        }
        if self.shapes.iter().any(mesh_in_csg) {
            return Err(SceneError::Invalid("a mesh cannot be a CSG operand".into()));
        }
        if !(self.camera.aspect_ratio.is_finite() && self.camera.aspect_ratio > 0.0) {
            return Err(SceneError::Invalid(format!(
                "camera aspect ratio must be positive, got {}",
                self.camera.aspect_ratio
            )));
        }
        if let Projection::Perspective { screen_distance } = self.camera.projection {
            if !(screen_distance.is_finite() && screen_distance > 0.0) {
                return Err(SceneError::Invalid(format!("screen distance must be positive, got {screen_distance}")));
            }
        }
        Ok(())
    }
}
