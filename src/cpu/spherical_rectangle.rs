//! Points on a rectangle drawn uniformly in the solid angle it subtends from a point: the
//! area-preserving map of the spherical rectangle onto the unit square by Ureña, Fajardo
//! and King ("An Area-Preserving Parametrization for Spherical Rectangles", EGSR 2013).
//! Mirrored by `shaders/spherical_rectangle.wgsl`.
//!
//! Cube lights use it for their faces ([`super::area_light`]): a point close to a face sees
//! it at distances and angles that vary so much across the face that uniform area
//! sampling's weight d²/(A cos θ) swings by orders of magnitude (the ceiling beside
//! `scenes/cornell.sl`'s lamp holds most of that image's noise); drawn by solid angle, the
//! weight is the constant Ω.
//!
//! The rectangle lies at height z0 < 0 in an orthonormal frame at the shading point, over
//! x ∈ [x0, x1], y ∈ [y0, y1]. Its solid angle is the classic sum over its corners,
//! Ω = F(x1, y1) − F(x1, y0) − F(x0, y1) + F(x0, y0) with F(x, y) = atan(x·y / (|z0|·r)),
//! r the corner's distance; each term is an interior angle of the spherical rectangle less
//! π/2, so Ω never subtracts 2π, and each is computed as an atan2 of two products, the form
//! that `shaders/angles.wgsl`'s precise atan2 keeps to f32 precision.

use glam::DVec3;

/// A rectangle as seen from a shading point, ready for sampling.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphericalRectangle {
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    /// The rectangle's height in the frame at the shading point (negative).
    z0: f64,
    /// z components of the unit normals of the planes through the point and the two edges
    /// along x (at y0 and at y1), which the inversion of the x marginal needs.
    b0: f64,
    b1: f64,
    /// Where the angle φ that u sweeps over Ω starts: F(x0, y1) − F(x0, y0), the corner
    /// terms of the edge x = x0 (Ureña et al.'s angle less π, so that φ ∈ (−π, π)).
    phi0: f64,
    solid_angle: f64,
}

impl SphericalRectangle {
    /// The rectangle `corner + s·ea + t·eb` (s, t ∈ [0, 1], `ea` ⟂ `eb`) seen from `o`.
    ///
    /// ```
    /// use glam::DVec3;
    /// use lumen::cpu::spherical_rectangle::SphericalRectangle;
    ///
    /// // A 2 × 2 square one unit below the point, centred under it: 4·atan(1/√3) = 2π/3.
    /// let r = SphericalRectangle::new(DVec3::ZERO, DVec3::new(-1.0, -1.0, -1.0), 2.0 * DVec3::X, 2.0 * DVec3::Y);
    /// assert!((r.solid_angle() - 2.0 * std::f64::consts::PI / 3.0).abs() < 1e-12);
    /// // The middle of the unit square maps to the middle of the square (by symmetry).
    /// let (s, t) = r.sample(0.5, 0.5);
    /// assert!((s - 0.5).abs() < 1e-12 && (t - 0.5).abs() < 1e-12);
    /// ```
    pub fn new(o: DVec3, corner: DVec3, ea: DVec3, eb: DVec3) -> Self {
        let (la, lb) = (ea.length(), eb.length());
        let (ex, ey) = (ea / la, eb / lb);
        let d = corner - o;
        let (x0, y0) = (d.dot(ex), d.dot(ey));
        let z0 = -d.dot(ex.cross(ey)).abs();
        let (x1, y1) = (x0 + la, y0 + lb);
        // Corner terms, each atan2(x·y, |z0|·r).
        let z = -z0;
        let corner_term = |x: f64, y: f64| (x * y).atan2(z * (x * x + y * y + z * z).sqrt());
        let (f00, f01, f10, f11) = (corner_term(x0, y0), corner_term(x0, y1), corner_term(x1, y0), corner_term(x1, y1));
        Self {
            x0,
            x1,
            y0,
            y1,
            z0,
            b0: -y0 / (z0 * z0 + y0 * y0).sqrt(),
            b1: y1 / (z0 * z0 + y1 * y1).sqrt(),
            phi0: f01 - f00,
            solid_angle: (f11 - f10) - (f01 - f00),
        }
    }

