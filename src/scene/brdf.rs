//! Surface scattering models (the description; sampling lives with each renderer).

use super::Pigment;
use crate::color::Color;

/// How a surface scatters light. Each variant carries the pigment that tints it.
#[derive(Debug, Clone, PartialEq)]
pub enum Brdf {
    /// Lambertian: f = pigment / π, sampled by the cosine.
    Diffuse {
        /// The albedo ρ: the fraction of light reflected, per channel.
        pigment: Pigment,
    },
    /// Perfect mirror tinted by the pigment. `threshold_angle_rad` is kept from
    /// Raytracer.jl for DUMP and round-trips; like Raytracer.jl's own sampler, lumen reflects
    /// exactly.
    Specular {
        /// Tints the reflected light (per-channel reflectance).
        pigment: Pigment,
        /// SceneLang's `.threshold_angle_rad`, in radians (default
        /// [`DEFAULT_THRESHOLD_ANGLE_RAD`]); no renderer reads it.
        threshold_angle_rad: f64,
    },
    /// Dielectric interface (ext): exact Fresnel reflection and refraction with total
    /// internal reflection; `ior` is the inside index relative to the outside. Roughness 0
    /// is smooth glass; above, GGX reflection and transmission (Walter et al. 2007), with
    /// energy compensation unless `multiple_scattering` is false.
    Dielectric {
        /// Tints both the reflected and the transmitted light.
        pigment: Pigment,
        /// Index of refraction of the inside relative to the outside (the side the outward
        /// normal points to); SceneLang requires it finite and > 0.
        ior: f64,
        /// GGX α in [0, 1] (SceneLang checks the range); 0 is a smooth (delta) interface.
        roughness: f64,
        /// Kulla–Conty energy compensation of the rough lobes; no effect at roughness 0.
        multiple_scattering: bool,
    },
    /// GGX metal (ext): `roughness` is α (0: a perfect mirror); `fresnel` the complex index
    /// (η, k) per channel, or `None` for F = 1. Multiple scattering is compensated unless
    /// `multiple_scattering` is false (single scattering only, as most renderers do: for
    /// comparisons with them).
    Conductor {
        /// Tints the reflectance, on top of the Fresnel term.
        pigment: Pigment,
        /// GGX α in [0, 1] (SceneLang checks the range); 0 is a perfect (delta) mirror.
        roughness: f64,
        /// The metal's complex index (η, k), one value per RGB channel (from SceneLang's
        /// `.eta`/`.k` or `.metal`); `None` makes the Fresnel term 1.
        fresnel: Option<(Color, Color)>,
        /// Kulla–Conty energy compensation of the rough lobe; no effect at roughness 0.
        multiple_scattering: bool,
    },
    /// A diffuse base (the pigment) under a GGX dielectric coat of index `ior` (ext).
    Plastic {
        /// The diffuse base's albedo, clamped to [0, 1] per channel when shading.
        pigment: Pigment,
        /// Index of refraction of the coat relative to the outside; SceneLang requires it
        /// finite and > 0.
        ior: f64,
        /// GGX α of the coat in [0, 1] (SceneLang checks the range); 0 is a smooth coat.
        roughness: f64,
    },
}

impl Default for Brdf {
    fn default() -> Self {
        Brdf::Diffuse { pigment: Pigment::default() }
    }
}

/// Raytracer.jl's default mirror threshold, 0.1° in radians.
pub const DEFAULT_THRESHOLD_ANGLE_RAD: f64 = 0.0017453294;

impl Brdf {
    /// The pigment whatever the variant: what tints the scattering, and the colour the Flat
    /// renderer shows.
    pub fn pigment(&self) -> &Pigment {
        match self {
            Brdf::Diffuse { pigment }
            | Brdf::Specular { pigment, .. }
            | Brdf::Dielectric { pigment, .. }
            | Brdf::Conductor { pigment, .. }
            | Brdf::Plastic { pigment, .. } => pigment,
        }
    }
    /// True for BRDFs whose scattering is a Dirac delta (no light sampling through them).
    pub fn is_delta(&self) -> bool {
        match self {
            Brdf::Diffuse { .. } | Brdf::Plastic { .. } => false,
            Brdf::Specular { .. } => true,
            Brdf::Dielectric { roughness, .. } | Brdf::Conductor { roughness, .. } => *roughness == 0.0,
        }
    }
    /// True for BSDFs that transmit at their non-delta vertices, so that light from behind
    /// the surface reaches the viewer through it: a rough dielectric. (A point light is
    /// then summed on either side of the surface; on every other BSDF only in front.)
    ///
    /// ```
    /// use lumen::scene::{Brdf, Pigment};
    /// let rough = Brdf::Dielectric { pigment: Pigment::default(), ior: 1.5, roughness: 0.2, multiple_scattering: true };
    /// assert!(rough.transmits());
    /// assert!(!Brdf::smooth_dielectric(Pigment::default(), 1.5).transmits()); // a delta: never sampled
    /// assert!(!Brdf::default().transmits());
    /// ```
    pub fn transmits(&self) -> bool {
        matches!(self, Brdf::Dielectric { roughness, .. } if *roughness > 0.0)
    }
    /// The smooth glass of Raytracer.jl scripts' `Brdf.Dielectric` (roughness 0).
    pub fn smooth_dielectric(pigment: Pigment, ior: f64) -> Self {
        Brdf::Dielectric { pigment, ior, roughness: 0.0, multiple_scattering: true }
    }
}
