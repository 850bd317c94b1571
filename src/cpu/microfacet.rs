//! The rough BSDFs (GGX conductor, dielectric and plastic) with Kulla–Conty energy
//! compensation: sampling, evaluation and the density of the sampler, in the local frame of
//! the normal (z = n) with `o` = −d the direction toward the viewer (o.z > 0).
//!
//! Each BSDF is a mixture of single scattering (visible-normal sampling) and a
//! multiple-scattering lobe ∝ (1 − E(μo))(1 − E(μi)) (cosine-sampled); the lobe draw ξ3
//! chooses with probability E(μo) and is then reused, rescaled, for the second choice
//! (reflect or refract). The density is the mixture's, so a sample's weight f·|cos|/pdf and
//! MIS with light sampling are consistent. Transmitted radiance carries the 1/η² of
//! crossing the interface, as the smooth dielectric's does.

use glam::DVec3;

use crate::color::Color;
use crate::optics::compensation::{conductor_ms, dielectric_lobes, ms_lobe, plastic_base_albedo, plastic_coat};
use crate::optics::energy_tables::{energy_tables, EnergyTables};
use crate::optics::fresnel::{fresnel_conductor, fresnel_dielectric, reflect, refract};
use crate::optics::ggx::{distribution, masking_shadowing, sample_visible_normal, visible_normal_pdf};

use super::warp::{cosine_hemisphere, cosine_hemisphere_pdf};

/// A rough lobe: GGX α and whether multiple scattering is compensated (off only for
/// single-scattering comparisons).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rough {
    /// GGX α, the width of the microfacet slopes (`ggx::alpha_of` of the roughness).
    pub alpha: f64,
    /// Add the Kulla–Conty multiple-scattering lobe and mix its sampler in.
    pub compensate: bool,
}

/// A local-frame sample: direction, f·|cos|/pdf, pdf; `delta` for the plastic's smooth coat.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalSample {
    /// The sampled direction i in the local frame; z < 0 for a transmission.
    pub dir: DVec3,
    /// f·|cos θi|/pdf per channel: what the path's throughput is multiplied by.
    pub weight: Color,
    /// Solid-angle density of `dir` under the sampler (0 for a delta sample).
    pub pdf: f64,
    /// The smooth coat's mirror reflection: no density, and light sampling never finds it.
    pub delta: bool,
}

fn single_scattering_probability(r: Rough, e_o: f64) -> f64 {
    if r.compensate {
        e_o.clamp(0.0, 1.0)
    } else {
        1.0
    }
}

// ---- Conductor -----------------------------------------------------------------------

/// A conductor's Fresnel term per channel (1 without a complex index).
pub fn conductor_fresnel(cos: f64, fresnel: Option<(Color, Color)>) -> Color {
    match fresnel {
        None => Color::WHITE,
        Some((eta, k)) => eta.zip_with(k, |e, k| fresnel_conductor(cos, e, k)),
    }
}

/// f(o, i) of a GGX conductor, untinted.
pub fn conductor_eval(r: Rough, fresnel: Option<(Color, Color)>, o: DVec3, i: DVec3) -> Color {
    if o.z <= 0.0 || i.z <= 0.0 {
        return Color::BLACK;
    }
    let h = (o + i).normalize();
    let ss = distribution(r.alpha, h) * masking_shadowing(r.alpha, o, i) / (4.0 * o.z * i.z);
    let mut f = conductor_fresnel(o.dot(h), fresnel) * ss;
    if r.compensate {
        let t = energy_tables();
        let shape = ms_lobe(t.conductor_albedo(o.z, r.alpha), t.conductor_albedo(i.z, r.alpha), 1.0);
        f += conductor_ms(t, r.alpha, fresnel) * shape;
    }
    f
}

