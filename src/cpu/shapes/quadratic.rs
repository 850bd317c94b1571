//! The ray–sphere quadratic, solved without catastrophic cancellation.

use glam::DVec3;

use crate::cpu::ray::pow2_rescale;

/// Parameters `t0 ≤ t1` where the line `f + t·d` meets the sphere |x| = r (centre at the
/// origin), or `None` if it misses. `d` need not be normalised.
///
/// With `a = d·d`, `b' = f·d`, `c = f·f − r²` the roots of `a t² + 2b' t + c` are
/// `q/a` and `c/q` with `q = −(b' + sign(b')·√Δ)`, which never subtracts nearly equal
/// numbers. Δ = b'² − ac is computed as `a·(r² − |f − (b'/a)·d|²)` (Ray Tracing Gems ch. 7):
/// the vector `f − (b'/a)·d` is the line's closest approach to the centre, so Δ keeps its
/// precision when the sphere is tiny or far away, where `b'² − ac` would cancel. That
/// vector is then corrected once, by its own closest approach (`p − (p·d/a)·d`, which
/// is 0 in exact arithmetic): the first step's error grows with |f| times the error of
/// `b'/a`, the second's does not. From 1e7 radii away, a quotient one ulp off moved the
/// closest approach by a whole radius in f32; Vulkan allows 2.5 ulp for division, and an
/// NVIDIA H200 missed a fifth of a tiny far sphere's samples, most likely so (on lavapipe,
/// quotients made 1 ulp wrong on purpose reproduce it; STABILITY.md).
/// Used by the sphere (3-D) and by the cylinder's side (with z components zeroed).
///
/// `d` is first rescaled by a power of two (exact) so that its largest component lies in
/// [1, 2): a shape scaled by 1e300 has |d_obj| ≈ 1e-300, whose square underflows to 0,
/// and one scaled by 1e-300 has |d_obj|² = ∞. Only the direction is rescaled, so the roots
/// come out in units of the rescaled direction and are multiplied back by the same power
/// of two; in range, every step scales exactly and the result is bit for bit what the
/// unscaled formulas give.
pub fn sphere_roots(f: DVec3, d: DVec3, r2: f64) -> Option<(f64, f64)> {
    let s = pow2_rescale(d.abs().max_element());
    let d = d * s;
    let a = d.length_squared();
    if a == 0.0 || !a.is_finite() {
        return None;
    }
    let b = f.dot(d);
    let first = f - (b / a) * d;
    let closest = first - (first.dot(d) / a) * d;
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
    let (t0, t1) = (t0 * s, t1 * s);
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

    #[test]
    fn extreme_direction_lengths_keep_their_roots() {
        // From the centre of spheres scaled by 1e300 and 1e-300: |d_obj|² under- or
        // overflows f64, the roots ±1/|d| do not.
        for len in [1e-300, 1e-170, 1e170, 1e300] {
            let (t0, t1) = sphere_roots(DVec3::ZERO, DVec3::new(0.0, len, 0.0), 1.0).unwrap();
            assert!((t0 + 1.0 / len).abs() <= 1e-15 / len && (t1 - 1.0 / len).abs() <= 1e-15 / len, "{len}: {t0} {t1}");
        }
        // A subnormal direction still finds the sphere (whose far root 1e310 overflows).
        let (t0, t1) = sphere_roots(DVec3::ZERO, DVec3::new(1e-310, 0.0, 0.0), 1.0).unwrap();
        assert_eq!((t0, t1), (f64::NEG_INFINITY, f64::INFINITY));
        // In range the rescaling is exact: the same bits as d itself would give.
        let f = DVec3::new(-3.1, 0.2, 0.7);
        let d = DVec3::new(0.3, -0.01, 0.02);
        let (t0, t1) = sphere_roots(f, d, 1.0).unwrap();
        let (u0, u1) = sphere_roots(f, d * 1024.0, 1.0).unwrap();
        assert_eq!((t0, t1), (u0 * 1024.0, u1 * 1024.0));
    }
}
