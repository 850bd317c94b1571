//! The isotropic GGX (Trowbridge–Reitz) microfacet distribution in a local frame whose z
//! axis is the macroscopic normal: the normal distribution D, Smith's height-correlated
//! masking–shadowing, and sampling of the visible normals (Dupuy & Benyoub 2023, "Sampling
//! Visible GGX Normals with Spherical Caps"), with its density.
//!
//! Every function takes unit vectors. Written without tan θ (which overflows at grazing
//! angles) and with sin²θ from x² + y² (which keeps D accurate in f32 as α → 0).

use std::f64::consts::PI;

use glam::DVec3;

/// Smallest α rendered as a rough surface: a roughness in (0, ALPHA_MIN) uses ALPHA_MIN,
/// because narrower lobes are not resolved in f32 on the GPU (D's peak 1/(πα²) and the
/// half-vector's deviation α² fall under its precision). Roughness 0 is the smooth material.
pub const ALPHA_MIN: f64 = 1e-3;

/// The GGX α of a roughness r ∈ (0, 1] (r is α, floored at [`ALPHA_MIN`]).
pub fn alpha_of(roughness: f64) -> f64 {
    roughness.max(ALPHA_MIN)
}

/// D(h) = α² / (π (sin²θ + α² cos²θ)²) for h in the upper hemisphere, else 0.
pub fn distribution(alpha: f64, h: DVec3) -> f64 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let t = h.x * h.x + h.y * h.y + h.z * h.z * a2;
    a2 / (PI * t * t)
}

/// √(cos²θ + α² sin²θ) = |cos θ|·(1 + 2Λ(ω)): Smith's Λ without its tan θ.
fn lambda_term(alpha: f64, w: DVec3) -> f64 {
    (w.z * w.z + alpha * alpha * (w.x * w.x + w.y * w.y)).sqrt()
}

/// Smith masking G1(ω) = 1 / (1 + Λ(ω)) = 2|cos θ| / (|cos θ| + √(cos²θ + α² sin²θ)).
pub fn masking(alpha: f64, w: DVec3) -> f64 {
    let c = w.z.abs();
    let den = c + lambda_term(alpha, w);
    if den > 0.0 {
        2.0 * c / den
    } else {
        0.0
    }
}

/// Height-correlated masking–shadowing G2(o, i) = 1 / (1 + Λ(o) + Λ(i)) (Heitz 2014),
/// multiplied through by 2|cos θo||cos θi| so that grazing directions give 0, not NaN.
pub fn masking_shadowing(alpha: f64, o: DVec3, i: DVec3) -> f64 {
    let (co, ci) = (o.z.abs(), i.z.abs());
    let den = ci * lambda_term(alpha, o) + co * lambda_term(alpha, i);
    if den > 0.0 {
        2.0 * co * ci / den
    } else {
        0.0
    }
}

/// A microfacet normal drawn from the distribution of normals visible from `o` (o.z > 0),
/// D_o(h) = G1(o) max(0, o·h) D(h) / cos θo, by two uniforms: in the configuration
/// stretched to α = 1 the visible normals are o plus a uniform point of the spherical cap
/// z > −o.z of the unit sphere (Dupuy & Benyoub 2023); unstretching maps them back.
pub fn sample_visible_normal(alpha: f64, o: DVec3, u0: f64, u1: f64) -> DVec3 {
    let ws = DVec3::new(alpha * o.x, alpha * o.y, o.z).normalize();
    let phi = 2.0 * PI * u0;
    let z = (1.0 - u1) * (1.0 + ws.z) - ws.z;
    let s = (1.0 - z * z).max(0.0).sqrt();
    let h = DVec3::new(s * phi.cos(), s * phi.sin(), z) + ws;
    let m = DVec3::new(alpha * h.x, alpha * h.y, h.z.max(0.0));
    let len = m.length();
    if len > 0.0 {
        m / len
    } else {
        DVec3::Z
    }
}

