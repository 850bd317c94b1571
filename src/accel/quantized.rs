//! The GPU's form of a flattened BVH: inner nodes only, each holding its two children's
//! boxes on an 8-bit grid over its own box and, for a child that is a leaf, its range. A
//! descent step loads one 32-byte node for both children instead of two nodes, a leaf
//! needs no load of its own, and a pop loads nothing (the walk keeps each pushed child's
//! entry distance).
//!
//! Why: on llvmpipe every word of a node read at a lane-dependent index is a separate
//! per-lane load, and the child loads were about 40 % of the closest-hit stage
//! (BENCHMARKS.md, "compressed nodes are the next thing to try"). The grid is the one of
//! Ylitie, Karras and Laine's compressed wide BVH (2017), here for a binary tree: a corner,
//! a power-of-two step per axis, and each child bound as a byte, rounded outward.
//!
//! The boxes decoded on the GPU must contain the f32 boxes of [`BvhNode`] exactly, so the
//! builder evaluates the decoding `corner + q · step` as the GPU does: `q · step` is exact
//! (a byte times a power of two), so the sum is one correctly rounded f32 addition, fused
//! or not, which Vulkan requires; a denormal sum flushed to zero is allowed for as well.
//! The CPU reference keeps traversing the f64 [`BvhNode`]s; both find the same closest
//! hit, since either box set is conservative.
//!
//! ```
//! use lumen::accel::{quantized, quantized::Child, Bvh, BvhItem};
//! use lumen::scene::Aabb;
//! use glam::DVec3;
//!
//! let items: Vec<BvhItem> = (0..50)
//!     .map(|i| BvhItem { id: i, bounds: Aabb::new(DVec3::splat(i as f64), DVec3::splat(i as f64 + 0.5)) })
//!     .collect();
//! let bvh = Bvh::build(&items);
//! let nodes = quantized::quantize(bvh.nodes());
//! let inner = bvh.nodes().iter().filter(|n| !n.is_leaf()).count();
//! assert_eq!(nodes.len(), inner);
//! // Every primitive is in exactly one leaf, reached from the root.
//! let mut seen = vec![0; 50];
//! let mut stack = vec![0u32];
//! while let Some(i) = stack.pop() {
//!     for side in 0..2 {
//!         match nodes[i as usize].child(i, side) {
//!             Child::Inner(k) => stack.push(k),
//!             Child::Leaf { first, count } => (first..first + count).for_each(|p| seen[p as usize] += 1),
//!         }
//!     }
//! }
//! assert!(seen.iter().all(|&n| n == 1));
//! ```

use bytemuck::{Pod, Zeroable};
use rayon::prelude::*;

use super::BvhNode;

/// `QuantizedNode::scales`: the left child is a leaf.
pub const LEFT_LEAF: u32 = 1 << 24;
/// `QuantizedNode::scales`: the right child is a leaf.
pub const RIGHT_LEAF: u32 = 1 << 25;
/// `QuantizedNode::scales`: where a leaf child's primitive count sits (3 bits each; a leaf
/// holds at most [`super::MAX_LEAF_SIZE`]).
pub const LEFT_COUNT_SHIFT: u32 = 26;
/// `QuantizedNode::scales`: where the right leaf child's primitive count sits (3 bits).
pub const RIGHT_COUNT_SHIFT: u32 = 29;
/// Mask of a 3-bit primitive count once shifted down, in `scales` and in leaf references.
pub const COUNT_MASK: u32 = 7;
/// A walk's reference to a leaf, as the GPU's walk carries it on its stack: this bit, the
/// count at [`REF_COUNT_SHIFT`] and the first primitive below [`MAX_LEAF_FIRST`]. A node
/// reference is the node's index (`gpu::layout::mesh_bits::NODE_MASK` keeps those below
/// this bit).
pub const LEAF_REF: u32 = 1 << 31;
/// Where a leaf reference's primitive count sits (bits 28–30); the first primitive takes
/// the bits below.
pub const REF_COUNT_SHIFT: u32 = 28;
/// Leaves' first primitives stay below this (pack refuses more objects or triangles).
pub const MAX_LEAF_FIRST: u32 = 1 << REF_COUNT_SHIFT;
/// Bits of one grid coordinate (and of one biased exponent in `scales`).
pub const GRID_BITS: u32 = 8;
const GRID_MAX: u32 = (1 << GRID_BITS) - 1;
/// The smallest grid step's exponent: 2⁻¹²⁶, the least normal f32 (so the step is one
/// exact bit pattern, never a denormal a GPU would flush).
const MIN_EXPONENT: i32 = -126;

