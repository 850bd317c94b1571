//! The path tracer (DESIGN.md, "Integrators"): iterative, with next-event estimation of
//! area lights and the environment combined with BSDF sampling by the power heuristic,
//! deterministic point lights, and unbiased Russian roulette.

use glam::DVec3;

use crate::color::Color;
use crate::sampling::{stream, VertexStrata};
use crate::scene::{Brdf, Material, PathTracerSettings};

use super::bsdf::{eval_bsdf, pdf_bsdf, sample_bsdf};
use super::context::{Context, Counters};
use super::lights::LightChoice;
use super::point_lights::point_light_factor;
use super::vertex_draws::VertexDraws;
use super::{offset_origin, Hit, Ray};

/// What the next vertex needs to know about the one that scattered the ray to it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Previous {
    point: DVec3,
    shape: u32,
    /// Delta scattering (or the camera): what the ray finds gets full weight.
    delta: bool,
    /// Solid-angle density of the scattered direction.
    pdf: f64,
}

const CAMERA: Previous = Previous { point: DVec3::ZERO, shape: u32::MAX, delta: true, pdf: 0.0 };

/// Radiance along one camera ray: path `sample` of pixel `pixel`, vertex streams per the
/// stream rule.
pub fn path_radiance(
    ctx: &Context,
    settings: &PathTracerSettings,
    camera_ray: Ray,
    pixel: u32,
    sample: u32,
    counters: &mut Counters,
) -> Color {
    let mut radiance = Color::BLACK;
    let mut beta = Color::WHITE;
    let mut ray = camera_ray;
    let mut prev = CAMERA;
    for bounce in 0..=settings.max_depth {
        let Some(hit) = ctx.intersect(&ray, counters) else {
            radiance += beta * escaped(ctx, settings, &prev, ray.dir.normalize());
            break;
        };
        let strata = VertexStrata::new(ctx.seed_word, pixel, sample, bounce, ctx.strata_bits);
        let xi = VertexDraws::draw(&mut stream(ctx.scene.tracer.rng, pixel, sample, bounce), &strata);
        let material = ctx.scene.material(hit.material);
        let color = material.brdf.pigment().color_at(hit.surface.uv.x, hit.surface.uv.y);
        radiance += beta * emitted(ctx, settings, &prev, &hit, material);
        if bounce == settings.max_depth {
            break;
        }
        let d = ray.dir.normalize();
        if !material.brdf.is_delta() {
            add_point_lights(ctx, &hit, &material.brdf, color, d, beta, &mut radiance, counters);
            if settings.nee {
                radiance += beta * sample_light(ctx, &hit, &material.brdf, color, d, &xi, counters);
            }
        }
        let Some(s) =
            sample_bsdf(&material.brdf, color, d, hit.surface.normal, hit.surface.front_face, xi.lobe, xi.direction)
        else {
            break;
        };
        if !hit.surface.consistent(s.dir) {
            break;
        }
        beta *= s.weight;
        if bounce >= settings.roulette_depth {
            let q = roulette_probability(color);
            if xi.roulette <= q {
                break;
            }
            beta = beta / (1.0 - q);
        }
        if beta.is_black() {
            break;
        }
        prev = Previous { point: hit.surface.point, shape: hit.shape, delta: s.delta, pdf: s.pdf };
        ray = Ray::new(
            offset_origin(hit.surface.point, hit.surface.scale, hit.surface.geometric, s.dir),
            s.dir,
            0.0,
            f64::INFINITY,
        );
    }
    radiance
}

/// Termination probability q = max(0.05, 1 − max(pigment colour)) (Raytracer.jl's rule,
/// floored so bright surfaces still terminate); survivors are divided by 1 − q.
pub fn roulette_probability(color: Color) -> f64 {
    (1.0 - color.max_component()).clamp(0.05, 1.0)
}

/// The power heuristic (β = 2) weight of a strategy with density `a` against one with `b`.
pub fn power_heuristic(a: f64, b: f64) -> f64 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 {
        a2 / (a2 + b2)
    } else {
        0.0
    }
}

/// Emitted radiance at the hit, MIS-weighted when NEE could also have sampled it: an area
/// light reached through a non-delta BSDF sample.
fn emitted(ctx: &Context, settings: &PathTracerSettings, prev: &Previous, hit: &Hit, material: &Material) -> Color {
    let le = material.emitted.color_at(hit.surface.uv.x, hit.surface.uv.y);
    if le.is_black() || !settings.nee || prev.delta {
        return le;
    }
    let Some(i) = ctx.lights.area_of_shape[hit.shape as usize] else {
        return le;
    };
    let light_pdf = ctx.lights.selection_pdf()
        * ctx.lights.area[i as usize].pdf(prev.point, prev.shape, hit.surface.point, hit.surface.geometric);
    le * power_heuristic(prev.pdf, light_pdf)
}

