//! Warps from the unit square to directions, in a local frame with z as the axis.
//!
//! Each returns the direction and its density in solid angle, so the callers (BSDF and
//! light sampling) never recompute a pdf differently from how they drew the sample.

use std::f64::consts::PI;

use glam::DVec3;

/// Cosine-weighted hemisphere about +z (Malley's method on the polar disk):
/// pdf = cos θ / π.
pub fn cosine_hemisphere(xi0: f64, xi1: f64) -> DVec3 {
    let r = xi0.sqrt();
    let phi = 2.0 * PI * xi1;
    DVec3::new(r * phi.cos(), r * phi.sin(), (1.0 - xi0).max(0.0).sqrt())
}

/// Density of [`cosine_hemisphere`] for a direction with cosine `cos_theta` to the axis.
pub fn cosine_hemisphere_pdf(cos_theta: f64) -> f64 {
    cos_theta.max(0.0) / PI
}

/// Uniform on the whole sphere: pdf = 1/(4π).
pub fn uniform_sphere(xi0: f64, xi1: f64) -> DVec3 {
    let z = 1.0 - 2.0 * xi0;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * xi1;
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Solid-angle density of [`uniform_sphere`], 1/(4π) per steradian.
pub const UNIFORM_SPHERE_PDF: f64 = 1.0 / (4.0 * PI);

/// One minus the cosine of the half-angle of the cone that a sphere of radius `r` at
/// distance `d > r` subtends, computed without cancellation for small spheres:
/// 1 − cos θmax = sin²θmax / (1 + cos θmax).
pub fn cone_one_minus_cos(r: f64, d: f64) -> f64 {
    let sin2 = ((r / d) * (r / d)).min(1.0);
    let cos = (1.0 - sin2).sqrt();
    sin2 / (1.0 + cos)
}

/// Uniform in the cone about +z whose half-angle has 1 − cos θmax = `one_minus_cos_max`;
/// returns (direction, cos θ). pdf = 1 / (2π (1 − cos θmax)).
pub fn uniform_cone(xi0: f64, xi1: f64, one_minus_cos_max: f64) -> (DVec3, f64) {
    // 1 − cos θ = ξ0 · (1 − cos θmax): exact for tiny cones, where cos θ ≈ 1.
    let one_minus_cos = xi0 * one_minus_cos_max;
    let cos_theta = 1.0 - one_minus_cos;
    let sin_theta = (one_minus_cos * (2.0 - one_minus_cos)).max(0.0).sqrt();
    let phi = 2.0 * PI * xi1;
    (DVec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta), cos_theta)
}

/// Density of [`uniform_cone`] in solid angle.
pub fn uniform_cone_pdf(one_minus_cos_max: f64) -> f64 {
    1.0 / (2.0 * PI * one_minus_cos_max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warps_give_unit_vectors_in_their_domain() {
        for i in 0..20 {
            for j in 0..20 {
                let (a, b) = (i as f64 / 19.0 * 0.999_999, j as f64 / 19.0);
                let c = cosine_hemisphere(a, b);
                assert!((c.length() - 1.0).abs() < 1e-12 && c.z >= 0.0);
                let s = uniform_sphere(a, b);
                assert!((s.length() - 1.0).abs() < 1e-12);
                let (d, cos) = uniform_cone(a, b, 0.3);
                assert!((d.length() - 1.0).abs() < 1e-12 && (d.z - cos).abs() < 1e-15 && d.z >= 0.7 - 1e-12);
            }
        }
    }

    #[test]
    fn tiny_cone_keeps_precision() {
        // A sphere of radius 1e-6 at distance 1: 1 − cos θmax ≈ r²/2d².
        let omc = cone_one_minus_cos(1e-6, 1.0);
        assert!((omc / 5e-13 - 1.0).abs() < 1e-6);
        // Solid angle 2π(1 − cos θmax) ≈ π r² / d².
        assert!((2.0 * PI * omc / (PI * 1e-12) - 1.0).abs() < 1e-6);
    }
}
