//! A unit primitive placed in the world by a transformation.

use glam::{DVec2, DVec3};

use super::{span, surface, Crossing, Span};
use crate::cpu::offset::error_scale;
use crate::cpu::{normalize_scaled, Ray};
use crate::scene::{MaterialId, ShapeKind, Transform};

/// A unit primitive with its full object-to-world transformation (for CSG leaves, the
/// product of the transformations of every enclosing node).
#[derive(Debug, Clone, PartialEq)]
pub struct Instance {
    /// Which unit primitive.
    pub kind: ShapeKind,
    /// Object-to-world transformation.
    pub to_world: Transform,
    /// Material of the primitive's surface.
    pub material: MaterialId,
}

/// World-space surface data at a crossing, oriented against the ray (what every kind of
/// object reports, and the surface half of a closest hit, [`crate::cpu::Hit`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceHit {
    /// World-space point (computed from the object-space hit, not `origin + t·dir`, for
    /// accuracy).
    pub point: DVec3,
    /// Error scale of `point` (`offset::error_scale`): what spawned rays offset by.
    pub scale: f64,
    /// Unit shading normal, on the side the ray comes from (`normal · dir ≤ 0` but for
    /// interpolated mesh normals at grazing angles).
    pub normal: DVec3,
    /// Unit geometric normal with `geometric · dir ≤ 0`: it decides sidedness and offsets.
    /// Equal to `normal` but on smooth meshes.
    pub geometric: DVec3,
    /// The outward normal faced the ray (`outward · dir < 0`): the ray arrived from outside.
    pub front_face: bool,
    /// Surface coordinates per SCENELANG.md.
    pub uv: DVec2,
}

impl SurfaceHit {
    /// Whether a direction leaving the surface is on the same side of the geometric surface
    /// as the shading normal says: interpolated normals must not send light through a
    /// surface (or take it from behind one). Always true where the two normals are equal.
    pub fn consistent(&self, dir: DVec3) -> bool {
        (dir.dot(self.normal) > 0.0) == (dir.dot(self.geometric) > 0.0)
    }
}

impl Instance {
    /// The ray in object space. The parameter t means the same point in both spaces
    /// because the direction is transformed without normalising it.
    pub fn local_ray(&self, ray: &Ray) -> (DVec3, DVec3) {
        let inv = self.to_world.inverse_matrix();
        (inv.transform_point3(ray.origin), inv.transform_vector3(ray.dir))
    }

    /// The span of the ray's whole line through the solid.
    pub fn span(&self, ray: &Ray) -> Option<Span> {
        let (o, d) = self.local_ray(ray);
        span(self.kind, o, d)
    }

    /// The first surface crossing with t in the open range (tmin, tmax).
    pub fn first_crossing(&self, ray: &Ray) -> Option<Crossing> {
        self.span(ray)?.first_within(ray)
    }

    /// Surface point, normal and uv at crossing `c` of this ray. `flip` reverses the
    /// outward normal (surfaces carved by a subtracted CSG child).
    pub fn surface_hit(&self, ray: &Ray, c: Crossing, flip: bool) -> SurfaceHit {
        let (o, d) = self.local_ray(ray);
        let s = surface(self.kind, o + c.t * d, c.face);
        let point = self.to_world.point(s.point);
        let scale = error_scale(&self.to_world.matrix(), s.point);
        let n = normalize_scaled(self.to_world.normal(s.normal));
        let outward = if flip { -n } else { n };
        let front_face = outward.dot(ray.dir) < 0.0;
        let normal = if front_face { outward } else { -outward };
        SurfaceHit { point, scale, normal, geometric: normal, front_face, uv: s.uv }
    }
}
