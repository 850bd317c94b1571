//! Unit sphere: radius 1 at the origin.

use glam::{DVec2, DVec3};

use super::{sphere_roots, Crossing, Span, SurfacePoint};

pub(super) fn span(o: DVec3, d: DVec3) -> Option<Span> {
    let (t0, t1) = sphere_roots(o, d, 1.0)?;
    Some(Span { enter: Crossing::new(t0, 0), exit: Crossing::new(t1, 0) })
}

/// uv = (atan2(y, x)/2π wrapped to [0, 1), acos(z)/π).
pub(super) fn surface(p: DVec3) -> SurfacePoint {
    let n = p.normalize_or(DVec3::Z);
    let uv = DVec2::new(super::turns(n.y, n.x), n.z.clamp(-1.0, 1.0).acos() / std::f64::consts::PI);
    SurfacePoint { point: n, normal: n, uv }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uv_follows_the_spec() {
        let s = surface(DVec3::new(0.0, 1.0, 0.0));
        assert!((s.uv - DVec2::new(0.25, 0.5)).length() < 1e-15);
        let s = surface(DVec3::new(0.0, -1.0, 0.0));
        assert!((s.uv - DVec2::new(0.75, 0.5)).length() < 1e-15);
        let s = surface(DVec3::new(-1.0, 0.0, 0.0));
        assert!((s.uv - DVec2::new(0.5, 0.5)).length() < 1e-15);
        assert_eq!(surface(DVec3::Z).uv.y, 0.0);
        assert_eq!(surface(-DVec3::Z).uv.y, 1.0);
        let s = surface(DVec3::new(1.0, -1e-300, 0.0));
        assert!(s.uv.x < 1.0 && s.uv.x >= 0.0);
        assert!(surface(DVec3::new(1.0, -0.0, 0.0)).uv.x.is_sign_positive());
    }

    #[test]
    fn snaps_onto_the_surface() {
        let s = surface(DVec3::new(2.0, 0.0, 0.0));
        assert_eq!(s.point, DVec3::X);
        assert_eq!(s.normal, DVec3::X);
    }
}
