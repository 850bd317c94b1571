//! Sampling, evaluation and densities of the scene's BSDFs: diffuse, mirror and smooth glass
//! here, the rough ones (and the smooth conductor's Fresnel) in [`super::microfacet`].
//!
//! Conventions: `d` is the unit direction the incoming ray travels along, `n` the unit
//! normal facing it (`d · n ≤ 0`, as [`super::Hit`] gives it), `color` the BRDF pigment's
//! colour at the hit. A light direction `l` points away from the surface.

use std::f64::consts::FRAC_1_PI;

use glam::DVec3;

use crate::color::Color;
use crate::scene::Brdf;

use super::fresnel::{fresnel_dielectric, reflect, refract};
use super::microfacet::{self as mf, LocalSample, Rough};
use super::warp::{cosine_hemisphere, cosine_hemisphere_pdf};
use crate::optics::ggx::alpha_of;

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
        Brdf::Dielectric { ior, roughness, .. } if *roughness == 0.0 => {
            Some(sample_dielectric(color, d, n, relative_ior(*ior, front_face), xi_lobe))
        }
        Brdf::Conductor { roughness, fresnel, .. } if *roughness == 0.0 => {
            let weight = color * mf::conductor_fresnel(-d.dot(n), *fresnel);
            Some(BsdfSample { dir: reflect(d, n), weight, pdf: 0.0, delta: true })
        }
        _ => {
            let frame = Frame::new(n);
            let o = frame.local(-d);
            let s = sample_rough(brdf, color, front_face, o, xi_lobe, xi_dir)?;
            Some(BsdfSample { dir: frame.world(s.dir).normalize(), weight: s.weight, pdf: s.pdf, delta: s.delta })
        }
    }
}

/// BSDF value f for light arriving from `l` seen along `-d` (0 for delta BSDFs, whose value
/// is a Dirac delta that light sampling never hits).
pub fn eval_bsdf(brdf: &Brdf, color: Color, d: DVec3, n: DVec3, front_face: bool, l: DVec3) -> Color {
    match brdf {
        Brdf::Diffuse { .. } if n.dot(l) > 0.0 => color * FRAC_1_PI,
        Brdf::Diffuse { .. } => Color::BLACK,
        b if b.is_delta() => Color::BLACK,
        _ => {
            let frame = Frame::new(n);
            eval_rough(brdf, color, front_face, frame.local(-d), frame.local(l))
        }
    }
}

/// Solid-angle density with which [`sample_bsdf`] produces `l` (0 for delta BSDFs).
pub fn pdf_bsdf(brdf: &Brdf, d: DVec3, n: DVec3, front_face: bool, l: DVec3) -> f64 {
    match brdf {
        Brdf::Diffuse { .. } => cosine_hemisphere_pdf(n.dot(l)),
        b if b.is_delta() => 0.0,
        _ => {
            let frame = Frame::new(n);
            let (o, i) = (frame.local(-d), frame.local(l));
            match brdf {
                Brdf::Conductor { roughness, multiple_scattering, .. } => {
                    mf::conductor_pdf(rough(*roughness, *multiple_scattering), o, i)
                }
                Brdf::Dielectric { ior, roughness, multiple_scattering, .. } => {
                    mf::dielectric_pdf(rough(*roughness, *multiple_scattering), relative_ior(*ior, front_face), o, i)
                }
                Brdf::Plastic { ior, roughness, .. } => mf::plastic_pdf(coat(*roughness), *ior, o, i),
                _ => 0.0,
            }
        }
    }
}

/// The frame of the normal: local z = n (Duff et al.'s basis, as the GPU builds it).
struct Frame {
    t: DVec3,
    b: DVec3,
    n: DVec3,
}

impl Frame {
    fn new(n: DVec3) -> Self {
        let (t, b) = super::onb(n);
        Frame { t, b, n }
    }
    fn local(&self, v: DVec3) -> DVec3 {
        DVec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }
    fn world(&self, v: DVec3) -> DVec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }
}

