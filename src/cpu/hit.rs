//! What a closest-hit query returns.

use super::shapes::SurfaceHit;
use crate::scene::MaterialId;

/// A ray–surface intersection in world space: where along the ray, the surface there, and
/// what was hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit.
    pub t: f64,
    /// Point, normals, error scale and surface coordinates, oriented against the ray.
    pub surface: SurfaceHit,
    /// Material of the surface hit (of the CSG leaf whose surface it is, in a CSG tree).
    pub material: MaterialId,
    /// Index of the top-level shape in `Scene::shapes`.
    pub shape: u32,
}
