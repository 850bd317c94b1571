//! Unit cylinder: axis z, radius 0.5, z ∈ [−0.5, 0.5], closed by two caps.

use glam::{DVec2, DVec3};

use super::{slab, sphere_roots, Crossing, Span, SurfacePoint};

/// Face codes.
const SIDE: u8 = 0;
const BOTTOM: u8 = 1;
const TOP: u8 = 2;

/// The infinite solid cylinder's interval (the stable quadratic in the xy plane) intersected
/// with the slab |z| ≤ 0.5; axis-parallel lines are decided by the origin alone.
pub(super) fn span(o: DVec3, d: DVec3) -> Option<Span> {
    let (fxy, dxy) = (DVec3::new(o.x, o.y, 0.0), DVec3::new(d.x, d.y, 0.0));
    let (mut enter, mut exit) = if dxy == DVec3::ZERO {
        if fxy.length_squared() > 0.25 {
            return None;
        }
        (Crossing::open(f64::NEG_INFINITY), Crossing::open(f64::INFINITY))
    } else {
        let (t0, t1) = sphere_roots(fxy, dxy, 0.25)?;
        (Crossing::new(t0, SIDE), Crossing::new(t1, SIDE))
    };
    if !slab::clip(&mut enter, &mut exit, o.z, d.z, BOTTOM, TOP) {
        return None;
    }
    (enter.t <= exit.t).then_some(Span { enter, exit })
}

/// Side: uv = (z + 0.5, (atan2(y, x)/2π + 1)/2); top cap: ((3 − 2x)/4, (3 − 2y)/4);
/// bottom cap: ((3 − 2x)/4, (1 + 2y)/4), as SCENELANG.md specifies.
pub(super) fn surface(p: DVec3, face: u8) -> SurfacePoint {
    match face {
        SIDE => {
            let r = DVec3::new(p.x, p.y, 0.0).normalize_or(DVec3::X);
            let z = p.z.clamp(-0.5, 0.5);
            let uv = DVec2::new(z + 0.5, (r.y.atan2(r.x) / std::f64::consts::TAU + 1.0) / 2.0);
            SurfacePoint { point: DVec3::new(0.5 * r.x, 0.5 * r.y, z), normal: r, uv }
        }
        TOP => SurfacePoint {
            point: DVec3::new(p.x, p.y, 0.5),
            normal: DVec3::Z,
            uv: DVec2::new((3.0 - 2.0 * p.x) / 4.0, (3.0 - 2.0 * p.y) / 4.0),
        },
        _ => SurfacePoint {
            point: DVec3::new(p.x, p.y, -0.5),
            normal: -DVec3::Z,
            uv: DVec2::new((3.0 - 2.0 * p.x) / 4.0, (1.0 + 2.0 * p.y) / 4.0),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn side_and_caps() {
        let s = span(DVec3::new(-2.0, 0.0, 0.0), DVec3::X).unwrap();
        assert_eq!((s.enter.t, s.exit.t, s.enter.face, s.exit.face), (1.5, 2.5, SIDE, SIDE));
        let s = span(DVec3::new(0.1, 0.2, -3.0), DVec3::Z).unwrap();
        assert_eq!((s.enter.t, s.exit.t, s.enter.face, s.exit.face), (2.5, 3.5, BOTTOM, TOP));
        // Through the rim: enters through the top cap edge exactly.
        let s = span(DVec3::new(-1.0, 0.0, 1.5), DVec3::new(1.0, 0.0, -2.0)).unwrap();
        assert_eq!(s.enter.t, 0.5);
        assert!(span(DVec3::new(0.0, 0.6, -3.0), DVec3::Z).is_none());
        assert!(span(DVec3::new(-3.0, 0.0, 0.6), DVec3::X).is_none());
    }

    #[test]
    fn uv_follows_the_spec() {
        let s = surface(DVec3::new(0.0, 0.5, 0.25), SIDE);
        assert!((s.uv - DVec2::new(0.75, 0.625)).length() < 1e-15, "{}", s.uv);
        assert_eq!(s.normal, DVec3::Y);
        let s = surface(DVec3::new(0.5, 0.0, 0.5), TOP);
        assert_eq!(s.uv, DVec2::new(0.5, 0.75));
        let s = surface(DVec3::new(-0.5, -0.5, -0.5), BOTTOM);
        assert_eq!(s.uv, DVec2::new(1.0, 0.0));
        assert_eq!(s.normal, -DVec3::Z);
    }
}
