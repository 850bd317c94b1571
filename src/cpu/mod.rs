//! The f64 CPU reference renderer (and the fallback when no GPU exists).

mod hit;
mod ray;

pub use hit::Hit;
pub use ray::Ray;