const _: () = assert!(super::MAX_LEAF_SIZE as u32 <= COUNT_MASK);

/// One inner node of the GPU's tree, 32 bytes (WGSL: `struct QuantizedNode { corner:
/// vec3<f32>, scales: u32, grid: vec3<u32>, link: u32 }`), nodes in depth-first order.
///
/// `corner` is the node's f32 minimum; `scales` holds the biased exponent (`e + 127`) of
/// each axis's grid step in bits 0–7 (x), 8–15 (y) and 16–23 (z), then [`LEFT_LEAF`],
/// [`RIGHT_LEAF`] and the leaves' counts; `grid[axis]` holds that axis's four coordinates:
/// bits 0–7 the left child's minimum, 8–15 its maximum, 16–23 and 24–31 the right child's.
/// A bound is `corner + q · 2^e`.
///
/// The children ([`QuantizedNode::child`]): an inner left child is the next node; an inner
/// right child is node `link`. Where one child is a leaf and the other is not, the leaf is
/// the right child and starts at primitive `link`; where both are leaves, the left starts
/// at `link` and the right follows it.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct QuantizedNode {
    /// Origin of the node's grid: the least f32 minimum of its children's boxes, lowered
    /// where needed so that it stays finite and below them when a GPU flushes denormals.
    pub corner: [f32; 3],
    /// Biased grid-step exponents per axis, the leaf flags and the leaf children's counts.
    pub scales: u32,
    /// Per axis, the four 8-bit grid coordinates of the two children's bounds.
    pub grid: [u32; 3],
    /// Index of the right inner child, or the first primitive of the leaf children.
    pub link: u32,
}

const _: () = assert!(std::mem::size_of::<QuantizedNode>() == 32);

/// A child of a [`QuantizedNode`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Child {
    /// An inner node, by index.
    Inner(u32),
    /// A leaf: primitives `first .. first + count` of the BVH's primitive order.
    Leaf {
        /// Index of the leaf's first entry in the BVH's primitive order
        /// ([`super::Bvh::prim_indices`]).
        first: u32,
        /// Number of primitives in the leaf (at most [`super::MAX_LEAF_SIZE`]).
        count: u32,
    },
}

impl QuantizedNode {
    /// Child `side` (0 left, 1 right) of this node, which is node `index`.
    pub fn child(&self, index: u32, side: usize) -> Child {
        let count = |shift: u32| (self.scales >> shift) & COUNT_MASK;
        let left_leaf = self.scales & LEFT_LEAF != 0;
        match side {
            0 if left_leaf => Child::Leaf { first: self.link, count: count(LEFT_COUNT_SHIFT) },
            0 => Child::Inner(index + 1),
            _ if self.scales & RIGHT_LEAF != 0 => Child::Leaf {
                first: self.link + if left_leaf { count(LEFT_COUNT_SHIFT) } else { 0 },
                count: count(RIGHT_COUNT_SHIFT),
            },
            _ => Child::Inner(self.link),
        }
    }

    /// This node moved into a larger table: its inner children's indices by `nodes`, its
    /// leaves' first primitives by `prims` (`link` is the one or the other, as
    /// [`QuantizedNode::child`] reads it).
    pub fn moved(self, nodes: u32, prims: u32) -> Self {
        let by = if self.scales & RIGHT_LEAF != 0 { prims } else { nodes };
        QuantizedNode { link: self.link + by, ..self }
    }