/// Radiance of an escaping ray, MIS-weighted like [`emitted`] when NEE samples the
/// environment.
fn escaped(ctx: &Context, settings: &PathTracerSettings, prev: &Previous, dir: DVec3) -> Color {
    let Some(env) = &ctx.lights.env else {
        return Color::BLACK;
    };
    let le = env.radiance(dir);
    if !settings.nee || prev.delta {
        return le;
    }
    le * power_heuristic(prev.pdf, ctx.lights.selection_pdf() * env.pdf(dir))
}

/// Direct light from every point light (always on: point lights cannot be hit), each one's
/// throughput-weighted contribution added on its own, as the GPU's shadow stage adds each
/// shadow ray's (`shaders/wf_shade.wgsl`, `wf_shadow.wgsl`). (The vertex's state is passed
/// apart rather than bundled, to keep that per-light order of additions visible.)
#[allow(clippy::too_many_arguments)]
fn add_point_lights(
    ctx: &Context,
    hit: &Hit,
    brdf: &Brdf,
    color: Color,
    d: DVec3,
    beta: Color,
    radiance: &mut Color,
    counters: &mut Counters,
) {
    for light in &ctx.scene.point_lights {
        if let Some((dir, factor)) = point_light_factor(ctx, hit, light, brdf.transmits(), counters) {
            *radiance += beta
                * (eval_bsdf(brdf, color, d, hit.surface.normal, hit.surface.front_face, dir) * light.color * factor);
        }
    }
}

/// A direction toward a light chosen by ξ0, with its radiance and density.
struct LightSample {
    dir: DVec3,
    /// Radiance arriving from the light along `-dir` if unoccluded.
    radiance: Color,
    /// Solid-angle density, including the probability of choosing the light.
    pdf: f64,
    /// The light point, its normal and error scale (area lights); `None` for the
    /// environment.
    end: Option<(DVec3, DVec3, f64)>,
}

/// Next-event estimation at a non-delta vertex: one light (area or environment) chosen
/// uniformly by ξ0, a point on it by ξ1 ξ2, weighted against BSDF sampling.
fn sample_light(
    ctx: &Context,
    hit: &Hit,
    brdf: &Brdf,
    color: Color,
    d: DVec3,
    xi: &VertexDraws,
    counters: &mut Counters,
) -> Color {
    let Some(ls) = choose_and_sample_light(ctx, hit, xi) else {
        return Color::BLACK;
    };
    let f = eval_bsdf(brdf, color, d, hit.surface.normal, hit.surface.front_face, ls.dir);
    if f.is_black() || ls.radiance.is_black() || !hit.surface.consistent(ls.dir) {
        return Color::BLACK;
    }
    let clear = match ls.end {
        Some((y, ny, sy)) => {
            ctx.segment_clear(hit.surface.point, hit.surface.scale, hit.surface.geometric, y, Some((ny, sy)), counters)
        }
        None => ctx.direction_clear(hit.surface.point, hit.surface.scale, hit.surface.geometric, ls.dir, counters),
    };
    if !clear {
        return Color::BLACK;
    }
    let weight = power_heuristic(ls.pdf, pdf_bsdf(brdf, d, hit.surface.normal, hit.surface.front_face, ls.dir));
    // |cos|: a rough dielectric also receives light from behind (transmission).
    f * ls.radiance * (hit.surface.normal.dot(ls.dir).abs() * weight / ls.pdf)
}

fn choose_and_sample_light(ctx: &Context, hit: &Hit, xi: &VertexDraws) -> Option<LightSample> {
    let select = ctx.lights.selection_pdf();
    let [a, b] = xi.light_point;
    match ctx.lights.choose(xi.light)? {
        LightChoice::Area(i) => {
            let light = &ctx.lights.area[i as usize];
            let lp = light.sample(hit.surface.point, hit.shape, a, b);
            let to = lp.point - hit.surface.point;
            let dist = to.length();
            if lp.pdf <= 0.0 || dist <= 0.0 {
                return None;
            }
            let radiance = light.emission(ctx.scene, &lp);
            Some(LightSample {
                dir: to / dist,
                radiance,
                pdf: select * lp.pdf,
                end: Some((lp.point, lp.normal, lp.scale)),
            })
        }
        LightChoice::Env => {
            let env = ctx.lights.env.as_ref()?;
            let s = env.sample(a, b);
            if s.pdf <= 0.0 {
                return None;
            }
            Some(LightSample { dir: s.dir, radiance: s.radiance, pdf: select * s.pdf, end: None })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_heuristic_and_roulette() {
        assert_eq!(power_heuristic(1.0, 1.0), 0.5);
        assert!((power_heuristic(3.0, 1.0) - 0.9).abs() < 1e-15);
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
        assert!((roulette_probability(Color::new(0.9, 0.2, 0.1)) - 0.1).abs() < 1e-15);
        assert_eq!(roulette_probability(Color::WHITE), 0.05);
        assert_eq!(roulette_probability(Color::BLACK), 1.0);
    }
}