/// The rough lobe of a roughness > 0, compensated unless single scattering is asked for.
fn rough(roughness: f64, multiple_scattering: bool) -> Rough {
    Rough { alpha: alpha_of(roughness), compensate: multiple_scattering }
}

/// The plastic's coat: `None` when smooth.
fn coat(roughness: f64) -> Option<f64> {
    (roughness > 0.0).then(|| alpha_of(roughness))
}

fn eval_rough(brdf: &Brdf, color: Color, front_face: bool, o: DVec3, i: DVec3) -> Color {
    match brdf {
        Brdf::Conductor { roughness, fresnel, multiple_scattering, .. } => {
            color * mf::conductor_eval(rough(*roughness, *multiple_scattering), *fresnel, o, i)
        }
        Brdf::Dielectric { ior, roughness, multiple_scattering, .. } => {
            color * mf::dielectric_eval(rough(*roughness, *multiple_scattering), relative_ior(*ior, front_face), o, i)
        }
        Brdf::Plastic { ior, roughness, .. } => mf::plastic_eval(coat(*roughness), *ior, color, o, i),
        _ => Color::BLACK,
    }
}

fn sample_rough(
    brdf: &Brdf,
    color: Color,
    front_face: bool,
    o: DVec3,
    xi_lobe: f64,
    xi: [f64; 2],
) -> Option<LocalSample> {
    let s = match brdf {
        Brdf::Conductor { roughness, fresnel, multiple_scattering, .. } => {
            mf::conductor_sample(rough(*roughness, *multiple_scattering), *fresnel, o, xi_lobe, xi)
        }
        Brdf::Dielectric { ior, roughness, multiple_scattering, .. } => {
            let r = rough(*roughness, *multiple_scattering);
            mf::dielectric_sample(r, relative_ior(*ior, front_face), o, xi_lobe, xi)
        }
        Brdf::Plastic { ior, roughness, .. } => {
            return mf::plastic_sample(coat(*roughness), *ior, color, o, xi_lobe, xi);
        }
        _ => None,
    }?;
    Some(LocalSample { weight: s.weight * color, ..s })
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
    use crate::scene::Pigment;

    fn diffuse() -> Brdf {
        Brdf::Diffuse { pigment: Pigment::default() }
    }

    /// χ² of diffuse sampling about a tilted normal; the weight is exactly the pigment.
    #[test]
    fn diffuse_sampling_matches_its_pdf_chi_square() {
        let n = DVec3::new(0.3, -0.5, 0.8).normalize();
        let d = -n;
        super::super::chi_square::chi_square_test(
            "diffuse",
            n,
            |rng| {
                let s = sample_bsdf(
                    &diffuse(),
                    Color::WHITE,
                    d,
                    n,
                    true,
                    rng.next_f64(),
                    [rng.next_f64(), rng.next_f64()],
                )?;
                assert_eq!(s.weight, Color::WHITE);
                Some(LocalSample { dir: s.dir, weight: s.weight, pdf: s.pdf, delta: s.delta })
            },
            |l| pdf_bsdf(&diffuse(), d, n, true, l),
        );
    }

    #[test]
    fn diffuse_eval_and_albedo() {
        let n = DVec3::Z;
        let c = Color::new(0.2, 0.5, 0.9);
        assert_eq!(eval_bsdf(&diffuse(), c, -n, n, true, DVec3::new(0.0, 0.6, 0.8)), c / PI);
        assert_eq!(eval_bsdf(&diffuse(), c, -n, n, true, DVec3::new(0.0, 0.6, -0.8)), Color::BLACK);
        assert_eq!(pdf_bsdf(&diffuse(), -n, n, true, -DVec3::Z), 0.0);
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
        assert_eq!(eval_bsdf(&m, c, d, n, true, s.dir), Color::BLACK);
    }

    #[test]
    fn dielectric_chooses_by_fresnel_and_obeys_snell() {
        let g = Brdf::Dielectric { pigment: Pigment::default(), ior: 1.5, roughness: 0.0, multiple_scattering: true };
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
