//! Mirror reflection, Snell refraction and the exact unpolarised Fresnel reflectance of a
//! smooth dielectric interface.

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

#[cfg(test)]
mod tests {
    use super::*;

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
