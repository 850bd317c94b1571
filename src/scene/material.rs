//! Materials: a BRDF plus emitted radiance.

use super::{Brdf, Pigment};

/// What a surface is made of. Any material may emit; an emitting top-level sphere or cube
/// becomes an area light that the path tracer samples directly.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// How the surface scatters light; its pigment is the surface's colour.
    pub brdf: Brdf,
    /// Radiance leaving the surface on its own, the same in every direction.
    pub emitted: Pigment,
}

impl Default for Material {
    /// SceneLang's `Material()`: white diffuse, no emission.
    fn default() -> Self {
        Self { brdf: Brdf::default(), emitted: Pigment::Uniform(crate::color::Color::BLACK) }
    }
}

impl Material {
    /// A material that scatters by `brdf` and emits `emitted` (a black pigment for none).
    pub fn new(brdf: Brdf, emitted: Pigment) -> Self {
        Self { brdf, emitted }
    }
    /// Whether the surface emits anywhere: its emitted pigment is not black everywhere.
    pub fn is_emissive(&self) -> bool {
        !self.emitted.is_black()
    }
}

/// Index of a material in [`super::Scene::materials`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MaterialId(pub u32);
