//! Round spheres: unit spheres placed by a similarity (s times a rotation or reflection,
//! then a translation), which both renderers test in the world, about their centre with
//! radius s, instead of moving the ray into object space (DESIGN.md "Round spheres").
//! The quadratic |o + t·d − c|² = s² has the same roots t as the object-space one.

use std::ops::RangeInclusive;

use glam::DVec3;

use crate::scene::{Primitive, Shape, ShapeKind};

/// The radii (similarity scales) a round sphere may have: 2⁻²⁰ to 2²⁰. Within them the
/// world-space test's squared radius and distances stay far inside f32's range wherever
/// the object-space test's do (the GPU's concern); the extreme scales of STABILITY.md keep
/// the object-space test in both renderers.
pub const ROUND_SCALES: RangeInclusive<f64> = (1.0 / 1048576.0)..=1048576.0;

/// A round sphere's centre and squared radius.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoundSphere {
    /// The transformation's translation.
    pub centre: DVec3,
    /// The squared length of the first row of the transformation's linear part, s² for a
    /// similarity: what the GPU's leaf test reads from the packed `to_world`
    /// (`shaders/shapes.wgsl`, `shape_first_crossing`).
    pub radius2: f64,
}

impl RoundSphere {
    /// The round sphere `p` is: a sphere whose transformation is a similarity
    /// (`Transform::similarity_scale`) of scale within [`ROUND_SCALES`].
    ///
    /// ```
    /// use lumen::prepare::RoundSphere;
    /// use lumen::scene::{MaterialId, Primitive, ShapeKind, Transform};
    /// use glam::DVec3;
    /// let t = Transform::translation(DVec3::new(1.0, 2.0, 3.0)) * Transform::scaling(DVec3::splat(-0.5));
    /// let p = Primitive { kind: ShapeKind::Sphere, transform: t, material: MaterialId(0) };
    /// assert_eq!(RoundSphere::of(&p), Some(RoundSphere { centre: DVec3::new(1.0, 2.0, 3.0), radius2: 0.25 }));
    /// let egg = Primitive { transform: Transform::scaling(DVec3::new(1.0, 1.0, 2.0)), ..p };
    /// assert_eq!(RoundSphere::of(&egg), None);
    /// ```
    pub fn of(p: &Primitive) -> Option<RoundSphere> {
        if p.kind != ShapeKind::Sphere || !p.transform.similarity_scale().is_some_and(|s| ROUND_SCALES.contains(&s)) {
            return None;
        }
        let m = p.transform.matrix();
        Some(RoundSphere { centre: m.w_axis.truncate(), radius2: m.row(0).truncate().length_squared() })
    }
}

/// Whether every finite top-level shape is a round sphere (planes beside them allowed):
/// then the renderers test the spheres in the world. One rule for both, so that their
/// sphere tests read alike; on the GPU, where a SIMD group runs one test for all its lanes,
/// it decides the kernel (`gpu::features::FeatureSet::round_spheres`).
pub fn all_round(shapes: &[Shape]) -> bool {
    shapes.iter().all(|s| match s {
        Shape::Primitive(p) => p.kind == ShapeKind::Plane || RoundSphere::of(p).is_some(),
        _ => false,
    })
}