    /// The solid angle Ω (the density of [`Self::sample`] is 1/Ω). NaN or 0 where the
    /// point lies in the rectangle's plane.
    pub fn solid_angle(&self) -> f64 {
        self.solid_angle
    }

    /// The point of the unit square (u, v) maps to, as fractions (s, t) ∈ [0, 1]² along
    /// `ea` and `eb`: u fixes the column x by the solid angle left of it, v the height
    /// within the column by the solid angle below it.
    pub fn sample(&self, u: f64, v: f64) -> (f64, f64) {
        let Self { x0, x1, y0, y1, z0, b0, b1, .. } = *self;
        // The spherical rectangle's area up to column x grows with the angle φ ∈ (−π, π).
        let (sin, cos) = (u * self.solid_angle + self.phi0).sin_cos();
        let fu = (cos * b0 + b1) / sin;
        let sign = if fu < 0.0 { -1.0 } else { 1.0 };
        let cu = (sign / (fu * fu + b0 * b0).sqrt()).clamp(-1.0 + f64::EPSILON, 1.0 - f64::EPSILON);
        let xu = (-(cu * z0) / (1.0 - cu * cu).sqrt()).clamp(x0, x1);
        // Within the column, the sine of the elevation is linear in the solid angle.
        let dd = (xu * xu + z0 * z0).sqrt();
        let h0 = y0 / (dd * dd + y0 * y0).sqrt();
        let h1 = y1 / (dd * dd + y1 * y1).sqrt();
        let hv = h0 + v * (h1 - h0);
        let hv2 = hv * hv;
        let yv = if hv2 < 1.0 - 1e-6 { hv * dd / (1.0 - hv2).sqrt() } else { y1 };
        let s = ((xu - x0) / (x1 - x0)).clamp(0.0, 1.0);
        let t = ((yv - y0) / (y1 - y0)).clamp(0.0, 1.0);
        (s, t)
    }
}

