//! The form of a scene the renderers consume: the script's scene with every top-level
//! UNITE split into its parts ([`Shape::top_level_parts`]). A UNITE keeps every surface, so
//! its parts render the same image; as separate top-level shapes they go into the BVH one
//! by one instead of through the CSG evaluation (DESIGN.md "Top-level UNITEs"). Both
//! renderers, and the GPU's feature set, start from this form, so shape indices (area
//! lights, BVH leaves) mean the same everywhere; `lumen check` and DUMP show the script's
//! own structure.

use std::borrow::Cow;

use crate::scene::{Scene, Shape};

/// Where shape `index` of [`render_form`]`(scene)` comes from: its index in `scene.shapes`
/// and, for a part of a split top-level UNITE, which part (both from 0); `None` past the
/// end. For messages that name a shape as the script wrote it.
///
/// ```
/// use lumen::scene::*;
/// let mut b = SceneBuilder::new(4, 4);
/// let m = b.diffuse(lumen::color::Color::gray(0.5));
/// let ball = |x: f64| Shape::primitive(ShapeKind::Sphere, Transform::translation(glam::DVec3::new(x, 0.0, 0.0)), m);
/// b.shape(Shape::csg(CsgOp::Unite, vec![ball(0.0), ball(3.0)], Transform::IDENTITY)).shape(ball(6.0));
/// let scene = b.build().unwrap();
/// assert_eq!(lumen::prepare::source_shape(&scene, 1), Some((0, Some(1))));
/// assert_eq!(lumen::prepare::source_shape(&scene, 2), Some((1, None)));
/// assert_eq!(lumen::prepare::source_shape(&scene, 3), None);
/// ```
pub fn source_shape(scene: &Scene, index: usize) -> Option<(usize, Option<usize>)> {
    let mut start = 0;
    for (k, s) in scene.shapes.iter().enumerate() {
        let parts = if s.splits_at_top_level() { s.clone().top_level_parts().len() } else { 1 };
        if index < start + parts {
            return Some((k, s.splits_at_top_level().then_some(index - start)));
        }
        start += parts;
    }
    None
}

/// `scene` itself when no top-level shape splits, else a copy with the parts in place of
/// each splitting UNITE, in order (textures and meshes are shared, not copied).
///
/// ```
/// use lumen::scene::*;
/// let mut b = SceneBuilder::new(4, 4);
/// let m = b.diffuse(lumen::color::Color::gray(0.5));
/// let ball = |x: f64| Shape::primitive(ShapeKind::Sphere, Transform::translation(glam::DVec3::new(x, 0.0, 0.0)), m);
/// b.shape(Shape::csg(CsgOp::Unite, vec![ball(0.0), ball(3.0)], Transform::IDENTITY));
/// let scene = b.build().unwrap();
/// assert_eq!(scene.shapes.len(), 1);
/// assert_eq!(lumen::prepare::render_form(&scene).shapes.len(), 2);
/// ```
pub fn render_form(scene: &Scene) -> Cow<'_, Scene> {
    if !scene.shapes.iter().any(Shape::splits_at_top_level) {
        return Cow::Borrowed(scene);
    }
    let Scene { shapes, materials, point_lights, camera, width, height, renderer, tracer, environment, origins: _ } =
        scene;
    Cow::Owned(Scene {
        shapes: shapes.iter().flat_map(|s| s.clone().top_level_parts()).collect(),
        materials: materials.clone(),
        point_lights: point_lights.clone(),
        camera: *camera,
        width: *width,
        height: *height,
        renderer: renderer.clone(),
        tracer: *tracer,
        environment: environment.clone(),
        // Its shapes are parts: a message about one finds the script's shape, and where it
        // was written, through `source_shape`.
        origins: crate::scene::ShapeOrigins::default(),
    })
}
