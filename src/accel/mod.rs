//! Acceleration structure: a binned-SAH BVH over top-level shapes, flattened depth-first
//! into the 32-byte [`BvhNode`]s that the CPU reference traverses, and the GPU in their
//! [`quantized`] form (the children's boxes held by their parent, on an 8-bit grid).
//!
//! ```
//! use lumen::accel::{Bvh, BvhItem, Visit, MAX_DEPTH, MAX_LEAF_SIZE};
//! use lumen::scene::Aabb;
//! use glam::DVec3;
//!
//! let items: Vec<BvhItem> = (0..100)
//!     .map(|i| {
//!         let c = DVec3::new(i as f64 * 3.0, 0.0, 0.0);
//!         BvhItem { id: i, bounds: Aabb::new(c - 1.0, c + 1.0) }
//!     })
//!     .collect();
//! let bvh = Bvh::build(&items);
//! assert!(bvh.depth() <= MAX_DEPTH);
//! // Which leaves does a ray along +y at x = 30 reach? The one holding box 10 (a leaf
//! // may hold a few neighbours too; the caller tests the primitives themselves).
//! let mut seen = Vec::new();
//! bvh.traverse(DVec3::new(30.0, -5.0, 0.0), DVec3::Y, 0.0, f64::INFINITY, |id| {
//!     seen.push(id);
//!     Visit::Continue
//! });
//! assert!(seen.contains(&10) && seen.len() <= MAX_LEAF_SIZE);
//! ```

mod build;
mod node;
pub mod quantized;
mod traverse;
mod triangle;

pub use build::{Bvh, BvhItem, MAX_DEPTH, MAX_LEAF_SIZE};
pub use node::BvhNode;
pub use quantized::QuantizedNode;
pub use traverse::{RayBox, Visit};
pub use triangle::{intersect_triangle, ShearedRay, TriangleHit};