/// Whether the rectangle `corner + s·ea + t·eb` may subtend `omega` or more from `o`: no
/// part of a plane figure subtends more than its area over its plane's distance squared,
/// so Ω ≤ A/z², tested as A³ ≥ ω·(d·(ea × eb))² (|ea × eb| = A, d·(ea × eb) = ±z·A) with
/// no division and no corner term; far faces are told apart at the cost of a cross
/// product.
pub fn may_subtend(o: DVec3, corner: DVec3, ea: DVec3, eb: DVec3, omega: f64) -> bool {
    let c = ea.cross(eb);
    let a2 = c.length_squared();
    let za = (corner - o).dot(c);
    a2 * a2.sqrt() >= omega * za * za
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;

    /// Solid angle of the triangle (a, b, c) seen from the origin, by Van Oosterom and
    /// Strackee's formula: an oracle independent of the corner-angle sum above.
    fn triangle_solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
        let (la, lb, lc) = (a.length(), b.length(), c.length());
        let num = a.dot(b.cross(c)).abs();
        let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
        2.0 * num.atan2(den)
    }

    fn rectangle_solid_angle(o: DVec3, corner: DVec3, ea: DVec3, eb: DVec3) -> f64 {
        let p = |s: f64, t: f64| corner + s * ea + t * eb - o;
        triangle_solid_angle(p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0))
            + triangle_solid_angle(p(0.0, 0.0), p(1.0, 1.0), p(0.0, 1.0))
    }

    /// Rectangles in general position: tilted, off-axis, near and far, the point on
    /// either side of the plane.
    fn cases() -> Vec<(DVec3, DVec3, DVec3, DVec3)> {
        let ea = DVec3::new(0.8, 0.3, -0.2);
        let eb = DVec3::new(-0.1, 0.4, 0.2).reject_from(ea) * 1.7;
        let corner = DVec3::new(0.2, -0.1, 1.0);
        let n = ea.cross(eb).normalize();
        let centre = corner + 0.5 * (ea + eb);
        let mut out = Vec::new();
        for (along, side) in [(0.0, 0.05), (0.3, 0.5), (-0.4, 0.01), (2.0, 3.0), (0.1, -0.7), (5.0, 0.2)] {
            let o = centre + side * n + along * ea + 0.3 * along * eb;
            out.push((o, corner, ea, eb));
        }
        out
    }

    #[test]
    fn the_solid_angle_is_the_sum_of_two_triangles() {
        for (o, corner, ea, eb) in cases() {
            let want = rectangle_solid_angle(o, corner, ea, eb);
            let got = SphericalRectangle::new(o, corner, ea, eb).solid_angle();
            assert!((got / want - 1.0).abs() < 1e-12, "{got} vs {want} from {o}");
        }
        // A square of side 2a centred under the point at height h: 4 atan(a² / (h √(2a² + h²))).
        let (a, h) = (0.3f64, 0.9f64);
        let r = SphericalRectangle::new(
            DVec3::new(0.0, 0.0, h),
            DVec3::new(-a, -a, 0.0),
            DVec3::new(2.0 * a, 0.0, 0.0),
            DVec3::new(0.0, 2.0 * a, 0.0),
        );
        let want = 4.0 * (a * a / (h * (2.0 * a * a + h * h).sqrt())).atan();
        assert!((r.solid_angle() / want - 1.0).abs() < 1e-14);
    }

    /// The map is uniform in solid angle: the share of samples in each cell of a 3 × 3 grid
    /// on the rectangle is the cell's solid angle over the whole (binomial bounds), and the
    /// sample's fractions stay in [0, 1]. A stratified (u, v) grid makes the shares tight.
    #[test]
    fn samples_are_uniform_in_solid_angle() {
        let mut rng = Pcg32::new(7, 11);
        for (o, corner, ea, eb) in cases() {
            let r = SphericalRectangle::new(o, corner, ea, eb);
            let n = 300_000usize;
            let mut counts = [[0usize; 3]; 3];
            for _ in 0..n {
                let (s, t) = r.sample(rng.next_f64(), rng.next_f64());
                assert!((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t), "{s} {t}");
                counts[((s * 3.0) as usize).min(2)][((t * 3.0) as usize).min(2)] += 1;
            }
            for (i, row) in counts.iter().enumerate() {
                for (j, &c) in row.iter().enumerate() {
                    let cell_corner = corner + (i as f64 / 3.0) * ea + (j as f64 / 3.0) * eb;
                    let p = rectangle_solid_angle(o, cell_corner, ea / 3.0, eb / 3.0) / r.solid_angle();
                    let got = c as f64 / n as f64;
                    let sigma = (p * (1.0 - p) / n as f64).sqrt();
                    assert!((got - p).abs() < 5.0 * sigma + 1e-9, "cell ({i}, {j}) from {o}: {got} vs {p}");
                }
            }
        }
    }

    /// The bound never excludes a rectangle that subtends ω: for each case, just below its
    /// Ω it may subtend, and above A/z² it may not.
    #[test]
    fn the_bound_never_excludes_what_subtends_enough() {
        for (o, corner, ea, eb) in cases() {
            let omega = SphericalRectangle::new(o, corner, ea, eb).solid_angle();
            assert!(may_subtend(o, corner, ea, eb, omega * (1.0 - 1e-12)));
            let c = ea.cross(eb);
            let z = (corner - o).dot(c.normalize()).abs();
            assert!(!may_subtend(o, corner, ea, eb, c.length() / (z * z) * (1.0 + 1e-9)));
        }
    }

    /// The corners of the unit square map onto the rectangle's corners (the map is onto).
    #[test]
    fn the_square_s_corners_reach_the_rectangle_s_corners() {
        for (o, corner, ea, eb) in cases() {
            let r = SphericalRectangle::new(o, corner, ea, eb);
            for (u, v) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
                let (s, t) = r.sample(u, v);
                assert!((s - u).abs() < 1e-6 && (t - v).abs() < 1e-6, "({u}, {v}) -> ({s}, {t}) from {o}");
            }
        }
    }
}