    /// The decoded box `(min, max)` of child `side` (0 left, 1 right) of an inner node, as
    /// the GPU computes it (without flushing denormals).
    pub fn child_box(&self, side: usize) -> ([f32; 3], [f32; 3]) {
        let mut lo = [0.0; 3];
        let mut hi = [0.0; 3];
        for a in 0..3 {
            let step = step_of(((self.scales >> (GRID_BITS * a as u32)) & GRID_MAX) as i32 - 127);
            let byte = |k: u32| (self.grid[a] >> (GRID_BITS * k)) & GRID_MAX;
            lo[a] = decode(self.corner[a], byte(2 * side as u32), step);
            hi[a] = decode(self.corner[a], byte(2 * side as u32 + 1), step);
        }
        (lo, hi)
    }
}

/// The GPU's decoding of grid coordinate `q`: one f32 rounding (the product is exact).
fn decode(corner: f32, q: u32, step: f32) -> f32 {
    corner + q as f32 * step
}

fn step_of(e: i32) -> f32 {
    f32::from_bits(((e + 127) as u32) << 23)
}

/// `x` as a GPU that flushes denormals may hold it.
fn flushed(x: f32) -> f32 {
    if x.is_subnormal() {
        0.0f32.copysign(x)
    } else {
        x
    }
}

/// Whether the decoding of `q` lies at or below `bound`, flushed or not.
fn at_or_below(corner: f32, q: u32, step: f32, bound: f32) -> bool {
    let v = decode(corner, q, step);
    v <= bound && flushed(v) <= bound
}

/// Whether the decoding of `q` lies at or above `bound`, flushed or not.
fn at_or_above(corner: f32, q: u32, step: f32, bound: f32) -> bool {
    let v = decode(corner, q, step);
    v >= bound && flushed(v) >= bound
}

/// The exponent of the finest grid step whose last point covers `top` from `corner`.
fn exponent(corner: f32, top: f32) -> i32 {
    let extent = f64::from(top) - f64::from(corner);
    // The step that fits in exact arithmetic, then the finest that fits in f32's.
    let guess = if extent > 0.0 { ceil_log2(extent / f64::from(GRID_MAX)) } else { MIN_EXPONENT };
    let mut e = guess.clamp(MIN_EXPONENT, 127);
    while e < 127 && !at_or_above(corner, GRID_MAX, step_of(e), top) {
        e += 1;
    }
    while e > MIN_EXPONENT && at_or_above(corner, GRID_MAX, step_of(e - 1), top) {
        e -= 1;
    }
    e
}

/// ⌈log₂ x⌉ of a positive normal f64, from its bits (no `log2` call: this runs for every
/// axis of every node).
fn ceil_log2(x: f64) -> i32 {
    let bits = x.to_bits();
    let floor = ((bits >> 52) & 0x7FF) as i32 - 1023;
    floor + i32::from(bits & ((1 << 52) - 1) != 0)
}

/// The grid coordinate nearest below (`up` false) or above `bound`, clamped to the grid:
/// the first guess, in f64 from the exact difference, is at most one off the f32 decoding.
fn guess(corner: f32, step: f32, bound: f32, up: bool) -> u32 {
    // Times 1/step, a power of two as exact as the division by step.
    let q = (f64::from(bound) - f64::from(corner)) * f64::from(step).recip();
    let q = if up { q.ceil() } else { q.floor() };
    // NaN (none arises from finite corners) and infinities clamp like any value.
    q.clamp(0.0, f64::from(GRID_MAX)) as u32
}

/// A large grid coordinate at or below `bound` (0 qualifies: the corner is the minimum): the
/// guess, lowered where the f32 decoding rounds above `bound` (tight but for such roundings).
fn grid_below(corner: f32, step: f32, bound: f32) -> u32 {
    let mut q = guess(corner, step, bound, false);
    while q > 0 && !at_or_below(corner, q, step, bound) {
        q -= 1;
    }
    q
}

/// A small grid coordinate at or above `bound` (the last one qualifies): the guess, raised
/// where the f32 decoding rounds below `bound`.
fn grid_above(corner: f32, step: f32, bound: f32) -> u32 {
    let mut q = guess(corner, step, bound, true);
    while q < GRID_MAX && !at_or_above(corner, q, step, bound) {
        q += 1;
    }
    q
}

