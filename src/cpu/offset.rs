//! Robust origins for rays spawned from a surface (Wächter & Binder, Ray Tracing Gems ch. 6,
//! adapted to f64 and made scale-aware).
//!
//! A computed hit point lies within a few ulps of the true surface, on either side. A ray
//! spawned exactly there may re-hit the surface it leaves ("shadow acne"), and a fixed
//! epsilon in t fails for scenes far from the origin or far smaller than 1. Instead the
//! point is pushed along the geometric normal by a number of ulps of each coordinate, which
//! scales with the coordinate's own rounding error, and by a small absolute amount where a
//! coordinate is near zero (where ulps become meaninglessly small).
//!
//! **Scale.** A coordinate near zero still carries the rounding error of the terms it was
//! computed from: the world point is `M·p_obj + t`, so its error is a few ulps of
//! `|M|·|p_obj| + |t|` ([`error_scale`]), not of the result. Wächter–Binder's absolute
//! offset and its threshold are fixed numbers that assume those terms are about 1; here
//! both are multiplied by the point's error scale, which every hit and every sampled light
//! point carries. A scene scaled by 1e-4 then gets offsets 1e-4 times those of the unit
//! scene (with the fixed constants its rays jumped 15 % of its unit on the GPU).
//!
//! Constants (f32 originals in brackets), relative to the error scale `s`:
//! - [`INT_SCALE`] = 2¹⁰ ulps \[256\]. Errors of the f64 pipeline (object-space root,
//!   projection onto the surface, one 4×4 transform of a point) are a handful of ulps of
//!   the largest term involved; 1024 ulps (relative 2.3·10⁻¹³) leaves a wide margin, also
//!   for CSG leaves whose transform is a product of several, and stays far below any
//!   visible scale.
//! - [`ORIGIN`] = 2⁻⁵ [1/32]. Below `ORIGIN·s` a coordinate gets the absolute offset; at
//!   the threshold its 1024 ulps are still 32 ulps of `s`.
//! - [`FLOAT_SCALE`] = 2⁻⁴⁰ [2⁻¹⁶]. At |x| = 2⁻⁵·s the integer offset is 2¹⁰·2⁻⁵⁷·s =
//!   2⁻⁴⁷·s; like the original (whose float offset is 16× its integer offset at the
//!   threshold) we take a larger absolute offset, 2⁻⁴⁰·s ≈ 9·10⁻¹³·s, since near-zero
//!   coordinates carry the absolute error of the (larger) terms they were computed from.

use glam::{DMat4, DVec3};

use super::normalize_scaled;

/// Ulps added to each coordinate (scaled by the normal's component).
pub const INT_SCALE: f64 = 1024.0;
/// Magnitude, relative to the error scale, below which a coordinate is offset by an
/// absolute amount instead.
pub const ORIGIN: f64 = 1.0 / 32.0;
/// Absolute offset (times the error scale and the normal's component) for coordinates
/// below [`ORIGIN`] times the error scale.
pub const FLOAT_SCALE: f64 = 1.0 / 1_099_511_627_776.0; // 2⁻⁴⁰

/// The error scale of the point `m · p_obj` (an affine object-to-world map): the largest,
/// over the three coordinates, of the sum of the magnitudes of the terms that produce it,
/// `Σⱼ |mᵢⱼ·pⱼ| + |tᵢ|`. Rounding errors of the point, and of the ray that leaves it, are a
/// few ulps of this, whatever the point's own coordinates are.
pub fn error_scale(m: &DMat4, p_obj: DVec3) -> f64 {
    let a = p_obj.abs();
    let row = |i: usize| {
        let r = m.row(i);
        r.x.abs() * a.x + r.y.abs() * a.y + r.z.abs() * a.z + r.w.abs()
    };
    row(0).max(row(1)).max(row(2))
}

