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