/// Density of [`sample_visible_normal`]: D_o(h) = G1(o) max(0, o·h) D(h) / cos θo.
pub fn visible_normal_pdf(alpha: f64, o: DVec3, h: DVec3) -> f64 {
    if o.z <= 0.0 {
        return 0.0;
    }
    masking(alpha, o) * o.dot(h).max(0.0) * distribution(alpha, h) / o.z
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(theta: f64, phi: f64) -> DVec3 {
        DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())
    }

    /// Midpoint rule over (cos θ, φ) of the upper hemisphere.
    fn hemisphere_integral(f: impl Fn(DVec3) -> f64) -> f64 {
        let (nz, nphi) = (2000, 64);
        let mut sum = 0.0;
        for a in 0..nz {
            let z = (a as f64 + 0.5) / nz as f64;
            for b in 0..nphi {
                let phi = 2.0 * PI * (b as f64 + 0.5) / nphi as f64;
                let s = (1.0 - z * z).sqrt();
                sum += f(DVec3::new(s * phi.cos(), s * phi.sin(), z));
            }
        }
        sum * 2.0 * PI / (nz * nphi) as f64
    }

    #[test]
    fn distribution_is_normalised_and_visible_normals_too() {
        for alpha in [0.1, 0.5, 1.0] {
            // ∫ D(h) cos θh dω = 1 (projected microfacet area is the macro area).
            let projected = hemisphere_integral(|h| distribution(alpha, h) * h.z);
            assert!((projected - 1.0).abs() < 2e-3, "α = {alpha}: {projected}");
            // ∫ D_o(h) dω = 1, i.e. G1 is Smith's masking for this D.
            for theta in [0.0f64, 0.7, 1.4] {
                let o = dir(theta, 0.3);
                let visible = hemisphere_integral(|h| visible_normal_pdf(alpha, o, h));
                assert!((visible - 1.0).abs() < 3e-3, "α = {alpha}, θ = {theta}: {visible}");
            }
        }
        // α = 1 is the uniform distribution over the hemisphere of projected area: D = 1/π.
        assert!((distribution(1.0, dir(0.9, 0.0)) - 1.0 / PI).abs() < 1e-15);
    }

    #[test]
    fn masking_closed_forms_and_grazing() {
        // Λ = (−1 + √(1 + α² tan²θ)) / 2.
        let (alpha, theta) = (0.4f64, 1.1f64);
        let lambda = (-1.0 + (1.0 + alpha * alpha * theta.tan().powi(2)).sqrt()) / 2.0;
        let o = dir(theta, 0.2);
        assert!((masking(alpha, o) - 1.0 / (1.0 + lambda)).abs() < 1e-14);
        let i = dir(0.5, 2.0);
        let li = (-1.0 + (1.0 + alpha * alpha * 0.5f64.tan().powi(2)).sqrt()) / 2.0;
        assert!((masking_shadowing(alpha, o, i) - 1.0 / (1.0 + lambda + li)).abs() < 1e-14);
        // Symmetric, 1 at normal incidence, 0 (not NaN) at grazing incidence.
        assert_eq!(masking_shadowing(alpha, o, i), masking_shadowing(alpha, i, o));
        assert_eq!(masking(alpha, DVec3::Z), 1.0);
        assert_eq!(masking(alpha, DVec3::X), 0.0);
        assert_eq!(masking_shadowing(alpha, DVec3::X, DVec3::Y), 0.0);
    }

    #[test]
    fn visible_normals_face_the_viewer() {
        let mut rng = crate::sampling::Pcg32::new(3, 4);
        for alpha in [ALPHA_MIN, 0.05, 0.5, 1.0] {
            for theta in [0.0f64, 0.8, 1.5, std::f64::consts::FRAC_PI_2 - 1e-4] {
                let o = dir(theta, 1.0);
                for _ in 0..2000 {
                    let h = sample_visible_normal(alpha, o, rng.next_f64(), rng.next_f64());
                    assert!(h.is_finite() && (h.length() - 1.0).abs() < 1e-12);
                    assert!(o.dot(h) >= -1e-12 && h.z >= 0.0, "{h} for {o}");
                }
            }
        }
    }
}