/// Moves the surface point `p` (error scale `scale`, see [`error_scale`]) off the surface
/// with geometric normal `n_geometric` (either orientation, any length) to the side that
/// the direction `dir` leaves through, so that a ray from the result with `tmin = 0` does
/// not re-hit that surface.
///
/// ```
/// use lumen::cpu::offset_origin;
/// use glam::DVec3;
/// let p = DVec3::new(1e5, 0.0, 0.0);
/// let o = offset_origin(p, 1e5, DVec3::X, DVec3::new(1.0, 1.0, 0.0));
/// assert!(o.x > p.x && o.y == 0.0);
/// let o = offset_origin(p, 1e5, DVec3::X, DVec3::new(-1.0, 1.0, 0.0));
/// assert!(o.x < p.x);
/// ```
pub fn offset_origin(p: DVec3, scale: f64, n_geometric: DVec3, dir: DVec3) -> DVec3 {
    let n = normalize_scaled(n_geometric);
    let n = if n.dot(dir) < 0.0 { -n } else { n };
    DVec3::new(offset_coord(p.x, scale, n.x), offset_coord(p.y, scale, n.y), offset_coord(p.z, scale, n.z))
}

/// One coordinate: by `INT_SCALE·n` ulps away from zero or towards it, or by the absolute
/// `FLOAT_SCALE·scale·n` near zero (below `ORIGIN·scale`).
fn offset_coord(p: f64, scale: f64, n: f64) -> f64 {
    if p.abs() < ORIGIN * scale {
        return p + FLOAT_SCALE * scale * n;
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
                let o = offset_origin(p, p.abs().max_element(), n, d);
                let side = (o - p).dot(if n.dot(d) < 0.0 { -n } else { n });
                assert!(side > 0.0, "{p} {n}: {o}");
            }
        }
    }

    #[test]
    fn offset_is_tiny_relative_to_the_coordinate() {
        // Coordinates near the scale move by ulps of their own; the one near zero (3 in a
        // point whose terms are 1e5) by FLOAT_SCALE of the scale, still 1e-12 of it.
        let p = DVec3::new(1e5, -1e5, 3.0);
        let o = offset_origin(p, 1e5, DVec3::ONE, DVec3::ONE);
        let rel = (o - p).abs() / 1e5;
        assert!(rel.max_element() < 1e-12 && rel.min_element() > 0.0, "{rel}");
        assert_eq!(o.z, 3.0 + FLOAT_SCALE * 1e5 / 3f64.sqrt());
        let o = offset_origin(DVec3::ZERO, 1.0, DVec3::Z, DVec3::Z);
        assert_eq!(o, DVec3::new(0.0, 0.0, FLOAT_SCALE));
    }

    #[test]
    fn offset_is_proportional_to_the_error_scale() {
        // The same surface point in a unit scene and in the scene scaled by 1e-4 (a
        // power-of-two ratio keeps the comparison exact): every coordinate, near zero or
        // not, moves by the same fraction of the scene.
        let k = 2f64.powi(-13); // ≈ 1.2e-4
        let m = DMat4::from_scale_rotation_translation(
            DVec3::splat(1.5),
            glam::DQuat::from_rotation_z(0.3),
            DVec3::new(0.5, -2.0, 0.01),
        );
        let p_obj = DVec3::new(0.6, 0.0, 0.8);
        let (p, n, d) = (m.transform_point3(p_obj), DVec3::new(0.2, -0.1, 1.0), DVec3::Z);
        let s = error_scale(&m, p_obj);
        let small = DMat4::from_scale(DVec3::splat(k)) * m;
        assert_eq!(error_scale(&small, p_obj), s * k);
        let o_unit = offset_origin(p, s, n, d) - p;
        let o_small = offset_origin(p * k, s * k, n, d) - p * k;
        assert_eq!(o_small, o_unit * k);
        assert!(o_unit.z > 0.0 && o_unit.z < 1e-11 * s, "{o_unit}");
        // The absolute offset of a near-zero coordinate is FLOAT_SCALE of the scale.
        let o = offset_origin(DVec3::new(1e-4, 1e-9, 0.0), 1e-4, DVec3::Y, DVec3::Y);
        assert_eq!(o.y, 1e-9 + FLOAT_SCALE * 1e-4);
    }

    #[test]
    fn error_scale_sums_the_terms() {
        let m =
            DMat4::from_cols_array(&[2.0, 0.0, 0.0, 0.0, 0.0, -3.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, -5.0, 1.0, 0.5, 1.0]);
        // x = 2·px + 1·pz − 5: terms 2·1 + 1·2 + 5 = 9 (the point itself is x = −1).
        assert_eq!(error_scale(&m, DVec3::new(1.0, 1.0, 2.0)), 9.0);
        assert_eq!(error_scale(&DMat4::IDENTITY, DVec3::new(0.0, -4.0, 1.0)), 4.0);
    }
}
