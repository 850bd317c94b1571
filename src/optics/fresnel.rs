//! Mirror reflection, Snell refraction and the exact unpolarised Fresnel reflectance of a
//! smooth dielectric interface and of a conductor (complex index).

use glam::DVec3;

/// Mirror reflection of the travelling direction `d` about the normal `n` (unit).
pub fn reflect(d: DVec3, n: DVec3) -> DVec3 {
    d - 2.0 * d.dot(n) * n
}

/// Refraction of the unit travelling direction `d` through a surface whose unit normal `n`
/// faces the incoming side (`d · n < 0`), with `eta` = n_transmitted / n_incident.
/// `None` on total internal reflection.
pub fn refract(d: DVec3, n: DVec3, eta: f64) -> Option<DVec3> {
    let cos_i = -d.dot(n);
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(d / eta + (cos_i / eta - cos_t) * n)
}

/// Unpolarised Fresnel reflectance for an incident cosine `cos_i` ∈ [0, 1] (measured on the
/// incident side) and relative index `eta` = n_t / n_i: the mean of the s and p
/// reflectances, 1 under total internal reflection.
pub fn fresnel_dielectric(cos_i: f64, eta: f64) -> f64 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// Unpolarised Fresnel reflectance of a conductor of complex index `eta + i·k` (relative to
/// the outside) for the incident cosine `cos_i`: the exact s and p reflectances of an
/// absorbing medium, written with the real and imaginary parts a, b of √(ñ² − sin²θ).
pub fn fresnel_conductor(cos_i: f64, eta: f64, k: f64) -> f64 {
    let c = cos_i.clamp(0.0, 1.0);
    let c2 = c * c;
    let s2 = 1.0 - c2;
    let t0 = eta * eta - k * k - s2;
    let a2b2 = (t0 * t0 + 4.0 * eta * eta * k * k).sqrt();
    let a = (0.5 * (a2b2 + t0)).max(0.0).sqrt();
    let rs = (a2b2 - 2.0 * a * c + c2) / (a2b2 + 2.0 * a * c + c2);
    let rp = rs * (c2 * a2b2 - 2.0 * a * c * s2 + s2 * s2) / (c2 * a2b2 + 2.0 * a * c * s2 + s2 * s2);
    let f = 0.5 * (rs + rp);
    if f.is_finite() {
        f.clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// Hemispherical average 2∫F(μ)μ dμ of a conductor's Fresnel reflectance (Kulla & Conty's
/// F_avg, which tints the multiple-scattering lobe), by a fixed midpoint rule so that both
/// renderers get the same value.
pub fn conductor_fresnel_average(eta: f64, k: f64) -> f64 {
    const N: usize = 64;
    let mut sum = 0.0;
    for j in 0..N {
        let mu = (j as f64 + 0.5) / N as f64;
        sum += fresnel_conductor(mu, eta, k) * mu;
    }
    2.0 * sum / N as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conductor_fresnel_closed_forms() {
        // Normal incidence: ((η − 1)² + k²) / ((η + 1)² + k²).
        let (eta, k) = (0.2, 3.0);
        let f0 = ((eta - 1.0f64).powi(2) + k * k) / ((eta + 1.0f64).powi(2) + k * k);
        assert!((fresnel_conductor(1.0, eta, k) - f0).abs() < 1e-14);
        // k = 0 is a dielectric.
        for c in [0.1, 0.4, 0.9] {
            assert!((fresnel_conductor(c, 1.5, 0.0) - fresnel_dielectric(c, 1.5)).abs() < 1e-13);
        }
        // Grazing incidence reflects everything; the average of F ≡ 1 would be 1.
        assert!((fresnel_conductor(0.0, eta, k) - 1.0).abs() < 1e-12);
        let avg = conductor_fresnel_average(eta, k);
        assert!(avg > 0.9 * f0 && avg < 1.0, "{avg}");
    }

    #[test]
    fn reflection_is_exact() {
        let n = DVec3::new(0.0, 0.0, 1.0);
        let d = DVec3::new(1.0, 2.0, -3.0);
        assert_eq!(reflect(d, n), DVec3::new(1.0, 2.0, 3.0));
        // Tilted normal: the angle with n is preserved and the tangential part kept.
        let n = DVec3::new(1.0, 1.0, 0.0).normalize();
        let d = DVec3::new(-1.0, 0.0, 0.0);
        let r = reflect(d, n);
        assert!((r - DVec3::new(0.0, 1.0, 0.0)).length() < 1e-15);
    }

    #[test]
    fn snell_law_holds_and_tir_is_detected() {
        let n = DVec3::Z;
        for deg in [0.0f64, 10.0, 30.0, 41.0, 60.0, 89.0] {
            let th = deg.to_radians();
            let d = DVec3::new(th.sin(), 0.0, -th.cos());
            let t = refract(d, n, 1.5).unwrap();
            assert!((t.length() - 1.0).abs() < 1e-14);
            // sin θt = sin θi / 1.5, in the plane of incidence, on the far side.
            assert!((t.x - th.sin() / 1.5).abs() < 1e-14 && t.y == 0.0 && t.z < 0.0);
            // Leaving glass: TIR beyond the critical angle asin(1/1.5) = 41.81°.
            let out = refract(d, n, 1.0 / 1.5);
            if deg > 41.82 {
                assert!(out.is_none());
                assert_eq!(fresnel_dielectric(th.cos(), 1.0 / 1.5), 1.0);
            } else if deg < 41.8 {
                let o = out.unwrap();
                assert!((o.x - 1.5 * th.sin()).abs() < 1e-13);
            }
        }
    }

    #[test]
    fn fresnel_known_values() {
        // Normal incidence: ((η − 1)/(η + 1))², the same from either side.
        let f0 = (0.5f64 / 2.5).powi(2);
        assert!((fresnel_dielectric(1.0, 1.5) - f0).abs() < 1e-15);
        assert!((fresnel_dielectric(1.0, 1.0 / 1.5) - f0).abs() < 1e-15);
        // Brewster's angle atan(1.5): p-polarised reflectance vanishes, F = Rs/2.
        let tb = 1.5f64.atan();
        let ct = (1.0 - (tb.sin() / 1.5).powi(2)).sqrt();
        let rs = ((tb.cos() - 1.5 * ct) / (tb.cos() + 1.5 * ct)).powi(2);
        assert!((fresnel_dielectric(tb.cos(), 1.5) - rs / 2.0).abs() < 1e-15);
        // Grazing: total reflection; index-matched: none.
        assert!((fresnel_dielectric(0.0, 1.5) - 1.0).abs() < 1e-15);
        assert!(fresnel_dielectric(0.7, 1.0).abs() < 1e-15);
    }
}
