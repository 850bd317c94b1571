//! Orthonormal bases around a unit vector.

use glam::DVec3;

/// Two unit tangents `(t, b)` completing the unit vector `n` to a right-handed orthonormal
/// basis (`t × b = n`), by Duff et al., "Building an Orthonormal Basis, Revisited" (JCGT
/// 2017). Branchless apart from the sign, continuous everywhere except across z = 0, and
/// accurate at n = −z, where Frisvad's original construction breaks down.
///
/// ```
/// use lumen::cpu::onb;
/// use glam::DVec3;
/// let n = DVec3::new(1.0, 2.0, -3.0).normalize();
/// let (t, b) = onb(n);
/// assert!(t.dot(n).abs() < 1e-15 && b.dot(n).abs() < 1e-15 && t.dot(b).abs() < 1e-15);
/// assert!((t.cross(b) - n).length() < 1e-15);
/// ```
///
/// The sign is taken as `n.z >= 0` (so −0.0 counts as positive), exactly as
/// `shaders/onb.wgsl` must (WGSL has no copysign that sees −0.0): facing-flipped normals
/// such as (−1, −0, −0) then get the same frame, and the same sampled directions, on both
/// renderers.
pub fn onb(n: DVec3) -> (DVec3, DVec3) {
    let sign = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = DVec3::new(b, sign + n.y * n.y * a, -n.y);
    (t, bt)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(n: DVec3) {
        let (t, b) = onb(n);
        for v in [t, b] {
            assert!((v.length() - 1.0).abs() < 1e-14, "{n} {v}");
            assert!(v.dot(n).abs() < 1e-14, "{n} {v}");
        }
        assert!(t.dot(b).abs() < 1e-14);
        assert!((t.cross(b) - n).length() < 1e-14, "{n}: not right-handed");
    }

    #[test]
    fn axes_and_poles() {
        for n in [DVec3::X, DVec3::Y, DVec3::Z, -DVec3::X, -DVec3::Y, -DVec3::Z] {
            check(n);
        }
        assert_eq!(onb(DVec3::Z), (DVec3::X, DVec3::Y));
        // Near the south pole, where Frisvad's method loses all precision.
        check(DVec3::new(1e-9, -2e-9, -1.0).normalize());
        check(DVec3::new(-0.0, 0.0, -1.0));
    }

    #[test]
    fn many_directions() {
        let mut rng = crate::sampling::Pcg32::new(7, 11);
        for _ in 0..10_000 {
            let z = 2.0 * rng.next_f64() - 1.0;
            let phi = std::f64::consts::TAU * rng.next_f64();
            let r = (1.0 - z * z).max(0.0).sqrt();
            check(DVec3::new(r * phi.cos(), r * phi.sin(), z));
        }
    }
}
