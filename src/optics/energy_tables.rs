//! Directional albedos of single-scattering GGX surfaces, the tables behind the energy
//! compensation of Kulla & Conty 2017 ("Revisiting Physically Based Shading at
//! Imageworks"): the energy 1 − E(μ) a microfacet lobe loses to multiple scattering is
//! returned by a lobe ∝ (1 − E(μo))(1 − E(μi)).
//!
//! Generated deterministically (a fixed midpoint rule over the two uniforms of
//! visible-normal sampling, so each entry is an integral computed the same way on every
//! machine) and shipped with the crate: `energy_tables.bin` holds what
//! [`EnergyTables::generate`] gives, which takes about 0.6 s of CPU, a cost every process
//! rendering a rough material paid before its first sample. A test regenerates the tables
//! and checks the shipped ones against them; after a change to the integrals, rewrite the
//! file with `LUMEN_WRITE_ENERGY_TABLES=1 cargo test --release --lib energy_tables`. The
//! CPU reference reads them through one interpolation; the GPU packer uploads the same
//! numbers.
//!
//! Tables (μ = cos θo, α the GGX roughness, both with nodes uniform in their square root,
//! η the relative index n_t / n_o):
//! - conductor: E(μ, α) of a reflector with F = 1, and its average E_avg(α) = 2∫E μ dμ;
//! - dielectric, for η > 1 (entering) and for 1/η (leaving): the reflected and the
//!   transmitted energy (flux, without the 1/η² of radiance) E_R(μ, α, η), E_T(μ, α, η), and
//!   their averages.

use std::sync::OnceLock;

use glam::DVec3;
use rayon::prelude::*;

use super::fresnel::{fresnel_dielectric, reflect, refract};
use super::ggx::{masking, masking_shadowing, sample_visible_normal, ALPHA_MIN};

/// Nodes in μ ∈ [0, 1] and α ∈ [0, 1] of the conductor table.
pub const CONDUCTOR_NODES: usize = 32;
/// Nodes in μ and α of the dielectric tables.
pub const DIELECTRIC_NODES: usize = 16;
/// Nodes in x = (η − 1)/(η + 1) ∈ [0, X_MAX] (F0 = x² is nearly linear in the albedos).
pub const ETA_NODES: usize = 8;
/// η = 3: indices above it use its entries.
pub const X_MAX: f64 = 0.5;
/// Side index of an interface seen from the rarer medium (η ≥ 1): the light enters the denser one.
pub const ENTERING: usize = 0;
/// Side index of an interface seen from the denser medium (η < 1; tabulated at 1/η).
pub const LEAVING: usize = 1;
/// Smallest μ integrated (μ = 0 has no visible normals); node 0 holds its value.
const MU_MIN: f64 = 1e-3;
/// The midpoint rule's points per uniform.
const CONDUCTOR_POINTS: usize = 64;
const DIELECTRIC_POINTS: usize = 48;

/// The tables, row-major: conductor `[α][μ]`, conductor average `[α]`, dielectric
/// `[side][η][α][μ]` and its averages `[side][η][α]`.
#[derive(Debug, Clone, PartialEq)]
pub struct EnergyTables {
    /// E(μ, α) of an F = 1 conductor, `[α][μ]`, [`CONDUCTOR_NODES`] per axis.
    pub conductor: Vec<f64>,
    /// E_avg(α) of the conductor, one value per α node.
    pub conductor_average: Vec<f64>,
    /// Reflected energy E_R(μ, α, η), `[side][η][α][μ]`, [`DIELECTRIC_NODES`] per α and μ.
    pub reflected: Vec<f64>,
    /// Transmitted flux E_T(μ, α, η), laid out as `reflected`.
    pub transmitted: Vec<f64>,
    /// Averages of E_R over μ, `[side][η][α]`.
    pub reflected_average: Vec<f64>,
    /// Averages of E_T over μ, `[side][η][α]`.
    pub transmitted_average: Vec<f64>,
}

