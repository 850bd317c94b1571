//! Sampling, evaluation and densities of the scene's BRDFs (diffuse, mirror, dielectric).
//!
//! Conventions: `d` is the unit direction the incoming ray travels along, `n` the unit
//! normal facing it (`d · n ≤ 0`, as [`super::Hit`] gives it), `color` the BRDF pigment's
//! colour at the hit. A light direction `l` points away from the surface.

use std::f64::consts::FRAC_1_PI;

use glam::DVec3;

use crate::color::Color;
use crate::scene::Brdf;

use super::fresnel::{fresnel_dielectric, reflect, refract};
use super::warp::{cosine_hemisphere, cosine_hemisphere_pdf};

/// A scattered direction and its Monte Carlo weight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BsdfSample {
    /// Unit direction of the scattered ray.
    pub dir: DVec3,
    /// f · |cos| / pdf: what the path throughput is multiplied by.
    pub weight: Color,
    /// Solid-angle density of `dir` (meaningful only when `delta` is false).
    pub pdf: f64,
    /// True for Dirac lobes (mirror, dielectric): no light sampling or MIS through them.
    pub delta: bool,
}

/// Samples the BRDF with the vertex's lobe draw `xi_lobe` (ξ3) and direction draws
/// `xi_dir` (ξ4, ξ5). `front_face` tells a dielectric whether the ray enters (relative
/// index `ior`) or leaves (1/ior). Returns `None` when nothing is scattered.
pub fn sample_bsdf(
    brdf: &Brdf,
    color: Color,
    d: DVec3,
    n: DVec3,
    front_face: bool,
    xi_lobe: f64,
    xi_dir: [f64; 2],
) -> Option<BsdfSample> {
    match brdf {
        Brdf::Diffuse { .. } => sample_diffuse(color, n, xi_dir[0], xi_dir[1]),
        Brdf::Specular { .. } => Some(BsdfSample { dir: reflect(d, n), weight: color, pdf: 0.0, delta: true }),
        Brdf::Dielectric { ior, .. } => Some(sample_dielectric(color, d, n, relative_ior(*ior, front_face), xi_lobe)),
    }
}

/// BRDF value f for light arriving from `l` seen along `-d` (0 for delta BRDFs, whose value
/// is a Dirac delta that light sampling never hits).
pub fn eval_bsdf(brdf: &Brdf, color: Color, n: DVec3, l: DVec3) -> Color {
    match brdf {
        Brdf::Diffuse { .. } if n.dot(l) > 0.0 => color * FRAC_1_PI,
        _ => Color::BLACK,
    }
}

/// Solid-angle density with which [`sample_bsdf`] produces `l` (0 for delta BRDFs).
pub fn pdf_bsdf(brdf: &Brdf, n: DVec3, l: DVec3) -> f64 {
    match brdf {
        Brdf::Diffuse { .. } => cosine_hemisphere_pdf(n.dot(l)),
        _ => 0.0,
    }
}

/// n_transmitted / n_incident for a ray entering (`front_face`) or leaving a dielectric.
pub fn relative_ior(ior: f64, front_face: bool) -> f64 {
    if front_face {
        ior
    } else {
        1.0 / ior
    }
}

/// Cosine-weighted direction about `n`: f·cos/pdf = ρ exactly.
fn sample_diffuse(color: Color, n: DVec3, xi0: f64, xi1: f64) -> Option<BsdfSample> {
    let local = cosine_hemisphere(xi0, xi1);
    let (t, b) = super::onb(n);
    let dir = (t * local.x + b * local.y + n * local.z).normalize();
    let pdf = cosine_hemisphere_pdf(local.z);
    if pdf <= 0.0 {
        return None;
    }
    Some(BsdfSample { dir, weight: color, pdf, delta: false })
}

