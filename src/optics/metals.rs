//! Complex refractive indices (η, k) of common metals at the linear sRGB primaries, for
//! `Brdf.Conductor(.metal "Au")`.
//!
//! Source: the measured spectra distributed with pbrt (Palik's handbook data), reduced to
//! RGB by integration against the sRGB primaries, as tabulated by Benedikt Bitterli's
//! Tungsten renderer (`ComplexIorData.hpp`); the same reduction Mitsuba's and pbrt's RGB
//! modes use, so a lumen conductor and a Mitsuba `roughconductor` with `material="Au"`
//! describe the same metal up to RGB-vs-spectral rendering.

use crate::color::Color;

/// A named metal: its symbol, η and k per channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Metal {
    /// Chemical symbol, as SceneLang's `.metal` names it ("Au").
    pub name: &'static str,
    /// Real part of the refractive index at the red, green and blue primaries.
    pub eta: Color,
    /// Extinction coefficient (imaginary part of the index) at the same primaries.
    pub k: Color,
}

/// Gold, silver, copper and aluminium.
pub const METALS: [Metal; 4] = [
    Metal {
        name: "Au",
        eta: Color::new(0.143_118_955_7, 0.374_957_043_2, 1.442_478_557_1),
        k: Color::new(3.983_160_424_7, 2.385_720_747_8, 1.603_215_289_9),
    },
    Metal {
        name: "Ag",
        eta: Color::new(0.155_264_648_9, 0.116_723_296_5, 0.138_380_695_9),
        k: Color::new(4.828_343_322_4, 3.122_245_927_8, 2.146_950_445_5),
    },
    Metal {
        name: "Cu",
        eta: Color::new(0.200_437_697_0, 0.924_033_430_4, 1.102_211_952_7),
        k: Color::new(3.912_948_503_3, 2.452_847_701_5, 2.142_187_955_2),
    },
    Metal {
        name: "Al",
        eta: Color::new(1.657_459_959_5, 0.880_368_957_9, 0.521_228_734_6),
        k: Color::new(9.223_869_199_6, 6.269_523_247_7, 4.837_001_228_1),
    },
];

/// The metal of symbol `name` (case-sensitive, as chemists write it).
pub fn metal(name: &str) -> Option<&'static Metal> {
    METALS.iter().find(|m| m.name == name)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::fresnel::fresnel_conductor;

    /// Normal-incidence reflectance F0 = ((η − 1)² + k²)/((η + 1)² + k²) against the
    /// handbook colours: gold and copper reflect red most and blue least, silver and
    /// aluminium are nearly neutral and bright (aluminium ≥ 0.9 in every channel).
    #[test]
    fn metals_have_their_colours() {
        let f0 = |m: &Metal| {
            let c = |e: f64, k: f64| ((e - 1.0).powi(2) + k * k) / ((e + 1.0).powi(2) + k * k);
            [c(m.eta.r, m.k.r), c(m.eta.g, m.k.g), c(m.eta.b, m.k.b)]
        };
        let au = f0(metal("Au").unwrap());
        let cu = f0(metal("Cu").unwrap());
        let ag = f0(metal("Ag").unwrap());
        let al = f0(metal("Al").unwrap());
        assert!(au[0] > au[1] && au[1] > au[2] && au[0] > 0.9 && au[2] < 0.5, "{au:?}");
        assert!(cu[0] > cu[1] && cu[1] > cu[2], "{cu:?}");
        assert!(ag.iter().all(|&f| f > 0.85) && al.iter().all(|&f| f > 0.85), "{ag:?} {al:?}");
        // The exact Fresnel agrees with F0 at normal incidence.
        let m = metal("Au").unwrap();
        assert!((fresnel_conductor(1.0, m.eta.r, m.k.r) - au[0]).abs() < 1e-12);
        assert!(metal("au").is_none() && metal("Pt").is_none());
    }
}