/// The process's tables: the shipped ones, decoded on first use.
pub fn energy_tables() -> &'static EnergyTables {
    static TABLES: OnceLock<EnergyTables> = OnceLock::new();
    TABLES.get_or_init(EnergyTables::shipped)
}

/// [`EnergyTables::generate`]'s conductor, reflected and transmitted tables, in that order,
/// row-major, little-endian f64 (the averages are derived from them on decoding).
const SHIPPED: &[u8] = include_bytes!("energy_tables.bin");
/// Values in the shipped file.
const SHIPPED_VALUES: usize =
    CONDUCTOR_NODES * CONDUCTOR_NODES + 2 * (2 * ETA_NODES * DIELECTRIC_NODES * DIELECTRIC_NODES);
const _: () = assert!(SHIPPED.len() == 8 * SHIPPED_VALUES, "energy_tables.bin does not match the table sizes");

/// Node `j` of `n` over [0, 1].
fn node(j: usize, n: usize) -> f64 {
    j as f64 / (n - 1) as f64
}

/// The relative index of η-node `k` on `side`.
pub fn eta_of_node(k: usize, side: usize) -> f64 {
    let x = node(k, ETA_NODES) * X_MAX;
    let eta = (1.0 + x) / (1.0 - x);
    if side == ENTERING {
        eta
    } else {
        1.0 / eta
    }
}

/// The viewing direction of μ-node `j`: nodes are uniform in √μ, denser at grazing angles
/// where the albedo changes fastest.
fn view(j: usize, n: usize) -> DVec3 {
    let mu = (node(j, n) * node(j, n)).max(MU_MIN);
    DVec3::new((1.0 - mu * mu).sqrt(), 0.0, mu)
}

/// Mean over the midpoint grid of `points`² pairs of uniforms of `f(visible normal)`.
fn visible_normal_mean(alpha: f64, o: DVec3, points: usize, mut f: impl FnMut(DVec3) -> [f64; 2]) -> [f64; 2] {
    let mut sum = [0.0; 2];
    for a in 0..points {
        for b in 0..points {
            let u = ((a as f64 + 0.5) / points as f64, (b as f64 + 0.5) / points as f64);
            let v = f(sample_visible_normal(alpha, o, u.0, u.1));
            sum[0] += v[0];
            sum[1] += v[1];
        }
    }
    let n = (points * points) as f64;
    [sum[0] / n, sum[1] / n]
}

/// E(μ) of an F = 1 GGX reflector: the mean of the visible-normal sample weight G2/G1.
pub fn conductor_albedo_integral(alpha: f64, o: DVec3, points: usize) -> f64 {
    let g1 = masking(alpha, o);
    visible_normal_mean(alpha, o, points, |h| {
        let i = reflect(-o, h);
        [if i.z > 0.0 { masking_shadowing(alpha, o, i) / g1 } else { 0.0 }, 0.0]
    })[0]
}

/// (E_R, E_T) of a GGX dielectric interface of relative index `eta` seen from `o`: the
/// visible-normal sample weights F·G2/G1 (reflection) and (1 − F)·G2/G1 (refraction).
pub fn dielectric_albedo_integral(alpha: f64, eta: f64, o: DVec3, points: usize) -> [f64; 2] {
    let g1 = masking(alpha, o);
    visible_normal_mean(alpha, o, points, |h| {
        let f = fresnel_dielectric(o.dot(h), eta);
        let r = reflect(-o, h);
        let er = if r.z > 0.0 { f * masking_shadowing(alpha, o, r) / g1 } else { 0.0 };
        let et = match refract(-o, h, eta) {
            Some(t) if t.z < 0.0 => (1.0 - f) * masking_shadowing(alpha, o, t.normalize()) / g1,
            _ => 0.0,
        };
        [er, et]
    })
}