/// Solid-angle density with which [`conductor_sample`] draws `i` seen from `o`: the
/// visible-normal reflection with probability E(μo) (1 when uncompensated), else the cosine
/// lobe. 0 when either direction is below the surface.
pub fn conductor_pdf(r: Rough, o: DVec3, i: DVec3) -> f64 {
    if o.z <= 0.0 || i.z <= 0.0 {
        return 0.0;
    }
    let p = single_scattering_probability(r, energy_tables().conductor_albedo(o.z, r.alpha));
    let h = (o + i).normalize();
    p * visible_normal_pdf(r.alpha, o, h) / (4.0 * o.dot(h)) + (1.0 - p) * cosine_hemisphere_pdf(i.z)
}

/// Draws i for a GGX conductor seen from `o`: `xi_lobe` chooses single scattering (a visible
/// normal, `xi` placing it, then a mirror reflection) or the multiple-scattering lobe (`xi`
/// cosine-distributed). `None` when nothing is scattered (i below the surface, a zero or
/// non-finite weight).
pub fn conductor_sample(
    r: Rough,
    fresnel: Option<(Color, Color)>,
    o: DVec3,
    xi_lobe: f64,
    xi: [f64; 2],
) -> Option<LocalSample> {
    let p = single_scattering_probability(r, energy_tables().conductor_albedo(o.z, r.alpha));
    let i = if xi_lobe < p {
        reflect(-o, sample_visible_normal(r.alpha, o, xi[0], xi[1]))
    } else {
        cosine_hemisphere(xi[0], xi[1])
    };
    finish(i, conductor_eval(r, fresnel, o, i), conductor_pdf(r, o, i), false)
}

/// The weight f·|cos|/pdf of a sampled direction, or `None` when nothing is scattered.
fn finish(i: DVec3, f: Color, pdf: f64, delta: bool) -> Option<LocalSample> {
    if pdf.is_nan() || pdf <= 0.0 || !i.is_finite() || f.is_black() {
        return None;
    }
    let weight = f * (i.z.abs() / pdf);
    weight.is_finite().then_some(LocalSample { dir: i, weight, pdf, delta })
}

// ---- Dielectric ----------------------------------------------------------------------

/// The compensation of an interface of relative index `eta` for a view μo: the albedo
/// E_o(μo) on this side and the lobes' constants.
fn dielectric_energy(
    t: &EnergyTables,
    alpha: f64,
    eta: f64,
    mu_o: f64,
) -> (f64, crate::optics::compensation::DielectricLobes) {
    let [r_o, t_o] = t.dielectric_albedo(mu_o, alpha, eta);
    (r_o + t_o, dielectric_lobes(t, alpha, eta))
}

/// The generalised half vector of a refraction o → i (Walter et al. 2007), facing +z.
fn refraction_half_vector(o: DVec3, i: DVec3, eta: f64) -> Option<DVec3> {
    let h = -(o + eta * i);
    let len = h.length();
    if len.is_nan() || len <= 1e-12 {
        return None;
    }
    let h = h / len;
    Some(if h.z < 0.0 { -h } else { h })
}

/// f(o, i) of a GGX dielectric interface of relative index `eta` = n_i / n_o (radiance:
/// transmission includes 1/η²), untinted.
pub fn dielectric_eval(r: Rough, eta: f64, o: DVec3, i: DVec3) -> f64 {
    if o.z <= 0.0 || i.z == 0.0 {
        return 0.0;
    }
    let a = r.alpha;
    let ss = if i.z > 0.0 {
        let h = (o + i).normalize();
        fresnel_dielectric(o.dot(h), eta) * distribution(a, h) * masking_shadowing(a, o, i) / (4.0 * o.z * i.z)
    } else {
        match refraction_half_vector(o, i, eta) {
            Some(h) if o.dot(h) > 0.0 && i.dot(h) < 0.0 => {
                let (oh, ih) = (o.dot(h), i.dot(h));
                let den = oh + eta * ih;
                (1.0 - fresnel_dielectric(oh, eta)) * distribution(a, h) * masking_shadowing(a, o, i) * oh * -ih
                    / (o.z * -i.z * den * den)
            }
            _ => 0.0,
        }
    };
    if !r.compensate {
        return ss;
    }
    let t = energy_tables();
    let (e_o, lobes) = dielectric_energy(t, a, eta, o.z);
    let ms = if i.z > 0.0 {
        let [ri, ti] = t.dielectric_albedo(i.z, a, eta);
        ms_lobe(e_o, ri + ti, lobes.reflect)
    } else {
        let [ri, ti] = t.dielectric_albedo(-i.z, a, 1.0 / eta);
        ms_lobe(e_o, ri + ti, lobes.transmit)
    };
    ss + ms
}

