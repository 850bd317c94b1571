//! Direct light from point lights, shared by the PointLight renderer and the path tracer.

use glam::DVec3;

use crate::scene::PointLight;

use super::context::{Context, Counters};
use super::Hit;

/// For a point light visible from the hit: the unit direction toward it and the factor
/// `|cos θ| · f(d)` (θ between the normal and that direction, f the light's falloff).
/// `None` when the light is occluded, or behind the surface unless `two_sided` (a BSDF that
/// transmits, `Brdf::transmits`: then the light may be on either side, where the shading
/// and geometric normals agree).
pub fn point_light_factor(
    ctx: &Context,
    hit: &Hit,
    light: &PointLight,
    two_sided: bool,
    counters: &mut Counters,
) -> Option<(DVec3, f64)> {
    let to_light = light.position - hit.surface.point;
    let dist = to_light.length();
    if dist <= 0.0 {
        return None;
    }
    let dir = to_light / dist;
    let cos = hit.surface.normal.dot(dir);
    let in_front = cos > 0.0 && hit.surface.geometric.dot(dir) > 0.0;
    let behind = cos < 0.0 && hit.surface.geometric.dot(dir) < 0.0;
    if !(in_front || (two_sided && behind)) {
        return None;
    }
    if !ctx.segment_clear(hit.surface.point, hit.surface.scale, hit.surface.geometric, light.position, None, counters) {
        return None;
    }
    Some((dir, cos.abs() * light.falloff(dist)))
}
