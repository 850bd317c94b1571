//! The f64 CPU reference renderer (and the fallback when no GPU exists).

pub mod csg;
mod hit;
mod offset;
mod onb;
mod ray;
pub mod shapes;
mod world;

pub use hit::Hit;
pub use offset::offset_origin;
pub use onb::onb;
pub use ray::Ray;
pub use world::World;

// Shading: BSDFs, lights, integrators and the render loop.
pub mod env_light;
pub mod fresnel;
pub mod pixel_samples;
pub mod vertex_draws;
pub mod warp;
