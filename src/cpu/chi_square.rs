//! χ² goodness-of-fit of a direction sampler against its density (tests only): the sphere
//! is binned in (cos θ, φ) about a normal, cells of equal solid angle; the expected count
//! of each cell integrates the density over it (a midpoint rule in both coordinates), so
//! the density function, not the sampler, is the oracle.

use std::f64::consts::PI;

use glam::DVec3;

use crate::sampling::Pcg32;

use super::microfacet::LocalSample;

/// Draws 200 000 samples (a `None` is mass the sampler absorbs, which the density must not
/// count), checks each reported pdf against `pdf`, and asserts χ² below the 1e-6 upper
/// quantile of its degrees of freedom; cells expecting fewer than 5 samples are checked to
/// be nearly empty instead.
pub fn chi_square_test(
    name: &str,
    n: DVec3,
    mut sample: impl FnMut(&mut Pcg32) -> Option<LocalSample>,
    pdf: impl Fn(DVec3) -> f64,
) {
    let (nz, nphi) = (20usize, 40usize);
    let (t, b) = super::onb(n);
    let mut counts = vec![0f64; 2 * nz * nphi];
    let mut rng = Pcg32::new(1, 2);
    let samples = 200_000;
    for _ in 0..samples {
        let Some(s) = sample(&mut rng) else { continue };
        if s.delta {
            continue;
        }
        let p = pdf(s.dir);
        assert!((s.pdf - p).abs() <= 1e-9 * p.max(1.0), "{name}: sample pdf {} vs density {p}", s.pdf);
        let z = s.dir.dot(n).clamp(-1.0, 1.0);
        let phi = s.dir.dot(b).atan2(s.dir.dot(t)).rem_euclid(2.0 * PI);
        let zi = (((z + 1.0) / 2.0 * (2 * nz) as f64) as usize).min(2 * nz - 1);
        let pi = ((phi / (2.0 * PI) * nphi as f64) as usize).min(nphi - 1);
        counts[zi * nphi + pi] += 1.0;
    }
    let (dz, dphi) = (2.0 / (2 * nz) as f64, 2.0 * PI / nphi as f64);
    let sub = 8;
    let (mut chi2, mut dof) = (0.0, 0);
    for (cell, c) in counts.iter().enumerate() {
        let (zi, pi) = (cell / nphi, cell % nphi);
        let mut p = 0.0;
        for a in 0..sub {
            let z = -1.0 + (zi as f64 + (a as f64 + 0.5) / sub as f64) * dz;
            let s = (1.0 - z * z).max(0.0).sqrt();
            for k in 0..sub {
                let phi = (pi as f64 + (k as f64 + 0.5) / sub as f64) * dphi;
                let dir = t * (s * phi.cos()) + b * (s * phi.sin()) + n * z;
                p += pdf(dir);
            }
        }
        let e = p * dz * dphi / (sub * sub) as f64 * samples as f64;
        if e < 5.0 {
            assert!(*c <= e + 20.0, "{name}: cell {cell}: {c} vs {e}");
            continue;
        }
        chi2 += (c - e) * (c - e) / e;
        dof += 1;
    }
    let limit = dof as f64 + 5.3 * (2.0 * dof as f64).sqrt() + 10.0;
    assert!(chi2 < limit, "{name}: χ² = {chi2} over {dof} cells, limit {limit}");
}
