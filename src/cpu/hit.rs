//! What a closest-hit query returns.

use glam::{DVec2, DVec3};

use crate::scene::MaterialId;

/// A ray–surface intersection in world space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit.
    pub t: f64,
    /// World-space point (computed from the object-space hit, not `origin + t·dir`, for
    /// accuracy).
    pub point: DVec3,
    /// Error scale of `point` (`offset::error_scale`): what spawned rays offset by.
    pub scale: f64,
    /// Unit shading normal, facing the incoming ray (`normal · dir ≤ 0`).
    pub normal: DVec3,
    /// True when the ray arrived from the outside of the surface (before flipping).
    pub front_face: bool,
    /// Surface coordinates per SCENELANG.md.
    pub uv: DVec2,
    pub material: MaterialId,
    /// Index of the top-level shape in `Scene::shapes`.
    pub shape: u32,
}