/// 2∫E(μ)μ dμ of the interpolant through the μ-row `row`: with s = √μ it is 4∫E s³ ds,
/// each segment linear in s, integrated exactly.
fn average(row: &[f64]) -> f64 {
    let h = 1.0 / (row.len() - 1) as f64;
    let mut sum = 0.0;
    for j in 0..row.len() - 1 {
        let (a, b) = (j as f64 * h, (j + 1) as f64 * h);
        // ∫_a^b (E_a (b − s) + E_b (s − a))/h · s³ ds.
        let m3 = |s: f64| s.powi(4) / 4.0;
        let m4 = |s: f64| s.powi(5) / 5.0;
        let ea = b * (m3(b) - m3(a)) - (m4(b) - m4(a));
        let eb = (m4(b) - m4(a)) - a * (m3(b) - m3(a));
        sum += (row[j] * ea + row[j + 1] * eb) / h;
    }
    4.0 * sum
}

/// Linear interpolation position of `v` ∈ [0, 1] over `n` nodes: (lower node, weight).
fn position(v: f64, n: usize) -> (usize, f64) {
    let t = v.clamp(0.0, 1.0) * (n - 1) as f64;
    let j = (t.floor() as usize).min(n - 2);
    (j, t - j as f64)
}

/// Bilinear interpolation of a `[α][μ]` block of `n`×`n` nodes.
fn bilinear(block: &[f64], n: usize, mu: f64, alpha: f64) -> f64 {
    let (j, tm) = position(mu.max(0.0).sqrt(), n);
    let (i, ta) = position(alpha.max(0.0).sqrt(), n);
    let at = |i: usize, j: usize| block[i * n + j];
    let lo = at(i, j) * (1.0 - tm) + at(i, j + 1) * tm;
    let hi = at(i + 1, j) * (1.0 - tm) + at(i + 1, j + 1) * tm;
    lo * (1.0 - ta) + hi * ta
}

/// Linear interpolation of a row of α-nodes (uniform in √α, like μ).
fn linear(row: &[f64], alpha: f64) -> f64 {
    let (j, t) = position(alpha.max(0.0).sqrt(), row.len());
    row[j] * (1.0 - t) + row[j + 1] * t
}

/// The side and the η coordinate x/X_MAX ∈ [0, 1] of a relative index.
fn side_and_x(eta: f64) -> (usize, f64) {
    let (side, e) = if eta >= 1.0 { (ENTERING, eta) } else { (LEAVING, 1.0 / eta) };
    (side, ((e - 1.0) / (e + 1.0) / X_MAX).clamp(0.0, 1.0))
}

impl EnergyTables {
    /// Computes the tables by numerical integration (about 0.6 s of CPU, on the rayon pool);
    /// the result is the same on every machine and is what `energy_tables.bin` ships.
    pub fn generate() -> Self {
        let (nc, nd) = (CONDUCTOR_NODES, DIELECTRIC_NODES);
        let conductor: Vec<f64> = (0..nc * nc)
            .into_par_iter()
            .map(|e| {
                let alpha = node(e / nc, nc).powi(2).max(ALPHA_MIN);
                conductor_albedo_integral(alpha, view(e % nc, nc), CONDUCTOR_POINTS)
            })
            .collect();
        let dielectric: Vec<[f64; 2]> = (0..2 * ETA_NODES * nd * nd)
            .into_par_iter()
            .map(|e| {
                let (side, k) = (e / (ETA_NODES * nd * nd), e / (nd * nd) % ETA_NODES);
                let alpha = node(e / nd % nd, nd).powi(2).max(ALPHA_MIN);
                dielectric_albedo_integral(alpha, eta_of_node(k, side), view(e % nd, nd), DIELECTRIC_POINTS)
            })
            .collect();
        let reflected: Vec<f64> = dielectric.iter().map(|v| v[0]).collect();
        let transmitted: Vec<f64> = dielectric.iter().map(|v| v[1]).collect();
        Self::from_tables(conductor, reflected, transmitted)
    }