/// The probability that [`dielectric_sample`] draws the visible-normal lobe (the
/// directional albedo E(μo), clamped; 1 without compensation), and the compensation lobe's
/// transmit probability, for an interface seen at cos θ = `mu_o`.
fn dielectric_lobe_choice(r: Rough, eta: f64, mu_o: f64) -> (f64, f64) {
    if !r.compensate {
        return (1.0, 0.0);
    }
    let (e_o, lobes) = dielectric_energy(energy_tables(), r.alpha, eta, mu_o);
    (e_o.clamp(0.0, 1.0), lobes.k_t)
}

/// Solid-angle density with which [`dielectric_sample`] draws `i` (reflected for i.z > 0,
/// transmitted for i.z < 0) seen from `o` through an interface of relative index `eta`:
/// the visible-normal lobe weighted by Fresnel, mixed with the compensation lobe. 0 for
/// o.z ≤ 0 or i.z = 0.
pub fn dielectric_pdf(r: Rough, eta: f64, o: DVec3, i: DVec3) -> f64 {
    if o.z <= 0.0 || i.z == 0.0 {
        return 0.0;
    }
    let (p, k_t) = dielectric_lobe_choice(r, eta, o.z);
    let cos = cosine_hemisphere_pdf(i.z.abs());
    if i.z > 0.0 {
        let h = (o + i).normalize();
        let ss = fresnel_dielectric(o.dot(h), eta) * visible_normal_pdf(r.alpha, o, h) / (4.0 * o.dot(h));
        p * ss + (1.0 - p) * (1.0 - k_t) * cos
    } else {
        let ss = match refraction_half_vector(o, i, eta) {
            Some(h) if o.dot(h) > 0.0 && i.dot(h) < 0.0 => {
                let den = o.dot(h) + eta * i.dot(h);
                (1.0 - fresnel_dielectric(o.dot(h), eta)) * visible_normal_pdf(r.alpha, o, h) * eta * eta * -i.dot(h)
                    / (den * den)
            }
            _ => 0.0,
        };
        p * ss + (1.0 - p) * k_t * cos
    }
}

/// Draws i for a GGX dielectric interface of relative index `eta` seen from `o`: with
/// probability E(μo) a visible normal, reflected or refracted by its Fresnel term (`xi_lobe`
/// rescaled decides), else the cosine lobe, mirrored below the surface with the
/// compensation's transmit probability. `None` when the microfacet sends i to the wrong side
/// (the single-scattering loss) or nothing is scattered.
pub fn dielectric_sample(r: Rough, eta: f64, o: DVec3, xi_lobe: f64, xi: [f64; 2]) -> Option<LocalSample> {
    let (p, k_t) = dielectric_lobe_choice(r, eta, o.z);
    let i = if xi_lobe < p {
        let u = xi_lobe / p;
        let h = sample_visible_normal(r.alpha, o, xi[0], xi[1]);
        let f = fresnel_dielectric(o.dot(h), eta);
        // A reflection below the horizon or a refraction above it leaves the surface on
        // the wrong side: that energy is the single-scattering loss.
        match refract(-o, h, eta) {
            Some(t) if u >= f => Some(t.normalize()).filter(|t| t.z < 0.0)?,
            _ => Some(reflect(-o, h)).filter(|r| r.z > 0.0)?,
        }
    } else {
        let u = (xi_lobe - p) / (1.0 - p);
        let c = cosine_hemisphere(xi[0], xi[1]);
        if u < k_t {
            DVec3::new(c.x, c.y, -c.z)
        } else {
            c
        }
    };
    finish(i, Color::gray(dielectric_eval(r, eta, o, i)), dielectric_pdf(r, eta, o, i), false)
}

