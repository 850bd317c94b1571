//! The four unit primitives in object space: where a line crosses them, and the surface
//! (point, normal, uv) at a crossing.
//!
//! Every unit primitive is convex (the plane as the half-space z ≤ 0), so a line meets its
//! solid in at most one interval, its [`Span`]. A lone primitive's hit is the first end of
//! the span inside the ray's range; CSG combines spans. Transformed shapes are handled by
//! [`Instance`], which moves the ray into object space (t is unchanged by that).

mod cube;
mod cylinder;
mod instance;
mod plane;
mod quadratic;
mod slab;
mod sphere;

use glam::{DVec2, DVec3};

use crate::cpu::Ray;
use crate::scene::ShapeKind;

pub use cube::CUBE_FACE_LAYOUT;
pub use instance::{Instance, SurfaceHit};
pub use quadratic::sphere_roots;

/// Where the line crosses a primitive's surface: its parameter and which face (cube:
/// `2·axis + (1 if the + side)`; cylinder: 0 side, 1 bottom cap, 2 top cap; others 0).
/// An infinite `t` marks an open end of a span (no surface there).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crossing {
    /// Line parameter of the crossing (object and world space alike); ±∞ for an open end.
    pub t: f64,
    /// Which face of the primitive is crossed, numbered as above.
    pub face: u8,
}

impl Crossing {
    /// A crossing of `face` at parameter `t`.
    pub const fn new(t: f64, face: u8) -> Self {
        Self { t, face }
    }
    /// An open end at ±∞.
    pub const fn open(t: f64) -> Self {
        Self { t, face: 0 }
    }
}

/// The interval of the line inside the solid: `enter.t ≤ exit.t`, either end possibly
/// infinite (planes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Span {
    /// Where the line enters the solid; `t = −∞` where the solid is unbounded behind.
    pub enter: Crossing,
    /// Where the line leaves the solid; `t = +∞` where the solid is unbounded ahead.
    pub exit: Crossing,
}

impl Span {
    /// The first of its crossings with a finite t in the open range (tmin, tmax) of `ray`
    /// (`span_first_crossing` in shaders/shapes.wgsl).
    pub fn first_within(&self, ray: &Ray) -> Option<Crossing> {
        [self.enter, self.exit].into_iter().find(|c| c.t > ray.tmin && c.t < ray.tmax && c.t.is_finite())
    }
}

/// Object-space surface data at a crossing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// The crossing point snapped exactly onto the surface (removes the error of `o + t·d`
    /// along the normal, which grows with the distance of the origin).
    pub point: DVec3,
    /// Outward normal (not necessarily unit length).
    pub normal: DVec3,
    /// Texture coordinates of the point, per SCENELANG.md.
    pub uv: DVec2,
}

/// The span of the line `o + t·d` (object space, any t) through the unit primitive.
pub fn span(kind: ShapeKind, o: DVec3, d: DVec3) -> Option<Span> {
    if d == DVec3::ZERO || !o.is_finite() || !d.is_finite() {
        return None;
    }
    match kind {
        ShapeKind::Sphere => sphere::span(o, d),
        ShapeKind::Plane => plane::span(o, d),
        ShapeKind::Cube => cube::span(o, d),
        ShapeKind::Cylinder => cylinder::span(o, d),
    }
}

/// Surface point, outward normal and uv (per SCENELANG.md) at object-space point `p`
/// found on `face`.
pub fn surface(kind: ShapeKind, p: DVec3, face: u8) -> SurfacePoint {
    match kind {
        ShapeKind::Sphere => sphere::surface(p),
        ShapeKind::Plane => plane::surface(p),
        ShapeKind::Cube => cube::surface(p, face),
        ShapeKind::Cylinder => cylinder::surface(p, face),
    }
}

/// `atan2(y, x)/2π` wrapped to [0, 1).
pub(crate) fn turns(y: f64, x: f64) -> f64 {
    let u = y.atan2(x) / std::f64::consts::TAU;
    // `abs` turns atan2's −0 (y = −0) into +0.
    let u = if u < 0.0 { u + 1.0 } else { u.abs() };
    if u >= 1.0 {
        0.0
    } else {
        u
    }
}
