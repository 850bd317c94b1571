//! The lights next-event estimation chooses from: area lights, then the environment.

use crate::scene::Scene;

use super::area_light::AreaLight;
use super::env_light::EnvLight;

/// Every light NEE can sample, built once per render. Point lights are not here: the
/// integrators visit all of them deterministically.
#[derive(Debug, Clone)]
pub struct Lights {
    /// Area lights in [`Scene::area_lights`] order.
    pub area: Vec<AreaLight>,
    /// The environment (or background colour) as a light, last in the selection order.
    pub env: Option<EnvLight>,
    /// For each top-level shape, its index in `area`, if it is an area light.
    pub area_of_shape: Vec<Option<u32>>,
}

/// Which light ξ0 chose.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LightChoice {
    /// The area light at this index of [`Lights::area`].
    Area(u32),
    /// The environment light, [`Lights::env`].
    Env,
}

impl Lights {
    /// The scene's NEE lights: its emissive top-level spheres, cubes and meshes (leaving out
    /// meshes of zero or non-finite area) and its escape radiance, unless that is black.
    pub fn new(scene: &Scene) -> Self {
        let area: Vec<AreaLight> = scene.area_lights().iter().filter_map(|l| AreaLight::new(scene, l.shape)).collect();
        let mut area_of_shape = vec![None; scene.shapes.len()];
        for (i, l) in area.iter().enumerate() {
            area_of_shape[l.shape as usize] = Some(i as u32);
        }
        Self { area, env: EnvLight::new(scene), area_of_shape }
    }

    /// Number of lights the choice is uniform over.
    pub fn count(&self) -> usize {
        self.area.len() + usize::from(self.env.is_some())
    }

    /// Probability of choosing any one light (0 when there are none).
    pub fn selection_pdf(&self) -> f64 {
        match self.count() {
            0 => 0.0,
            n => 1.0 / n as f64,
        }
    }

    /// The light ⌊ξ0 · count⌋ (area lights first, the environment last).
    pub fn choose(&self, xi: f64) -> Option<LightChoice> {
        let n = self.count();
        if n == 0 {
            return None;
        }
        let i = ((xi * n as f64) as usize).min(n - 1);
        Some(if i < self.area.len() { LightChoice::Area(i as u32) } else { LightChoice::Env })
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::color::Color;
    use crate::scene::{Environment, Material, Pigment, SceneBuilder, Transform};

    #[test]
    fn selection_is_uniform_over_area_lights_then_environment() {
        let mut b = SceneBuilder::new(2, 2);
        let lamp = b.material(Material::new(Default::default(), Pigment::Uniform(Color::WHITE)));
        let plain = b.diffuse(Color::gray(0.5));
        b.sphere(Transform::IDENTITY, plain)
            .sphere(Transform::translation(DVec3::X), lamp)
            .cube(Transform::IDENTITY, lamp)
            .plane(Transform::IDENTITY, lamp)
            .environment(Environment::Uniform(Color::WHITE));
        let lights = Lights::new(&b.build().unwrap());
        assert_eq!(lights.count(), 3);
        assert_eq!(lights.area_of_shape, vec![None, Some(0), Some(1), None]);
        assert_eq!(lights.choose(0.0), Some(LightChoice::Area(0)));
        assert_eq!(lights.choose(0.5), Some(LightChoice::Area(1)));
        assert_eq!(lights.choose(0.99), Some(LightChoice::Env));
        assert!((lights.selection_pdf() - 1.0 / 3.0).abs() < 1e-15);
    }
}