    /// The tables shipped in `energy_tables.bin` (what [`Self::generate`] gives).
    ///
    /// ```
    /// use lumen::optics::energy_tables::EnergyTables;
    /// let t = EnergyTables::shipped();
    /// // A smooth F = 1 reflector keeps all the light in single scattering; a rougher one
    /// // loses more to multiple scattering.
    /// assert!((t.conductor_albedo(0.5, 0.0) - 1.0).abs() < 1e-3);
    /// assert!(t.conductor_albedo(0.5, 1.0) < t.conductor_albedo(0.5, 0.3));
    /// ```
    pub fn shipped() -> Self {
        let mut values = SHIPPED.chunks_exact(8).map(|b| f64::from_le_bytes(b.try_into().unwrap_or([0; 8])));
        let mut take = |n: usize| -> Vec<f64> { values.by_ref().take(n).collect() };
        let conductor = take(CONDUCTOR_NODES * CONDUCTOR_NODES);
        let dielectric = 2 * ETA_NODES * DIELECTRIC_NODES * DIELECTRIC_NODES;
        let reflected = take(dielectric);
        let transmitted = take(dielectric);
        Self::from_tables(conductor, reflected, transmitted)
    }

    /// The shipped file's bytes for these tables (see [`Self::shipped`]).
    pub fn to_bytes(&self) -> Vec<u8> {
        [&self.conductor, &self.reflected, &self.transmitted]
            .into_iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect()
    }

    /// The tables with their averages over μ.
    fn from_tables(conductor: Vec<f64>, reflected: Vec<f64>, transmitted: Vec<f64>) -> Self {
        let conductor_average = conductor.chunks(CONDUCTOR_NODES).map(average).collect();
        let reflected_average = reflected.chunks(DIELECTRIC_NODES).map(average).collect();
        let transmitted_average = transmitted.chunks(DIELECTRIC_NODES).map(average).collect();
        EnergyTables { conductor, conductor_average, reflected, transmitted, reflected_average, transmitted_average }
    }

    /// E(μ, α) of an F = 1 conductor.
    pub fn conductor_albedo(&self, mu: f64, alpha: f64) -> f64 {
        bilinear(&self.conductor, CONDUCTOR_NODES, mu, alpha)
    }

    /// E_avg(α) of an F = 1 conductor.
    pub fn conductor_average(&self, alpha: f64) -> f64 {
        linear(&self.conductor_average, alpha)
    }

    /// Interpolates a `[side][η][α][per]` table (`per` values per α row) between the two
    /// η nodes around `eta`.
    fn dielectric_lookup(&self, table: &[f64], per: usize, eta: f64, f: impl Fn(&[f64]) -> f64) -> f64 {
        let (side, x) = side_and_x(eta);
        let (k, t) = position(x, ETA_NODES);
        let block = |k: usize| {
            let start = (side * ETA_NODES + k) * DIELECTRIC_NODES * per;
            f(&table[start..start + DIELECTRIC_NODES * per])
        };
        block(k) * (1.0 - t) + block(k + 1) * t
    }

    /// (E_R, E_T)(μ, α) of a dielectric interface of relative index `eta` (either side).
    pub fn dielectric_albedo(&self, mu: f64, alpha: f64, eta: f64) -> [f64; 2] {
        let n = DIELECTRIC_NODES;
        [
            self.dielectric_lookup(&self.reflected, n, eta, |b| bilinear(b, n, mu, alpha)),
            self.dielectric_lookup(&self.transmitted, n, eta, |b| bilinear(b, n, mu, alpha)),
        ]
    }

    /// (averages of E_R, E_T)(α) for relative index `eta`.
    pub fn dielectric_average(&self, alpha: f64, eta: f64) -> [f64; 2] {
        [
            self.dielectric_lookup(&self.reflected_average, 1, eta, |b| linear(b, alpha)),
            self.dielectric_lookup(&self.transmitted_average, 1, eta, |b| linear(b, alpha)),
        ]
    }

    /// The conductor table interpolated to one α: its μ-row, which [`row_value`] reads as
    /// [`Self::conductor_albedo`] does (bilinear interpolation is separable, so fixing α
    /// first changes only rounding). The GPU gets one such row per material: its α is a
    /// material constant, so only μ is interpolated per query.
    pub fn conductor_row(&self, alpha: f64) -> Vec<f64> {
        alpha_row(&self.conductor, CONDUCTOR_NODES, alpha)
    }

