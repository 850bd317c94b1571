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
    /// Unit shading normal, facing the incoming ray (`normal · dir ≤ 0`; smooth meshes'
    /// interpolated normals may lean past that at grazing angles).
    pub normal: DVec3,
    /// Unit geometric normal facing the incoming ray: sidedness and ray offsets. Equal to
    /// `normal` except on smooth meshes.
    pub geometric: DVec3,
    /// True when the ray arrived from the outside of the surface (before flipping).
    pub front_face: bool,
    /// Surface coordinates per SCENELANG.md.
    pub uv: DVec2,
    pub material: MaterialId,
    /// Index of the top-level shape in `Scene::shapes`.
    pub shape: u32,
}

impl Hit {
    /// Whether a direction leaving the hit is on the same side of the geometric surface as
    /// the shading normal says: interpolated normals must not send light through a surface
    /// (or take it from behind one). Always true where the two normals are equal.
    pub fn consistent(&self, dir: DVec3) -> bool {
        (dir.dot(self.normal) > 0.0) == (dir.dot(self.geometric) > 0.0)
    }
}
