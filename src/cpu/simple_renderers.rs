//! The OnOff, Flat and PointLight integrators (SCENELANG.md "Renderers").

use crate::color::Color;

use super::bsdf::eval_bsdf;
use super::context::{Context, Counters};
use super::point_lights::point_light_factor;
use super::Ray;

/// `on` where the camera ray hits anything, `off` elsewhere (the environment is ignored).
pub fn on_off_radiance(ctx: &Context, ray: &Ray, on: Color, off: Color, counters: &mut Counters) -> Color {
    if ctx.intersect(ray, counters).is_some() {
        on
    } else {
        off
    }
}

/// Emitted + pigment colour at the first hit; escaping rays see the escape radiance.
pub fn flat_radiance(ctx: &Context, ray: &Ray, counters: &mut Counters) -> Color {
    let Some(hit) = ctx.intersect(ray, counters) else {
        return ctx.scene.escape_radiance(ray.dir);
    };
    let m = ctx.scene.material(hit.material);
    m.emitted.color_at(hit.surface.uv.x, hit.surface.uv.y)
        + m.brdf.pigment().color_at(hit.surface.uv.x, hit.surface.uv.y)
}

/// Raytracer.jl's point-light shading: the ambient colour plus, for each visible light,
/// `(emitted + f) · colour · cos θ · f(d)`, f the BRDF value (0 for delta BRDFs) and θ the
/// angle between the normal and the direction to the light.
pub fn point_light_radiance(ctx: &Context, ray: &Ray, ambient: Color, counters: &mut Counters) -> Color {
    let Some(hit) = ctx.intersect(ray, counters) else {
        return ctx.scene.escape_radiance(ray.dir);
    };
    let m = ctx.scene.material(hit.material);
    let emitted = m.emitted.color_at(hit.surface.uv.x, hit.surface.uv.y);
    let color = m.brdf.pigment().color_at(hit.surface.uv.x, hit.surface.uv.y);
    let mut radiance = ambient;
    for light in &ctx.scene.point_lights {
        // Raytracer.jl's model: only lights in front of the surface.
        if let Some((dir, factor)) = point_light_factor(ctx, &hit, light, false, counters) {
            radiance += (emitted
                + eval_bsdf(&m.brdf, color, ray.dir.normalize(), hit.surface.normal, hit.surface.front_face, dir))
                * light.color
                * factor;
        }
    }
    radiance
}
