//! Point lights (area lights are emissive shapes; see [`super::Scene::area_lights`]).

use glam::DVec3;

use crate::color::Color;

/// An isotropic point light.
///
/// Its contribution at distance `d` is `color · f(d)` with `f(d) = (r/d)²` when
/// `linear_radius` r > 0 and `f(d) = 1` otherwise, as in Raytracer.jl. Both the PointLight
/// renderer and the path tracer use this same falloff, so they agree on direct light; a
/// light with r = 1 is a physical point light of intensity `color`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointLight {
    /// Where the light is, in world space.
    pub position: DVec3,
    /// Linear RGB strength, unbounded: the contribution before the falloff f(d).
    pub color: Color,
    /// r of the falloff, in world units (SceneLang's `.linear_radius`, ≥ 0); 0 turns the
    /// falloff off.
    pub linear_radius: f64,
}

impl Default for PointLight {
    fn default() -> Self {
        Self { position: DVec3::ZERO, color: Color::WHITE, linear_radius: 0.0 }
    }
}

impl PointLight {
    /// The falloff factor f(d) at distance `d`.
    pub fn falloff(&self, d: f64) -> f64 {
        if self.linear_radius > 0.0 {
            let q = self.linear_radius / d;
            q * q
        } else {
            1.0
        }
    }
}
