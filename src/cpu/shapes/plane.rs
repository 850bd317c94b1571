//! Unit plane: z = 0 with normal +z; as a solid, the half-space z ≤ 0.

use glam::{DVec2, DVec3};

use super::{Crossing, Span, SurfacePoint};

pub(super) fn span(o: DVec3, d: DVec3) -> Option<Span> {
    if parallel(d) {
        // Parallel: entirely inside (on or below the plane) or entirely outside.
        return (o.z <= 0.0)
            .then_some(Span { enter: Crossing::open(f64::NEG_INFINITY), exit: Crossing::open(f64::INFINITY) });
    }
    let t = -o.z / d.z;
    Some(if d.z > 0.0 {
        Span { enter: Crossing::open(f64::NEG_INFINITY), exit: Crossing::new(t, 0) }
    } else {
        Span { enter: Crossing::new(t, 0), exit: Crossing::open(f64::INFINITY) }
    })
}

/// Whether direction `d` runs parallel to the plane, within
/// [`crate::prepare::PLANE_PARALLEL_SLOPE`] (shaders/plane.wgsl applies the same rule).
fn parallel(d: DVec3) -> bool {
    d.z.abs() <= crate::prepare::PLANE_PARALLEL_SLOPE * d.abs().max_element()
}

/// uv = (x − ⌊x⌋, y − ⌊y⌋), kept in [0, 1) where rounding would give 1.
pub(super) fn surface(p: DVec3) -> SurfacePoint {
    let frac = |x: f64| {
        let f = x - x.floor();
        if f >= 1.0 {
            0.0
        } else {
            f
        }
    };
    SurfacePoint { point: DVec3::new(p.x, p.y, 0.0), normal: DVec3::Z, uv: DVec2::new(frac(p.x), frac(p.y)) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_space_spans() {
        let s = span(DVec3::new(0.0, 0.0, 2.0), DVec3::new(1.0, 0.0, -0.5)).unwrap();
        assert_eq!(s.enter.t, 4.0);
        assert_eq!(s.exit.t, f64::INFINITY);
        let s = span(DVec3::new(0.0, 0.0, -2.0), DVec3::new(1.0, 0.0, 0.5)).unwrap();
        assert_eq!((s.enter.t, s.exit.t), (f64::NEG_INFINITY, 4.0));
        assert!(span(DVec3::new(0.0, 0.0, 1.0), DVec3::X).is_none());
        assert!(span(DVec3::new(0.0, 0.0, 0.0), DVec3::X).is_some());
    }

    /// A direction within 2⁻²⁰ of the plane is parallel to it: the plane is all inside
    /// (the ray on or below it) or all outside, whatever the sign of d.z; a steeper one
    /// crosses it where the line does.
    #[test]
    fn nearly_parallel_rays_are_parallel() {
        let slope = crate::prepare::PLANE_PARALLEL_SLOPE;
        for dz in [slope, -slope, 1e-17, -1e-17, 0.0] {
            let d = DVec3::new(1.0, -0.5, dz);
            assert!(span(DVec3::new(0.0, 0.0, 1.0), d).is_none(), "{dz}");
            let inside = span(DVec3::new(0.0, 0.0, -1.0), d).unwrap();
            assert_eq!((inside.enter.t, inside.exit.t), (f64::NEG_INFINITY, f64::INFINITY), "{dz}");
        }
        let steeper = span(DVec3::new(0.0, 0.0, 1.0), DVec3::new(1.0, 0.0, -2.0 * slope)).unwrap();
        assert_eq!(steeper.enter.t, 1.0 / (2.0 * slope));
        // The rule is relative: a short direction is as parallel as a long one.
        assert!(span(DVec3::new(0.0, 0.0, 1.0), DVec3::new(1e-30, 0.0, -1e-37)).is_none());
        assert!(span(DVec3::new(0.0, 0.0, 1.0), DVec3::new(1e-30, 0.0, -1e-35)).is_some());
    }

    #[test]
    fn uv_is_the_fractional_part() {
        let s = surface(DVec3::new(2.25, -0.25, 1e-9));
        assert_eq!(s.uv, DVec2::new(0.25, 0.75));
        assert_eq!(s.point.z, 0.0);
        assert_eq!(surface(DVec3::new(-1e-20, 0.0, 0.0)).uv.x, 0.0);
    }
}
