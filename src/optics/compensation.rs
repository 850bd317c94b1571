//! The constants of a material's multiple-scattering compensation (Kulla & Conty 2017):
//! everything that depends on its α and η only. The CPU reference computes them per query
//! and the GPU packer once per material, through these functions, so both renderers weigh
//! the compensating lobes with the same numbers.
//!
//! Each lobe has the shape (1 − E(μo))(1 − E(μi)) · scale: the energy a single-scattering
//! lobe loses at μo, returned with the angular profile that keeps it reciprocal.

use std::f64::consts::FRAC_1_PI;

use super::energy_tables::EnergyTables;
use super::fresnel::conductor_fresnel_average;
use crate::color::Color;

/// Below this, 1 − E_avg is treated as 0 (no multiple scattering to return).
pub const MS_EPSILON: f64 = 1e-6;

/// 1 / (π (1 − E_avg)): the normalisation of the lobe (1 − E(μo))(1 − E(μi)), whose
/// cosine-weighted integral over μi is then 1 − E(μo); 0 when the lobe loses nothing.
pub fn ms_scale(e_avg: f64) -> f64 {
    if 1.0 - e_avg < MS_EPSILON {
        0.0
    } else {
        FRAC_1_PI / (1.0 - e_avg)
    }
}

/// (1 − E(μo))(1 − E(μi)) · `scale`, each factor floored at 0.
pub fn ms_lobe(e_o: f64, e_i: f64, scale: f64) -> f64 {
    (1.0 - e_o).max(0.0) * (1.0 - e_i).max(0.0) * scale
}

/// A conductor's multiple-scattering lobe scale per channel: Kulla & Conty's tint
/// F_avg² E_avg / (1 − F_avg (1 − E_avg)) (the energy that leaves after two or more
/// bounces, each reflecting F_avg; 1 for F = 1) times [`ms_scale`].
pub fn conductor_ms(t: &EnergyTables, alpha: f64, fresnel: Option<(Color, Color)>) -> Color {
    let e_avg = t.conductor_average(alpha);
    let tint = match fresnel {
        None => Color::WHITE,
        Some((eta, k)) => eta.zip_with(k, |e, k| {
            let f = conductor_fresnel_average(e, k);
            f * f * e_avg / (1.0 - f * (1.0 - e_avg))
        }),
    };
    tint * ms_scale(e_avg)
}

/// The compensation of a dielectric interface of relative index `eta` seen from its
/// side: `k_t`, the share of the lost energy that is transmitted, and the scales of the
/// reflected and the transmitted lobes (the latter with the 1/η² of radiance).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DielectricLobes {
    /// Share of the lost energy returned by transmission: the probability with which the
    /// compensation lobe's sampler goes below the surface.
    pub k_t: f64,
    /// Scale of the reflected lobe: (1 − k_t) times [`ms_scale`] of this side's E_avg.
    pub reflect: f64,
    /// Scale of the transmitted lobe: k_t times [`ms_scale`] of the far side's E_avg, over η².
    pub transmit: f64,
}

/// k_T is the single-scattering transmitted share T_avg/E_avg on the entering side; on the
/// leaving side the share that balances it, k_T^o (1 − E_avg^o) = η² k_T^t (1 − E_avg^t),
/// which makes the lobes reciprocal (f(o→i)/n_o² = f(i→o)/n_i²); capped at 1, the
/// entering side's share is lowered to match.
pub fn dielectric_lobes(t: &EnergyTables, alpha: f64, eta: f64) -> DielectricLobes {
    let [ar_o, at_o] = t.dielectric_average(alpha, eta);
    let [ar_t, at_t] = t.dielectric_average(alpha, 1.0 / eta);
    let (avg_o, avg_t) = (ar_o + at_o, ar_t + at_t);
    // Entering side A (η_A→B = e ≥ 1) and leaving side B.
    let (e, avg_a, avg_b, share_a) =
        if eta >= 1.0 { (eta, avg_o, avg_t, at_o / avg_o) } else { (1.0 / eta, avg_t, avg_o, at_t / avg_t) };
    let (lost_a, lost_b) = ((1.0 - avg_a).max(0.0), (1.0 - avg_b).max(0.0));
    let (mut k_a, mut k_b) = (share_a, 0.0);
    if lost_a >= MS_EPSILON && lost_b >= MS_EPSILON {
        k_b = k_a * lost_a / (e * e * lost_b);
        if k_b > 1.0 {
            k_b = 1.0;
            k_a = e * e * lost_b / lost_a;
        }
    }
    let k_t = if eta >= 1.0 { k_a } else { k_b };
    DielectricLobes { k_t, reflect: (1.0 - k_t) * ms_scale(avg_o), transmit: k_t * ms_scale(avg_t) / (eta * eta) }
}

/// The plastic's coat: `internal` r_i = 1 − (1 − E_R,avg)/η², the coat's reflectance for
/// diffuse light from below, and `base` the [`ms_scale`] of its reflected albedo, so the
/// base seen through the coat is ρ (1 − r_i)/(1 − ρ r_i) · (1 − E_R(μo))(1 − E_R(μi)) ·
/// `base`. `alpha` is `None` for a smooth coat.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlasticCoat {
    /// r_i, the coat's reflectance for diffuse light arriving from the base below it.
    pub internal: f64,
    /// Scale of the base's lobe: [`ms_scale`] of the coat's average reflected albedo.
    pub base: f64,
}

/// The [`PlasticCoat`] constants of a coat of GGX α `alpha` and relative index `eta` (a
/// smooth coat, `None`, reads the tables at their smoothest α node).
pub fn plastic_coat(t: &EnergyTables, alpha: Option<f64>, eta: f64) -> PlasticCoat {
    let avg = t.dielectric_average(alpha.unwrap_or(0.0), eta)[0];
    PlasticCoat { internal: 1.0 - (1.0 - avg) / (eta * eta), base: ms_scale(avg) }
}

/// The diffuse base's factor ρ (1 − r_i)/(1 − ρ r_i) for one channel, ρ clamped to [0, 1]:
/// the series of the light bounced between base and coat, Σ (ρ r_i)ⁿ, diverges at ρ r_i ≥ 1,
/// where the closed form turns infinite and then negative (an HDR image as the base's
/// pigment reaches that: negative pixels on both devices before the clamp, found by
/// `tests/gpu_random_scenes.rs`). A base cannot reflect more than it receives.
pub fn plastic_base_albedo(rho: f64, internal: f64) -> f64 {
    let rho = rho.clamp(0.0, 1.0);
    rho * (1.0 - internal) / (1.0 - rho * internal)
}