// ---- Plastic -------------------------------------------------------------------------

/// The coat's reflected albedo E_R(μ) and its average: the exact Fresnel reflectance for a
/// smooth coat (α = None), the table's GGX reflection otherwise.
fn coat_albedo(t: &EnergyTables, alpha: Option<f64>, eta: f64, mu: f64) -> f64 {
    match alpha {
        None => fresnel_dielectric(mu, eta),
        Some(a) => t.dielectric_albedo(mu, a, eta)[0],
    }
}

/// The diffuse base seen through the coat (see [`plastic_coat`]): for a white base it
/// returns exactly what the coat does not reflect; for a smooth coat it is the classic
/// ρ(1 − F(μo))(1 − F(μi)) / (π η² (1 − ρ r_i)).
fn plastic_base(t: &EnergyTables, alpha: Option<f64>, eta: f64, rho: Color, mu_o: f64, mu_i: f64) -> Color {
    let coat = plastic_coat(t, alpha, eta);
    let shape = ms_lobe(coat_albedo(t, alpha, eta, mu_o), coat_albedo(t, alpha, eta, mu_i), coat.base);
    rho.map(|p| plastic_base_albedo(p, coat.internal) * shape)
}

/// f(o, i) of the plastic: the coat's GGX reflection (none for a smooth coat, a delta) and
/// the base.
pub fn plastic_eval(alpha: Option<f64>, eta: f64, rho: Color, o: DVec3, i: DVec3) -> Color {
    if o.z <= 0.0 || i.z <= 0.0 {
        return Color::BLACK;
    }
    let t = energy_tables();
    let mut f = plastic_base(t, alpha, eta, rho, o.z, i.z);
    if let Some(a) = alpha {
        let h = (o + i).normalize();
        f += Color::gray(
            fresnel_dielectric(o.dot(h), eta) * distribution(a, h) * masking_shadowing(a, o, i) / (4.0 * o.z * i.z),
        );
    }
    f
}

/// Density of the plastic's non-delta scattering: the coat with probability E_R(μo).
pub fn plastic_pdf(alpha: Option<f64>, eta: f64, o: DVec3, i: DVec3) -> f64 {
    if o.z <= 0.0 || i.z <= 0.0 {
        return 0.0;
    }
    let p = coat_albedo(energy_tables(), alpha, eta, o.z);
    let coat = match alpha {
        None => 0.0,
        Some(a) => {
            let h = (o + i).normalize();
            visible_normal_pdf(a, o, h) / (4.0 * o.dot(h))
        }
    };
    p * coat + (1.0 - p) * cosine_hemisphere_pdf(i.z)
}

