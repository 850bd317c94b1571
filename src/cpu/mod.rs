//! The f64 CPU reference renderer (and the fallback when no GPU exists).

mod hit;
mod ray;

pub use hit::Hit;
pub use ray::Ray;

// Shading: BSDFs, lights, integrators and the render loop.
pub mod env_light;
pub mod fresnel;
pub mod pixel_samples;
pub mod vertex_draws;
pub mod warp;
