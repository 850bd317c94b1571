//! Robust origins for rays spawned from a surface (Wächter & Binder, Ray Tracing Gems ch. 6,
//! adapted to f64).
//!
//! A computed hit point lies within a few ulps of the true surface, on either side. A ray
//! spawned exactly there may re-hit the surface it leaves ("shadow acne"), and a fixed
//! epsilon in t fails for scenes far from the origin or far smaller than 1. Instead the
//! point is pushed along the geometric normal by a number of ulps of each coordinate, which
//! scales with the coordinate's own rounding error, and by a small absolute amount where a
//! coordinate is near zero (where ulps become meaninglessly small).
//!
//! Constants (f32 originals in brackets):
//! - [`INT_SCALE`] = 2¹⁰ ulps [256]. Errors of the f64 pipeline (object-space root,
//!   projection onto the surface, one 4×4 transform of a point) are a handful of ulps of
//!   the largest term involved; 1024 ulps (relative 2.3·10⁻¹³) leaves a wide margin, also
//!   for CSG leaves whose transform is a product of several, and stays far below any
//!   visible scale.
//! - [`ORIGIN`] = 2⁻⁵ [1/32]. Below this magnitude a coordinate gets the absolute offset.
//! - [`FLOAT_SCALE`] = 2⁻⁴⁰ [2⁻¹⁶]. At |x| = 2⁻⁵ the integer offset is 2¹⁰·2⁻⁵⁷ = 2⁻⁴⁷;
//!   like the original (whose float offset is 16× its integer offset at the threshold) we
//!   take a larger absolute offset, 2⁻⁴⁰ ≈ 9·10⁻¹³, since near-zero coordinates carry the
//!   absolute error of the (larger) terms they were computed from. It is 10⁻⁸ of a
//!   10⁻⁴-sized object: invisible.

use glam::DVec3;

/// Ulps added to each coordinate (scaled by the normal's component).
pub const INT_SCALE: f64 = 1024.0;
/// Magnitude below which a coordinate is offset by an absolute amount instead.
pub const ORIGIN: f64 = 1.0 / 32.0;
/// Absolute offset (times the normal's component) for coordinates below [`ORIGIN`].
pub const FLOAT_SCALE: f64 = 1.0 / 1_099_511_627_776.0; // 2⁻⁴⁰

/// Moves the surface point `p` off the surface with geometric normal `n_geometric` (either
/// orientation, any length) to the side that the direction `dir` leaves through, so that
/// a ray from the result with `tmin = 0` does not re-hit that surface.
///
/// ```
/// use lumen::cpu::offset_origin;
/// use glam::DVec3;
/// let p = DVec3::new(1e5, 0.0, 0.0);
/// let o = offset_origin(p, DVec3::X, DVec3::new(1.0, 1.0, 0.0));
/// assert!(o.x > p.x && o.y == 0.0);
/// let o = offset_origin(p, DVec3::X, DVec3::new(-1.0, 1.0, 0.0));
/// assert!(o.x < p.x);
/// ```
pub fn offset_origin(p: DVec3, n_geometric: DVec3, dir: DVec3) -> DVec3 {
    let n = n_geometric.normalize_or_zero();
    let n = if n.dot(dir) < 0.0 { -n } else { n };
    DVec3::new(offset_coord(p.x, n.x), offset_coord(p.y, n.y), offset_coord(p.z, n.z))
}

/// One coordinate: by `INT_SCALE·n` ulps away from zero or towards it, or by the absolute
/// `FLOAT_SCALE·n` near zero.
fn offset_coord(p: f64, n: f64) -> f64 {
    if p.abs() < ORIGIN {
        return p + FLOAT_SCALE * n;
    }
    // Integer arithmetic on the bit pattern moves by whole ulps; adding to the magnitude
    // moves away from zero, so the step's sign follows p's.
    let ulps = (INT_SCALE * n) as i64;
    let step = if p < 0.0 { -ulps } else { ulps };
    let moved = f64::from_bits((p.to_bits() as i64).wrapping_add(step) as u64);
    if moved.is_finite() {
        moved
    } else {
        p
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moves_to_the_leaving_side() {
        for &p in &[DVec3::new(3.0, -2.0, 1e5), DVec3::new(-1e-3, 4e-5, 0.0), DVec3::new(-7.0, 1e-20, -1e10)] {
            for n in [DVec3::X, -DVec3::Y, DVec3::new(1.0, 2.0, -3.0)] {
                let d = DVec3::new(0.3, -0.5, 0.2);
                let o = offset_origin(p, n, d);
                let side = (o - p).dot(if n.dot(d) < 0.0 { -n } else { n });
                assert!(side > 0.0, "{p} {n}: {o}");
            }
        }
    }

    #[test]
    fn offset_is_tiny_relative_to_the_coordinate() {
        let p = DVec3::new(1e5, -1e5, 3.0);
        let o = offset_origin(p, DVec3::ONE, DVec3::ONE);
        let rel = (o - p).abs() / p.abs();
        assert!(rel.max_element() < 1e-12 && rel.min_element() > 0.0, "{rel}");
        let o = offset_origin(DVec3::ZERO, DVec3::Z, DVec3::Z);
        assert_eq!(o, DVec3::new(0.0, 0.0, FLOAT_SCALE));
    }
}
