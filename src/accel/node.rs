//! The flattened BVH node shared by the CPU and the GPU.

use bytemuck::{Pod, Zeroable};
use glam::DVec3;

use crate::scene::Aabb;

/// One node, 32 bytes, uploaded to the GPU as is (WGSL: `struct { min: vec3<f32>,
/// left_or_first: u32, max: vec3<f32>, count: u32 }`).
///
/// `count == 0`: interior node; its left child is the next node in the array and
/// `left_or_first` is the index of its right child. `count > 0`: leaf holding the `count`
/// entries of [`super::Bvh::prim_indices`] starting at `left_or_first`. The f32 bounds are
/// the f64 bounds rounded outward, so they contain every primitive exactly.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct BvhNode {
    /// Minimum corner of the node's box (in the items' space), rounded down to f32.
    pub min: [f32; 3],
    /// Interior node: index of the right child. Leaf: first index into `prim_indices`.
    pub left_or_first: u32,
    /// Maximum corner of the node's box (in the items' space), rounded up to f32.
    pub max: [f32; 3],
    /// Number of primitives in a leaf; 0 marks an interior node.
    pub count: u32,
}

const _: () = assert!(std::mem::size_of::<BvhNode>() == 32);

impl BvhNode {
    /// A node of `bounds` (rounded outward to f32) and nothing else: a box for the GPU.
    pub fn from_bounds(bounds: &Aabb) -> Self {
        Self::new(bounds, 0, 0)
    }

    pub(super) fn new(bounds: &Aabb, left_or_first: u32, count: u32) -> Self {
        let lo = bounds.min.to_array().map(round_down);
        let hi = bounds.max.to_array().map(round_up);
        Self { min: lo, left_or_first, max: hi, count }
    }

    /// Whether the node is a leaf (`count > 0`).
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }

    /// The node's box in f64 (exact widening of the f32 bounds).
    pub fn bounds(&self) -> Aabb {
        Aabb::new(DVec3::from_array(self.min.map(f64::from)), DVec3::from_array(self.max.map(f64::from)))
    }
}

/// The largest f32 ≤ x.
pub(crate) fn round_down(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) > x {
        next_down(f)
    } else {
        f
    }
}

/// The smallest f32 ≥ x.
pub(crate) fn round_up(x: f64) -> f32 {
    -round_down(-x)
}

fn next_down(f: f32) -> f32 {
    if f.is_nan() || f == f32::NEG_INFINITY {
        return f;
    }
    if f == 0.0 {
        return -f32::from_bits(1);
    }
    let b = f.to_bits();
    f32::from_bits(if f > 0.0 { b - 1 } else { b + 1 })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_layout_matches_the_wgsl_struct() {
        let n = BvhNode { min: [1.0, 2.0, 3.0], left_or_first: 7, max: [4.0, 5.0, 6.0], count: 9 };
        let b = bytemuck::bytes_of(&n);
        let word = |i: usize| u32::from_le_bytes(b[4 * i..4 * i + 4].try_into().unwrap());
        assert_eq!(b.len(), 32);
        assert_eq!([word(0), word(1), word(2)], [1f32.to_bits(), 2f32.to_bits(), 3f32.to_bits()]);
        assert_eq!(word(3), 7);
        assert_eq!([word(4), word(5), word(6)], [4f32.to_bits(), 5f32.to_bits(), 6f32.to_bits()]);
        assert_eq!(word(7), 9);
    }

    #[test]
    fn rounding_is_outward() {
        for x in [0.1, -0.1, 1e-40, -1e-40, 1e5 + 1e-9, 3.0, -7.0, 1e39, -1e39, 0.0, f64::INFINITY, f64::NEG_INFINITY] {
            let (lo, hi) = (round_down(x), round_up(x));
            assert!(f64::from(lo) <= x && f64::from(hi) >= x, "{x}: {lo} {hi}");
            if x.is_finite() && x.abs() < 1e38 {
                // Tight: at most one f32 step away.
                assert!(lo == hi || next_down(hi) == lo, "{x}: {lo} {hi}");
            }
        }
        assert_eq!(round_down(3.0), 3.0);
        assert_eq!(round_up(0.0), 0.0);
    }
}