/// Reflects with probability F (chosen by `xi_lobe`), else refracts. Both branches weigh
/// `color` (F/F and (1−F)/(1−F)); refraction also scales radiance by 1/η², because radiance
/// is compressed by η² when it crosses into the denser medium.
fn sample_dielectric(color: Color, d: DVec3, n: DVec3, eta: f64, xi_lobe: f64) -> BsdfSample {
    let f = fresnel_dielectric(-d.dot(n), eta);
    let reflected = BsdfSample { dir: reflect(d, n), weight: color, pdf: 0.0, delta: true };
    if xi_lobe < f {
        return reflected;
    }
    match refract(d, n, eta) {
        Some(t) => BsdfSample { dir: t.normalize(), weight: color / (eta * eta), pdf: 0.0, delta: true },
        None => reflected,
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::*;
    use crate::sampling::Pcg32;
    use crate::scene::Pigment;

    fn diffuse() -> Brdf {
        Brdf::Diffuse { pigment: Pigment::default() }
    }

    /// Chi-square test of diffuse sampling against its pdf, over a sphere binned in
    /// (cos θ, φ) cells of equal solid angle about a tilted normal.
    #[test]
    fn diffuse_sampling_matches_its_pdf_chi_square() {
        let n = DVec3::new(0.3, -0.5, 0.8).normalize();
        let d = -n;
        let (nz, nphi) = (20usize, 40usize);
        let (t, b) = super::super::onb(n);
        let mut counts = vec![0f64; 2 * nz * nphi];
        let mut rng = Pcg32::new(1, 2);
        let samples = 400_000;
        for _ in 0..samples {
            let s = sample_bsdf(&diffuse(), Color::WHITE, d, n, true, rng.next_f64(), [rng.next_f64(), rng.next_f64()])
                .unwrap();
            assert!((s.pdf - pdf_bsdf(&diffuse(), n, s.dir)).abs() < 1e-12);
            assert_eq!(s.weight, Color::WHITE);
            counts[bin(s.dir, n, t, b, nz, nphi)] += 1.0;
        }
        // Expected counts: integrate the pdf over each bin (midpoint rule in cos θ, fine bins).
        let mut chi2 = 0.0;
        let mut dof = 0;
        for (i, c) in counts.iter().enumerate() {
            let zi = i / nphi;
            let sub = 64;
            let mut p = 0.0;
            for k in 0..sub {
                let z = -1.0 + (zi as f64 + (k as f64 + 0.5) / sub as f64) * 2.0 / (2 * nz) as f64;
                p += cosine_hemisphere_pdf(z) * (2.0 / (2 * nz) as f64 / sub as f64) * (2.0 * PI / nphi as f64);
            }
            let e = p * samples as f64;
            if e < 5.0 {
                // Pool tiny bins into a "must be empty-ish" check instead of chi-square.
                assert!(*c <= e + 20.0, "bin {i}: {c} vs {e}");
                continue;
            }
            chi2 += (c - e) * (c - e) / e;
            dof += 1;
        }
        // For ~400 degrees of freedom the 1e-6 upper quantile is about dof + 5.3·√(2·dof).
        let limit = dof as f64 + 5.3 * (2.0 * dof as f64).sqrt() + 10.0;
        assert!(chi2 < limit, "chi2 = {chi2} over {dof} bins, limit {limit}");
    }

    fn bin(l: DVec3, n: DVec3, t: DVec3, b: DVec3, nz: usize, nphi: usize) -> usize {
        let z = l.dot(n).clamp(-1.0, 1.0);
        let phi = l.dot(b).atan2(l.dot(t)).rem_euclid(2.0 * PI);
        let zi = (((z + 1.0) / 2.0 * (2 * nz) as f64) as usize).min(2 * nz - 1);
        let pi = ((phi / (2.0 * PI) * nphi as f64) as usize).min(nphi - 1);
        zi * nphi + pi
    }

    #[test]
    fn diffuse_eval_and_albedo() {
        let n = DVec3::Z;
        let c = Color::new(0.2, 0.5, 0.9);
        assert_eq!(eval_bsdf(&diffuse(), c, n, DVec3::new(0.0, 0.6, 0.8)), c / PI);
        assert_eq!(eval_bsdf(&diffuse(), c, n, DVec3::new(0.0, 0.6, -0.8)), Color::BLACK);
        assert_eq!(pdf_bsdf(&diffuse(), n, -DVec3::Z), 0.0);
    }

    #[test]
    fn mirror_reflects_exactly_with_tint() {
        let m = Brdf::Specular { pigment: Pigment::default(), threshold_angle_rad: 0.0 };
        let n = DVec3::Z;
        let d = DVec3::new(0.6, 0.0, -0.8);
        let c = Color::new(0.9, 0.5, 0.1);
        let s = sample_bsdf(&m, c, d, n, true, 0.3, [0.1, 0.2]).unwrap();
        assert_eq!(s.dir, DVec3::new(0.6, 0.0, 0.8));
        assert_eq!(s.weight, c);
        assert!(s.delta);
        assert_eq!(eval_bsdf(&m, c, n, s.dir), Color::BLACK);
    }

    #[test]
    fn dielectric_chooses_by_fresnel_and_obeys_snell() {
        let g = Brdf::Dielectric { pigment: Pigment::default(), ior: 1.5 };
        let th = 30f64.to_radians();
        let d = DVec3::new(th.sin(), 0.0, -th.cos());
        let n = DVec3::Z;
        let f = fresnel_dielectric(th.cos(), 1.5);
        let r = sample_bsdf(&g, Color::WHITE, d, n, true, f * 0.999, [0.0, 0.0]).unwrap();
        assert!((r.dir - DVec3::new(th.sin(), 0.0, th.cos())).length() < 1e-15);
        assert_eq!(r.weight, Color::WHITE);
        let t = sample_bsdf(&g, Color::WHITE, d, n, true, f * 1.001, [0.0, 0.0]).unwrap();
        assert!((t.dir.x - th.sin() / 1.5).abs() < 1e-15 && t.dir.z < 0.0);
        assert!((t.weight.r - 1.0 / 2.25).abs() < 1e-15);
        // Leaving the glass (back face): η = 1/1.5; past the critical angle, always reflect.
        let th = 50f64.to_radians();
        let d = DVec3::new(th.sin(), 0.0, -th.cos());
        let s = sample_bsdf(&g, Color::WHITE, d, n, false, 0.999_999, [0.0, 0.0]).unwrap();
        assert!((s.dir - DVec3::new(th.sin(), 0.0, th.cos())).length() < 1e-15);
        // Below it, refraction out multiplies radiance by 1.5².
        let th = 20f64.to_radians();
        let d = DVec3::new(th.sin(), 0.0, -th.cos());
        let s = sample_bsdf(&g, Color::WHITE, d, n, false, 0.999_999, [0.0, 0.0]).unwrap();
        assert!((s.dir.x - 1.5 * th.sin()).abs() < 1e-14);
        assert!((s.weight.g - 2.25).abs() < 1e-13);
    }
}
