//! Surface scattering models (the description; sampling lives with each renderer).

use super::Pigment;

/// How a surface scatters light. Each variant carries the pigment that tints it.
#[derive(Debug, Clone, PartialEq)]
pub enum Brdf {
    /// Lambertian: f = pigment / π, sampled by the cosine.
    Diffuse { pigment: Pigment },
    /// Perfect mirror tinted by the pigment. `threshold_angle_rad` is kept from
    /// Raytracer.jl for DUMP and round-trips; like Raytracer.jl's own sampler, lumen reflects
    /// exactly.
    Specular { pigment: Pigment, threshold_angle_rad: f64 },
    /// Smooth dielectric interface (ext): exact Fresnel reflection and refraction with
    /// total internal reflection; `ior` is the inside index relative to the outside.
    Dielectric { pigment: Pigment, ior: f64 },
}

impl Default for Brdf {
    fn default() -> Self {
        Brdf::Diffuse { pigment: Pigment::default() }
    }
}

/// Raytracer.jl's default mirror threshold, 0.1° in radians.
pub const DEFAULT_THRESHOLD_ANGLE_RAD: f64 = 0.0017453294;

impl Brdf {
    pub fn pigment(&self) -> &Pigment {
        match self {
            Brdf::Diffuse { pigment } | Brdf::Specular { pigment, .. } | Brdf::Dielectric { pigment, .. } => pigment,
        }
    }
    /// True for BRDFs whose scattering is a Dirac delta (no light sampling through them).
    pub fn is_delta(&self) -> bool {
        !matches!(self, Brdf::Diffuse { .. })
    }
}