/// The grid and flags of the node over children `l` and `r`, leaf counts included; `link`
/// as [`QuantizedNode`] says.
fn inner(l: &BvhNode, r: &BvhNode, link: u32) -> QuantizedNode {
    let mut node = QuantizedNode { corner: [0.0; 3], scales: 0, grid: [0; 3], link };
    for a in 0..3 {
        let least = l.min[a].min(r.min[a]);
        // The corner itself must lie at or below both minima when flushed: a denormal
        // minimum becomes a zero corner only where that is still below it. An infinite
        // minimum (a bound past f32's range, rounded outward) becomes f32's least finite
        // value, which every f32 point the ray reaches lies above: -∞ + q·step would be NaN.
        let corner = match flushed(least) {
            c if c == f32::NEG_INFINITY => f32::MIN,
            c if c > least => -f32::MIN_POSITIVE,
            c => c,
        };
        let top = l.max[a].max(r.max[a]);
        let e = exponent(corner, top);
        let step = step_of(e);
        let mut word = 0;
        for (k, child) in [l, r].into_iter().enumerate() {
            let q_lo = grid_below(corner, step, child.min[a]);
            let q_hi = grid_above(corner, step, child.max[a]);
            word |= (q_lo | q_hi << GRID_BITS) << (2 * GRID_BITS * k as u32);
        }
        node.corner[a] = corner;
        node.grid[a] = word;
        node.scales |= ((e + 127) as u32) << (GRID_BITS * a as u32);
    }
    if l.is_leaf() {
        node.scales |= LEFT_LEAF | l.count << LEFT_COUNT_SHIFT;
    }
    if r.is_leaf() {
        node.scales |= RIGHT_LEAF | r.count << RIGHT_COUNT_SHIFT;
    }
    node
}

/// The GPU form of a flattened tree (`nodes`, as [`super::Bvh::nodes`] lays them out): its
/// inner nodes, depth first, an inner child before a leaf sibling. A tree that is a single
/// leaf gets a root over it and an empty leaf (at the leaf's box), so every tree has a root;
/// an empty tree stays empty. The order is found in one pass, then the nodes' grids, which
/// are independent, in parallel (a tree of millions of triangles has millions of nodes).
pub fn quantize(nodes: &[BvhNode]) -> Vec<QuantizedNode> {
    match nodes {
        [] => Vec::new(),
        [leaf] => {
            let mut root = inner(leaf, &BvhNode { count: 0, ..*leaf }, leaf.left_or_first);
            root.scales |= RIGHT_LEAF;
            vec![root]
        }
        _ => {
            let mut order = Vec::with_capacity(nodes.len() / 2);
            arrange(nodes, 0, &mut order);
            order.par_iter().with_min_len(1 << 12).map(|p| inner(&nodes[p.left], &nodes[p.right], p.link)).collect()
        }
    }
}

/// Where one GPU node's children are in the flattened tree, and its `link`.
struct Placed {
    left: usize,
    right: usize,
    link: u32,
}