    /// The dielectric tables at one α and η: the μ-rows of E_R and E_T (see
    /// [`Self::conductor_row`]).
    pub fn dielectric_rows(&self, alpha: f64, eta: f64) -> [Vec<f64>; 2] {
        let n = DIELECTRIC_NODES;
        let (side, x) = side_and_x(eta);
        let (k, t) = position(x, ETA_NODES);
        let rows = |table: &[f64]| {
            let block = |k: usize| {
                let start = (side * ETA_NODES + k) * n * n;
                alpha_row(&table[start..start + n * n], n, alpha)
            };
            let (a, b) = (block(k), block(k + 1));
            a.iter().zip(&b).map(|(a, b)| a * (1.0 - t) + b * t).collect()
        };
        [rows(&self.reflected), rows(&self.transmitted)]
    }
}

/// The value at μ of a μ-row (nodes uniform in √μ over [0, 1]), interpolated linearly in √μ.
pub fn row_value(row: &[f64], mu: f64) -> f64 {
    let (j, t) = position(mu.max(0.0).sqrt(), row.len());
    row[j] * (1.0 - t) + row[j + 1] * t
}

/// Row α of an `[α][μ]` block of `n`×`n` nodes, interpolated linearly in √α.
fn alpha_row(block: &[f64], n: usize, alpha: f64) -> Vec<f64> {
    let (i, t) = position(alpha.max(0.0).sqrt(), n);
    (0..n).map(|j| block[i * n + j] * (1.0 - t) + block[(i + 1) * n + j] * t).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smooth_limits_and_closed_forms() {
        let t = energy_tables();
        // Node α = 0 (integrated at ALPHA_MIN) is the mirror: E = 1 except at grazing; the
        // smooth dielectric reflects F(μ) and transmits 1 − F(μ).
        assert!((t.conductor_albedo(0.5, 0.0) - 1.0).abs() < 1e-3);
        for mu in [0.2, 0.6, 1.0] {
            for eta in [1.5, 1.0 / 1.5, 2.2] {
                let [r, tr] = t.dielectric_albedo(mu, 0.0, eta);
                let f = fresnel_dielectric(mu, eta);
                // Between the η nodes the interpolation error dominates.
                let tol = if eta == 1.5 || eta == 1.0 / 1.5 { 5e-3 } else { 1e-2 };
                assert!((r - f).abs() < tol && (tr - (1.0 - f)).abs() < tol, "μ {mu} η {eta}: {r} {tr} vs {f}");
            }
        }
        // η = 1: nothing reflects.
        assert!(t.dielectric_albedo(0.7, 0.5, 1.0)[0].abs() < 1e-12);
        // Energy is never created; roughness loses some.
        assert!(t.conductor.iter().chain(&t.reflected).all(|e| (0.0..=1.0 + 1e-12).contains(e)));
        assert!(t.conductor_average(1.0) < 0.75 && t.conductor_average(1.0) > 0.4);
        let avg = t.conductor_average(0.5);
        let direct: f64 = 2.0
            * (0..400).map(|j| (j as f64 + 0.5) / 400.0).map(|mu| t.conductor_albedo(mu, 0.5) * mu).sum::<f64>()
            / 400.0;
        assert!((avg - direct).abs() < 1e-5, "{avg} vs {direct}");
    }

    /// The tables between nodes agree with fresh integrals (finer rule) within what the
    /// white furnace tolerates: the conductor's albedo, and each of the dielectric's two lobes
    /// (a swap or a leak between reflection and transmission would keep their sum). One place
    /// is exempt from the lobes' check, only their sum holding there: leaving a denser medium
    /// (η < 1) at low roughness, within 0.13 in μ above the critical angle, reflection falls
    /// from total to a few per cent faster than linear interpolation between nodes follows
    /// (α 0.05, μ 0.71, η 1/1.33: 0.355 for 0.215, measured 2026-12-07). The renderers read
    /// the lobes only summed or averaged over μ there (DESIGN.md "Rough materials").
    #[test]
    fn interpolation_error_is_small() {
        let t = energy_tables();
        for alpha in [0.05, 0.23, 0.61, 0.97] {
            for mu in [0.07, 0.33, 0.71] {
                let o = DVec3::new((1.0f64 - mu * mu).sqrt(), 0.0, mu);
                let e = conductor_albedo_integral(alpha, o, 96);
                assert!((t.conductor_albedo(mu, alpha) - e).abs() < 4e-3, "α {alpha} μ {mu}");
                for eta in [1.5, 1.0 / 1.33] {
                    // Each lobe on its own: a swap or a leak between reflection and
                    // transmission would keep their sum.
                    let fresh = dielectric_albedo_integral(alpha, eta, o, 96);
                    let table = t.dielectric_albedo(mu, alpha, eta);
                    let sum = (fresh[0] + fresh[1] - table[0] - table[1]).abs();
                    assert!(sum < 6e-3, "α {alpha} μ {mu} η {eta}: {fresh:?} vs {table:?}");
                    let critical = (1.0 - eta * eta).max(0.0).sqrt();
                    let near_edge = alpha < 0.1 && eta < 1.0 && (0.0..2.0 / 15.0).contains(&(mu - critical));
                    let lobes = (fresh[0] - table[0]).abs().max((fresh[1] - table[1]).abs());
                    assert!(near_edge || lobes < 6e-3, "α {alpha} μ {mu} η {eta}: {fresh:?} vs {table:?}");
                }
            }
        }
    }

    /// Rows fixed at a material's α (and η) read back the bilinear (trilinear) lookups.
    #[test]
    fn material_rows_equal_the_table_lookups() {
        let t = energy_tables();
        for alpha in [0.001, 0.05, 0.3, 0.77, 1.0] {
            let row = t.conductor_row(alpha);
            for eta in [1.0, 1.33, 1.5, 1.0 / 1.5, 2.4, 5.0] {
                let [r, tr] = t.dielectric_rows(alpha, eta);
                for mu in [0.0, 1e-4, 0.1, 0.37, 0.5, 0.93, 1.0] {
                    let [er, et] = t.dielectric_albedo(mu, alpha, eta);
                    assert!((row_value(&r, mu) - er).abs() < 1e-12 && (row_value(&tr, mu) - et).abs() < 1e-12);
                    assert!((row_value(&row, mu) - t.conductor_albedo(mu, alpha)).abs() < 1e-12);
                }
            }
        }
    }

    /// The shipped tables are what generation gives (within 1e-12 relative: another libm may
    /// round a sine differently in the last bit). With `LUMEN_WRITE_ENERGY_TABLES` set, the
    /// test rewrites the shipped file instead.
    #[test]
    fn shipped_energy_tables_are_the_generated_ones() {
        let fresh = EnergyTables::generate();
        assert_eq!(fresh, EnergyTables::generate(), "generation is deterministic");
        if std::env::var_os("LUMEN_WRITE_ENERGY_TABLES").is_some() {
            let path = concat!(env!("CARGO_MANIFEST_DIR"), "/src/optics/energy_tables.bin");
            std::fs::write(path, fresh.to_bytes()).unwrap();
            return;
        }
        let shipped = energy_tables();
        assert_eq!(fresh.to_bytes().len(), SHIPPED.len());
        let fields = |t: &EnergyTables| {
            [
                t.conductor.clone(),
                t.conductor_average.clone(),
                t.reflected.clone(),
                t.transmitted.clone(),
                t.reflected_average.clone(),
                t.transmitted_average.clone(),
            ]
        };
        for (k, (a, b)) in fields(&fresh).iter().zip(fields(shipped)).enumerate() {
            assert_eq!(a.len(), b.len());
            for (i, (x, y)) in a.iter().zip(&b).enumerate() {
                assert!(
                    (x - y).abs() <= 1e-12 * x.abs().max(1e-3),
                    "table {k} entry {i}: generated {x:e}, shipped {y:e}: regenerate energy_tables.bin (module doc)"
                );
            }
        }
    }
}
