//! The ray–sphere quadratic, solved without catastrophic cancellation.

use glam::DVec3;

/// Parameters `t0 ≤ t1` where the line `f + t·d` meets the sphere |x| = r (centre at the
/// origin), or `None` if it misses. `d` need not be normalised.
///
/// With `a = d·d`, `b' = f·d`, `c = f·f − r²` the roots of `a t² + 2b' t + c` are
/// `q/a` and `c/q` with `q = −(b' + sign(b')·√Δ)`, which never subtracts nearly equal
/// numbers. Δ = b'² − ac is computed as `a·(r² − |f − (b'/a)·d|²)` (Ray Tracing Gems ch. 7):
/// the vector `f − (b'/a)·d` is the line's closest approach to the centre, so Δ keeps its
/// precision when the sphere is tiny or far away, where `b'² − ac` would cancel.
/// Used by the sphere (3-D) and by the cylinder's side (with z components zeroed).
pub fn sphere_roots(f: DVec3, d: DVec3, r2: f64) -> Option<(f64, f64)> {
    let a = d.length_squared();
    if a == 0.0 {
        return None;
    }
    let b = f.dot(d);
    let closest = f - (b / a) * d;
    let disc = a * (r2 - closest.length_squared());
    if disc < 0.0 || disc.is_nan() {
        return None;
    }
    let c = f.length_squared() - r2;
    let q = -(b + b.signum() * disc.sqrt());
    let (t0, t1) = if q == 0.0 {
        // b' = 0 and Δ = 0: the line touches the sphere at its closest approach, t = 0.
        (0.0, 0.0)
    } else {
        (q / a, c / q)
    };
    Some(if t0 <= t1 { (t0, t1) } else { (t1, t0) })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_sphere_from_outside_and_inside() {
        let (t0, t1) = sphere_roots(DVec3::new(-3.0, 0.0, 0.0), DVec3::new(2.0, 0.0, 0.0), 1.0).unwrap();
        assert_eq!((t0, t1), (1.0, 2.0));
        let (t0, t1) = sphere_roots(DVec3::ZERO, DVec3::Z, 1.0).unwrap();
        assert_eq!((t0, t1), (-1.0, 1.0));
        assert!(sphere_roots(DVec3::new(0.0, 2.0, 0.0), DVec3::X, 1.0).is_none());
    }

    #[test]
    fn tiny_sphere_far_away_keeps_precision() {
        // Radius 1e-3 seen from 1e4 away (relative size 1e-7): the naive b² − ac loses
        // about 14 of 16 digits here.
        let r = 1e-3;
        let f = DVec3::new(-1e4, 0.5e-3, 0.0);
        let (t0, t1) = sphere_roots(f, DVec3::X, r * r).unwrap();
        let half = (r * r - 0.25e-6f64).sqrt();
        assert!((t0 - (1e4 - half)).abs() < 1e-11, "{t0}");
        assert!((t1 - (1e4 + half)).abs() < 1e-11, "{t1}");
    }
}
