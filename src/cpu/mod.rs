//! The f64 CPU reference renderer (and the fallback when no GPU exists).
//!
//! Geometry: [`World`] (closest hit and occlusion over the BVH), shapes, CSG, robust
//! offsets, ONB. Shading, one concept per file, each mirrored by a WGSL file: [`warp`]
//! (square → directions), [`fresnel`], [`bsdf`], [`area_light`], [`env_light`], [`lights`]
//! (what NEE chooses from), [`point_lights`], [`vertex_draws`] (the 7 uniforms per vertex),
//! [`simple_renderers`] (OnOff, Flat,
//! PointLight), [`path_tracer`], and [`render()`] (tiles on rayon). What both renderers
//! prepare from a scene (BVH, lights, environment tables, camera samples, CSG bounds) is
//! in [`crate::prepare`]. DESIGN.md states the rules they follow.

pub mod csg;
mod hit;
pub mod mesh;
pub mod offset;
mod onb;
pub(crate) mod ray;
pub mod shapes;
mod world;

pub use hit::Hit;
pub use offset::offset_origin;
pub use onb::onb;
pub use ray::{normalize_scaled, pow2_rescale, Ray};
pub use world::World;

// Shading: BSDFs, lights, integrators and the render loop.
pub mod area_light;
pub mod bsdf;
#[cfg(test)]
mod chi_square;
pub mod context;
pub mod env_light;
pub use crate::optics::fresnel;
pub mod lights;
pub mod microfacet;
pub mod path_tracer;
pub mod point_lights;
mod render;
pub mod simple_renderers;
pub mod spherical_rectangle;
pub mod vertex_draws;
pub mod warp;

pub use render::{
    add_samples, memory_estimate, paths_per_sample, render, render_limited, render_pixel, Limits, Progress,
    RenderOptions, RenderOutput, RenderStats, CPU_RENDER_BYTES_PER_PIXEL,
};
