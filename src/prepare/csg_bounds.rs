//! Bounds on CSG interval lists, computed from the tree before rendering: the GPU sizes its
//! interval arrays with them, SceneLang refuses trees whose bound is too large.

use crate::scene::{CsgOp, Shape};

/// An upper bound on the number of intervals `cpu::csg::CsgTree::intervals` (and the GPU's CSG stage) can return for this
/// shape, for any ray, which also bounds every intermediate list the evaluation builds
/// (each node's bound is at least its children's). The GPU sizes its fixed interval arrays
/// with it.
///
/// Rules, with `n` the bound and `overlap` whether the list may hold overlapping intervals
/// (only UNITE creates overlaps): a leaf is 1 (convex); UNITE and FUSE sum their children
/// (FUSE lists are disjoint); INTERSECT of lists `a`, `b` is `a + b − 1` when both are
/// disjoint (each boundary of one list starts at most one new piece), else `a·b` (pairs);
/// DIFF of `a` by children summing to `m` is `a + m` when `a` is disjoint (each cut
/// interval splits at most one piece in two), else `a·(m + 1)`.
///
/// Products grow fast (an INTERSECT of 32 two-sphere UNITEs is 2³²), so the arithmetic
/// saturates at `u64::MAX` instead of overflowing; loaders refuse shapes whose bound
/// exceeds [`crate::scene::MAX_CSG_INTERVALS`], so for a loaded scene it fits a `u32`.
pub fn max_intervals(shape: &Shape) -> u64 {
    IntervalBound::of(shape).n
}

/// The interval bound of a shape ([`max_intervals`]) with what its parent needs to combine
/// it: whether the list may hold overlapping intervals. Public so that a loader can bound a
/// tree node by node as it builds it, without walking the finished tree again.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IntervalBound {
    /// Most intervals of this node's list, or of any list built while evaluating it
    /// (saturating at `u64::MAX`).
    pub n: u64,
    /// The list may hold overlapping intervals.
    pub overlap: bool,
}

impl IntervalBound {
    /// A primitive: convex, so at most one interval.
    pub const LEAF: Self = Self { n: 1, overlap: false };

    /// The bound of a whole shape.
    pub fn of(shape: &Shape) -> Self {
        match shape {
            Shape::Primitive(_) | Shape::Mesh(_) => Self::LEAF,
            Shape::Csg(c) => {
                let children: Vec<Self> = c.children.iter().map(Self::of).collect();
                Self::combine(c.op, &children)
            }
        }
    }

    /// The bound of a CSG node from its children's, in order.
    pub fn combine(op: CsgOp, children: &[Self]) -> Self {
        let Some((&first, rest)) = children.split_first() else { return Self { n: 0, overlap: false } };
        let rest_sum = rest.iter().fold(0u64, |s, b| s.saturating_add(b.n));
        let (n, overlap) = match op {
            CsgOp::Unite => (first.n.saturating_add(rest_sum), first.overlap || !rest.is_empty()),
            CsgOp::Fuse => (first.n.saturating_add(rest_sum), false),
            CsgOp::Intersect => rest.iter().fold((first.n, first.overlap), |(n, ov), b| {
                if ov || b.overlap {
                    (n.saturating_mul(b.n).max(n).max(b.n), true)
                } else {
                    // a + b − 1, kept at u64::MAX once saturated.
                    let sum = n.saturating_add(b.n);
                    let pieces = if sum == u64::MAX { sum } else { sum.saturating_sub(1) };
                    (pieces.max(n).max(b.n), false)
                }
            }),
            CsgOp::Diff if first.overlap => (first.n.saturating_mul(rest_sum.saturating_add(1)), true),
            CsgOp::Diff => (first.n.saturating_add(rest_sum), false),
        };
        // Intermediate lists (a child's, the concatenation of DIFF's cut) must fit too.
        let widest = children.iter().map(|b| b.n).max().unwrap_or(0);
        Self { n: n.max(widest).max(rest_sum), overlap }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{MaterialId, Transform};

    fn sphere() -> Shape {
        Shape::primitive(crate::scene::ShapeKind::Sphere, Transform::IDENTITY, MaterialId(0))
    }

    /// INTERSECT of `k` two-sphere UNITEs: each UNITE may hold 2 overlapping intervals, so
    /// the bound is 2^k (the shrunk reproducer of issue 16, item 6).
    fn intersect_of_unites(k: usize) -> Shape {
        let pair = Shape::csg(CsgOp::Unite, vec![sphere(), sphere()], Transform::IDENTITY);
        Shape::csg(CsgOp::Intersect, vec![pair; k], Transform::IDENTITY)
    }

    #[test]
    fn interval_bounds_saturate_instead_of_overflowing() {
        assert_eq!(max_intervals(&intersect_of_unites(2)), 4);
        assert_eq!(max_intervals(&intersect_of_unites(32)), 1 << 32);
        assert_eq!(max_intervals(&intersect_of_unites(63)), 1 << 63);
        // 2^64 and beyond do not fit: the bound stays at the largest u64.
        assert_eq!(max_intervals(&intersect_of_unites(64)), u64::MAX);
        assert_eq!(max_intervals(&intersect_of_unites(100)), u64::MAX);
        // A DIFF of the saturated tree by anything stays saturated.
        let d = Shape::csg(CsgOp::Diff, vec![intersect_of_unites(64), sphere()], Transform::IDENTITY);
        assert_eq!(max_intervals(&d), u64::MAX);
        // Disjoint INTERSECT sums at the saturation point do not wrap either.
        let huge = IntervalBound { n: u64::MAX, overlap: false };
        assert_eq!(IntervalBound::combine(CsgOp::Intersect, &[huge, IntervalBound::LEAF]).n, u64::MAX);
        assert_eq!(IntervalBound::combine(CsgOp::Fuse, &[huge, huge]).n, u64::MAX);
        assert_eq!(IntervalBound::combine(CsgOp::Unite, &[]).n, 0);
    }

    #[test]
    fn node_by_node_bounds_match_the_whole_tree() {
        // DIFF(UNITE(s, s), s, s): a = 2 overlapping, m = 2, so 2·3 = 6.
        let u = Shape::csg(CsgOp::Unite, vec![sphere(), sphere()], Transform::IDENTITY);
        let d = Shape::csg(CsgOp::Diff, vec![u, sphere(), sphere()], Transform::IDENTITY);
        assert_eq!(max_intervals(&d), 6);
        let u = IntervalBound::combine(CsgOp::Unite, &[IntervalBound::LEAF; 2]);
        assert_eq!(u, IntervalBound { n: 2, overlap: true });
        let leaf = IntervalBound::LEAF;
        assert_eq!(IntervalBound::combine(CsgOp::Diff, &[u, leaf, leaf]), IntervalBound { n: 6, overlap: true });
        // INTERSECT of disjoint lists 3 and 2: 3 + 2 − 1 = 4.
        let f3 = IntervalBound::combine(CsgOp::Fuse, &[leaf; 3]);
        let f2 = IntervalBound::combine(CsgOp::Fuse, &[leaf; 2]);
        assert_eq!(IntervalBound::combine(CsgOp::Intersect, &[f3, f2]), IntervalBound { n: 4, overlap: false });
    }
}
