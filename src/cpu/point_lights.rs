//! Direct light from point lights, shared by the PointLight renderer and the path tracer.

use glam::DVec3;

use crate::scene::PointLight;

use super::context::{Context, Counters};
use super::Hit;

/// For a point light visible from the hit: the unit direction toward it and the factor
/// `cos θ · f(d)` (θ between the normal and that direction, f the light's falloff).
/// `None` when the light is behind the surface or occluded.
pub fn point_light_factor(
    ctx: &Context,
    hit: &Hit,
    light: &PointLight,
    counters: &mut Counters,
) -> Option<(DVec3, f64)> {
    let to_light = light.position - hit.point;
    let dist = to_light.length();
    if dist <= 0.0 {
        return None;
    }
    let dir = to_light / dist;
    let cos = hit.normal.dot(dir);
    if cos <= 0.0 || hit.geometric.dot(dir) <= 0.0 {
        return None;
    }
    if !ctx.segment_clear(hit.point, hit.scale, hit.geometric, light.position, None, counters) {
        return None;
    }
    Some((dir, cos * light.falloff(dist)))
}