/// Appends inner node `i` of `nodes` and its inner descendants to `out` in the GPU's order
/// (depth ≤ `MAX_DEPTH`, so the recursion is shallow).
fn arrange(nodes: &[BvhNode], i: usize, out: &mut Vec<Placed>) {
    let n = &nodes[i];
    let (mut left, mut right) = (i + 1, n.left_or_first as usize);
    if nodes[left].is_leaf() && !nodes[right].is_leaf() {
        std::mem::swap(&mut left, &mut right);
    }
    let at = out.len();
    out.push(Placed { left, right, link: 0 });
    if !nodes[left].is_leaf() {
        arrange(nodes, left, out);
    }
    let (l, r) = (&nodes[left], &nodes[right]);
    out[at].link = if !r.is_leaf() {
        let k = out.len() as u32;
        arrange(nodes, right, out);
        k
    } else if l.is_leaf() {
        // Sibling leaves cover adjacent ranges, the left one first: the builder partitions
        // the primitives in place, depth first.
        assert_eq!(r.left_or_first, l.left_or_first + l.count, "sibling leaves' ranges must be adjacent");
        l.left_or_first
    } else {
        r.left_or_first
    };
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{Bvh, BvhItem};
    use crate::scene::Aabb;
    use glam::DVec3;

    /// Walks the original tree and the quantized one side by side: every decoded child
    /// contains its f32 box, flushed or not, and leaves hold the same ranges.
    fn check(nodes: &[BvhNode]) {
        let q = quantize(nodes);
        assert_eq!(q.len(), nodes.iter().filter(|n| !n.is_leaf()).count().max(1));
        // (original inner node, quantized node); a single-leaf tree's root stands for itself.
        let mut pairs = vec![(0usize, 0u32)];
        let mut visited = 0;
        while let Some((i, k)) = pairs.pop() {
            visited += 1;
            let n = nodes[i];
            let children: [(Option<usize>, BvhNode); 2] = if n.is_leaf() {
                [(None, n), (None, BvhNode { count: 0, ..n })]
            } else {
                let (l, r) = (i + 1, n.left_or_first as usize);
                let (l, r) = if nodes[l].is_leaf() && !nodes[r].is_leaf() { (r, l) } else { (l, r) };
                [(Some(l), nodes[l]), (Some(r), nodes[r])]
            };
            for (side, (index, c)) in children.into_iter().enumerate() {
                let (lo, hi) = q[k as usize].child_box(side);
                for a in 0..3 {
                    for (l, h) in [(lo[a], hi[a]), (flushed(lo[a]), flushed(hi[a]))] {
                        assert!(l <= c.min[a] && h >= c.max[a], "node {k} side {side} axis {a}: {l} {h} vs {c:?}");
                    }
                }
                match q[k as usize].child(k, side) {
                    Child::Leaf { first, count } if c.count == 0 => assert_eq!(count, 0, "{first}"),
                    Child::Leaf { first, count } => assert_eq!((first, count), (c.left_or_first, c.count), "node {k}"),
                    Child::Inner(j) => {
                        assert!(!c.is_leaf(), "node {k} side {side}");
                        pairs.push((index.unwrap(), j));
                    }
                }
            }
        }
        assert_eq!(visited, q.len(), "every quantized node is reached once");
    }

    fn tree(boxes: &[(DVec3, DVec3)]) -> Bvh {
        let items: Vec<BvhItem> = boxes
            .iter()
            .enumerate()
            .map(|(i, &(lo, hi))| BvhItem { id: i as u32, bounds: Aabb::new(lo, hi) })
            .collect();
        Bvh::build(&items)
    }

    /// A small deterministic generator (the test needs no statistics, only spread).
    fn lcg(state: &mut u64) -> f64 {
        *state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    #[test]
    fn decoded_children_contain_their_boxes_at_every_scale() {
        let mut s = 7u64;
        for scale in [1e-38, 1e-30, 1e-6, 1.0, 1e6, 1e30, 3e37] {
            for offset in [0.0, 1.0, -1e4, 1e7] {
                let boxes: Vec<_> = (0..300)
                    .map(|_| {
                        let c = DVec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 2.0 - 1.0;
                        let r = DVec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * 0.01;
                        (offset + (c - r) * scale, offset + (c + r) * scale)
                    })
                    .collect();
                check(tree(&boxes).nodes());
            }
        }
    }

    #[test]
    fn flat_points_denormal_and_huge_boxes_are_contained() {
        let d = f64::from(f32::from_bits(3)); // a denormal
        let cases: Vec<Vec<(DVec3, DVec3)>> = vec![
            // Flat boxes (a plane's patch) and points.
            (0..20).map(|i| (DVec3::new(i as f64, 0.0, 0.0), DVec3::new(i as f64 + 1.0, 1.0, 0.0))).collect(),
            (0..20).map(|i| (DVec3::splat(i as f64), DVec3::splat(i as f64))).collect(),
            // Around zero at denormal sizes.
            (0..20).map(|i| (DVec3::splat(-d * i as f64), DVec3::splat(d * i as f64))).collect(),
            // Near f32's largest finite values.
            (0..20)
                .map(|i| (DVec3::splat(-3.4e38 + i as f64 * 1e36), DVec3::splat(-3.3e38 + i as f64 * 1e37)))
                .collect(),
            (0..20).map(|i| (DVec3::splat(3.0e38 - i as f64 * 1e36), DVec3::splat(3.4e38))).collect(),
        ];
        for boxes in &cases {
            check(tree(boxes).nodes());
        }
    }

    #[test]
    fn the_grid_is_tight_where_nothing_forces_it_coarse() {
        // Unit boxes in a row along x: every bound is an integer, a multiple of every step
        // the nodes get (255 steps cover at most 16 units, so a step is at most 2^-3), so
        // each decoded child is its box exactly, not merely a box around it.
        let boxes: Vec<_> =
            (0..16).map(|i| (DVec3::new(i as f64, 0.0, 0.0), DVec3::new(i as f64 + 1.0, 1.0, 1.0))).collect();
        let bvh = tree(&boxes);
        let nodes = bvh.nodes();
        assert!(nodes.len() > 3);
        let q = quantize(nodes);
        // The root spans 16 units in x: 255 · 2^-4 < 16 ≤ 255 · 2^-3.
        assert_eq!(q[0].scales & 0xFF, (127 - 3) as u32);
        // Every child box, decoded, is one of the unions of adjacent unit boxes exactly.
        for node in &q {
            for side in 0..2 {
                let (lo, hi) = node.child_box(side);
                assert!(lo.iter().chain(&hi).all(|v| v.fract() == 0.0), "{lo:?} {hi:?}");
                assert_eq!([lo[1], lo[2], hi[1], hi[2]], [0.0, 0.0, 1.0, 1.0]);
            }
        }
        check(nodes);
    }

    /// A moved tree's children are the original's, shifted: inner ones by the node base,
    /// leaves by the primitive base.
    #[test]
    fn moved_nodes_keep_their_children() {
        let boxes: Vec<_> = (0..40).map(|i| (DVec3::splat(f64::from(i)), DVec3::splat(f64::from(i) + 0.5))).collect();
        let q = quantize(tree(&boxes).nodes());
        for (k, n) in q.iter().enumerate() {
            let m = n.moved(100, 1000);
            for side in 0..2 {
                let want = match n.child(k as u32, side) {
                    Child::Inner(j) => Child::Inner(j + 100),
                    Child::Leaf { first, count } => Child::Leaf { first: first + 1000, count },
                };
                assert_eq!(m.child(k as u32 + 100, side), want, "node {k} side {side}");
            }
        }
    }

    #[test]
    fn ceil_log2_agrees_with_log2() {
        for x in [1.0, 2.0, 3.0, 0.75, 0.5, 1e-47, 1.0000001, 255.0, 256.0, 257.0, 1e38, 2f64.powi(-140)] {
            assert_eq!(ceil_log2(x), x.log2().ceil() as i32, "{x}");
        }
    }

    #[test]
    fn a_single_leaf_gets_a_root() {
        let bvh = tree(&[(DVec3::ZERO, DVec3::ONE)]);
        assert_eq!(bvh.nodes().len(), 1);
        check(bvh.nodes());
        let q = quantize(bvh.nodes());
        assert_eq!(q.len(), 1);
        assert_eq!(q[0].child(0, 0), Child::Leaf { first: 0, count: 1 });
        assert_eq!(q[0].child(0, 1), Child::Leaf { first: 1, count: 0 }, "the right child holds nothing");
        let (lo, hi) = q[0].child_box(0);
        assert!(lo.iter().all(|&v| v <= 0.0) && hi.iter().all(|&v| v >= 1.0));
        assert!(quantize(&[]).is_empty());
    }

    /// A node with one leaf child and one inner child puts the inner one first (left, the
    /// next node) and the leaf's range in `link`; trees of every shape check out.
    #[test]
    fn mixed_children_put_the_inner_child_first() {
        let mut s = 3u64;
        for n in [2, 3, 5, 9, 17, 100, 1000] {
            let boxes: Vec<_> = (0..n)
                .map(|i| {
                    // Clusters of very different sizes make lopsided trees.
                    let c = DVec3::new(lcg(&mut s), lcg(&mut s), lcg(&mut s)) * if i % 7 == 0 { 100.0 } else { 1.0 };
                    (c, c + 0.01)
                })
                .collect();
            let bvh = tree(&boxes);
            check(bvh.nodes());
            for (k, node) in quantize(bvh.nodes()).iter().enumerate() {
                let leaf = |side| matches!(node.child(k as u32, side), Child::Leaf { .. });
                assert!(!leaf(0) || leaf(1), "a leaf on the left beside an inner node");
            }
        }
    }
}