/// Draws i for the plastic, a coat of GGX α `alpha` (`None`: smooth) and index `eta` over a
/// diffuse base of albedo `rho`: with probability E_R(μo) the coat (for a smooth coat its
/// mirror reflection, a delta sample of weight 1), else the base's cosine lobe. `None` when
/// nothing is scattered.
pub fn plastic_sample(
    alpha: Option<f64>,
    eta: f64,
    rho: Color,
    o: DVec3,
    xi_lobe: f64,
    xi: [f64; 2],
) -> Option<LocalSample> {
    let p = coat_albedo(energy_tables(), alpha, eta, o.z);
    if xi_lobe < p && alpha.is_none() {
        // The smooth coat reflects F(μo), chosen with probability F(μo).
        return Some(LocalSample { dir: DVec3::new(-o.x, -o.y, o.z), weight: Color::WHITE, pdf: 0.0, delta: true });
    }
    let i = match alpha {
        Some(a) if xi_lobe < p => reflect(-o, sample_visible_normal(a, o, xi[0], xi[1])),
        _ => cosine_hemisphere(xi[0], xi[1]),
    };
    finish(i, plastic_eval(alpha, eta, rho, o, i), plastic_pdf(alpha, eta, o, i), false)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::chi_square::chi_square_test;
    use crate::optics::ggx::ALPHA_MIN;
    use crate::sampling::Pcg32;

    const ROUGHNESSES: [f64; 4] = [0.05, 0.2, 0.5, 1.0];

    fn view(mu: f64) -> DVec3 {
        DVec3::new((1.0 - mu * mu).sqrt(), 0.0, mu)
    }

    fn rough(alpha: f64, compensate: bool) -> Rough {
        Rough { alpha: alpha.max(ALPHA_MIN), compensate }
    }

    /// Mean energy of `n` samples (stratified in the direction draws): the weight, with
    /// transmitted radiance scaled back to flux by η².
    fn furnace(n: usize, eta: f64, mut sample: impl FnMut(f64, [f64; 2]) -> Option<LocalSample>) -> f64 {
        let mut rng = Pcg32::new(7, 11);
        let side = (n as f64).sqrt() as usize;
        let mut sum = 0.0;
        for a in 0..side {
            for b in 0..side {
                let xi = [(a as f64 + rng.next_f64()) / side as f64, (b as f64 + rng.next_f64()) / side as f64];
                if let Some(s) = sample(rng.next_f64(), xi) {
                    sum += s.weight.g * if s.dir.z < 0.0 { eta * eta } else { 1.0 };
                }
            }
        }
        sum / (side * side) as f64
    }

    /// White furnace: an F = 1 conductor and rough glass (either side) return every bit of
    /// energy within 1% at every roughness, and a white plastic too; single scattering
    /// alone loses energy as roughness grows. Prints the STABILITY.md table.
    #[test]
    fn white_furnace_is_one_at_every_roughness() {
        let n = 40_000;
        for &mu in &[0.2, 0.5, 1.0] {
            let o = view(mu);
            for &r in &ROUGHNESSES {
                let c = |comp| furnace(n, 1.0, |l, xi| conductor_sample(rough(r, comp), None, o, l, xi));
                let (ms, ss) = (c(true), c(false));
                println!("conductor μ {mu} r {r}: {ms:.4} (single scattering {ss:.4})");
                assert!((ms - 1.0).abs() < 0.01, "conductor μ {mu} r {r}: {ms}");
                assert!(ss <= ms + 1e-3);
                for eta in [1.5, 1.0 / 1.5] {
                    let g = |comp| furnace(n, eta, |l, xi| dielectric_sample(rough(r, comp), eta, o, l, xi));
                    let (ms, ss) = (g(true), g(false));
                    println!("dielectric η {eta:.3} μ {mu} r {r}: {ms:.4} (single scattering {ss:.4})");
                    assert!((ms - 1.0).abs() < 0.01, "dielectric η {eta} μ {mu} r {r}: {ms}");
                }
                let p = furnace(n, 1.0, |l, xi| plastic_sample(Some(r), 1.5, Color::WHITE, o, l, xi));
                println!("plastic μ {mu} r {r}: {p:.4}");
                assert!((p - 1.0).abs() < 0.01, "plastic μ {mu} r {r}: {p}");
            }
            let p = furnace(n, 1.0, |l, xi| plastic_sample(None, 1.5, Color::WHITE, o, l, xi));
            assert!((p - 1.0).abs() < 0.01, "smooth plastic μ {mu}: {p}");
        }
        // At 1: single scattering loses tens of percent at normal incidence.
        let ss = furnace(n, 1.0, |l, xi| conductor_sample(rough(1.0, false), None, view(1.0), l, xi));
        assert!(ss < 0.9, "{ss}");
    }

    /// A plastic base brighter than white (an HDR image as its pigment) reflects as a white
    /// one: without the clamp ρ = 3 under an η = 1.7 coat (r_i ≈ 0.69) made the base's term
    /// negative, and ρ = 1/r_i infinite. Hand values: ρ (1 − r_i)/(1 − ρ r_i) is 1 at ρ = 1
    /// and 0 at ρ = 0, whatever r_i.
    #[test]
    fn a_plastic_base_above_white_reflects_as_white() {
        use crate::optics::compensation::plastic_base_albedo;
        for internal in [0.0, 0.4, 0.69, 0.95] {
            assert!((plastic_base_albedo(1.0, internal) - 1.0).abs() < 1e-15);
            assert_eq!(plastic_base_albedo(0.0, internal), 0.0);
            for rho in [1.0 + 1e-9, 1.0 / internal.max(1e-3), 3.0, 1e30] {
                assert_eq!(plastic_base_albedo(rho, internal), plastic_base_albedo(1.0, internal), "ρ {rho}");
            }
        }
        let (o, i) = (view(0.6), view(0.3) * DVec3::new(-1.0, 1.0, 1.0));
        for r in [None, Some(0.3)] {
            let bright = plastic_eval(r, 1.7, Color::gray(3.0), o, i);
            assert!(bright.r > 0.0 && bright == plastic_eval(r, 1.7, Color::WHITE, o, i), "{bright:?}");
        }
    }

    /// χ² of each sampler against its density, over several roughnesses and angles.
    #[test]
    fn sampling_matches_density_chi_square() {
        for &alpha in &[0.2, 0.5, 1.0] {
            for &theta in &[0.3f64, 1.2] {
                let o = DVec3::new(theta.sin(), 0.0, theta.cos());
                let r = rough(alpha, true);
                let fr = Some((Color::new(0.2, 0.9, 1.1), Color::new(3.9, 2.4, 1.6)));
                chi_square_test(
                    &format!("conductor α {alpha} θ {theta}"),
                    DVec3::Z,
                    |rng| conductor_sample(r, fr, o, rng.next_f64(), [rng.next_f64(), rng.next_f64()]),
                    |i| conductor_pdf(r, o, i),
                );
                for eta in [1.5, 1.0 / 1.5] {
                    chi_square_test(
                        &format!("dielectric η {eta} α {alpha} θ {theta}"),
                        DVec3::Z,
                        |rng| dielectric_sample(r, eta, o, rng.next_f64(), [rng.next_f64(), rng.next_f64()]),
                        |i| dielectric_pdf(r, eta, o, i),
                    );
                }
                let rho = Color::new(0.8, 0.3, 0.1);
                chi_square_test(
                    &format!("plastic α {alpha} θ {theta}"),
                    DVec3::Z,
                    |rng| plastic_sample(Some(alpha), 1.5, rho, o, rng.next_f64(), [rng.next_f64(), rng.next_f64()]),
                    |i| plastic_pdf(Some(alpha), 1.5, o, i),
                );
            }
        }
    }

    fn random_dir(rng: &mut Pcg32, upper: bool) -> DVec3 {
        let z = rng.next_f64().max(1e-3);
        let phi = 2.0 * std::f64::consts::PI * rng.next_f64();
        let s = (1.0 - z * z).sqrt();
        DVec3::new(s * phi.cos(), s * phi.sin(), if upper { z } else { -z })
    }

    /// f(o→i) = f(i→o) for reflection; transmission obeys f(o→i)/n_o² = f(i→o)/n_i², i.e.
    /// f(i, o; 1/η) = η² f(o, i; η) (energy compensation included).
    #[test]
    fn every_bsdf_is_reciprocal() {
        let mut rng = Pcg32::new(5, 9);
        let fr = Some((Color::new(0.2, 0.9, 1.1), Color::new(3.9, 2.4, 1.6)));
        for _ in 0..300 {
            let alpha = rng.next_f64().max(0.01);
            let r = rough(alpha, true);
            let (o, i) = (random_dir(&mut rng, true), random_dir(&mut rng, true));
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-6);
            let (a, b) = (conductor_eval(r, fr, o, i), conductor_eval(r, fr, i, o));
            assert!(close(a.r, b.r) && close(a.b, b.b), "conductor {a:?} {b:?}");
            let (a, b) = (
                plastic_eval(Some(alpha), 1.5, Color::gray(0.6), o, i),
                plastic_eval(Some(alpha), 1.5, Color::gray(0.6), i, o),
            );
            assert!(close(a.g, b.g), "plastic {a:?} {b:?}");
            let (a, b) =
                (plastic_eval(None, 1.5, Color::gray(0.6), o, i), plastic_eval(None, 1.5, Color::gray(0.6), i, o));
            assert!(close(a.g, b.g), "smooth plastic {a:?} {b:?}");
            for eta in [1.5, 1.0 / 1.33] {
                assert!(close(dielectric_eval(r, eta, o, i), dielectric_eval(r, eta, i, o)), "reflection");
                // i below: seen from the other side, the frame flips.
                let t = random_dir(&mut rng, false);
                let flip = |v: DVec3| -v;
                let a = dielectric_eval(r, eta, o, t);
                let b = dielectric_eval(r, 1.0 / eta, flip(t), flip(o));
                assert!(close(b, eta * eta * a), "transmission η {eta} α {alpha}: {b} vs η² {a}");
            }
        }
    }

    /// Roughness → 0 gives the smooth materials: the albedos of α = ALPHA_MIN equal the
    /// closed forms of the mirror (F(μ)), of glass (1, split F : 1 − F) and of the smooth
    /// plastic.
    #[test]
    fn vanishing_roughness_is_the_smooth_material() {
        let (eta_c, k_c) = (0.2, 3.0);
        let fr = Some((Color::gray(eta_c), Color::gray(k_c)));
        for mu in [0.3, 0.7, 1.0] {
            let o = view(mu);
            let r = rough(0.0, true);
            let e = furnace(10_000, 1.0, |l, xi| conductor_sample(r, fr, o, l, xi));
            let f = fresnel_conductor(mu, eta_c, k_c);
            assert!((e - f).abs() < 5e-3, "conductor μ {mu}: {e} vs {f}");
            let reflected = furnace(10_000, 1.5, |l, xi| dielectric_sample(r, 1.5, o, l, xi).filter(|s| s.dir.z > 0.0));
            let f = fresnel_dielectric(mu, 1.5);
            assert!((reflected - f).abs() < 5e-3, "glass μ {mu}: {reflected} vs {f}");
            let rho = 0.5;
            let t = energy_tables();
            let avg = t.dielectric_average(0.0, 1.5)[0];
            let ri = 1.0 - (1.0 - avg) / 2.25;
            let expected = f + rho * (1.0 - ri) / (1.0 - rho * ri) * (1.0 - f);
            let smooth = furnace(10_000, 1.0, |l, xi| plastic_sample(None, 1.5, Color::gray(rho), o, l, xi));
            let rough_ = furnace(10_000, 1.0, |l, xi| plastic_sample(Some(ALPHA_MIN), 1.5, Color::gray(rho), o, l, xi));
            assert!(
                (smooth - expected).abs() < 5e-3 && (rough_ - expected).abs() < 5e-3,
                "plastic μ {mu}: {smooth} {rough_} vs {expected}"
            );
        }
    }

    /// Grazing views, tiny α and total internal reflection give finite results.
    #[test]
    fn no_nan_at_the_edges() {
        let mut rng = Pcg32::new(1, 1);
        for alpha in [ALPHA_MIN, 0.5, 1.0] {
            for mu in [1e-9, 1e-4, 0.5] {
                let o = view(mu);
                for _ in 0..500 {
                    let (l, xi) = (rng.next_f64(), [rng.next_f64(), rng.next_f64()]);
                    let r = rough(alpha, true);
                    let all = [
                        conductor_sample(r, None, o, l, xi),
                        dielectric_sample(r, 1.0 / 1.5, o, l, xi),
                        dielectric_sample(r, 1.5, o, l, xi),
                        plastic_sample(Some(alpha), 1.5, Color::WHITE, o, l, xi),
                    ];
                    for s in all.into_iter().flatten() {
                        assert!(s.weight.is_finite() && s.pdf.is_finite() && s.dir.is_finite(), "{s:?}");
                    }
                    let i = random_dir(&mut rng, l < 0.5);
                    assert!(
                        dielectric_eval(r, 1.0 / 1.5, o, i).is_finite()
                            && dielectric_pdf(r, 1.0 / 1.5, o, i).is_finite()
                    );
                }
            }
        }
    }
}
