//! The interval-list evaluation of CSG trees that lumen used before classifying
//! crossings (mod.rs): each node builds the list of intervals of the line inside its solid,
//! UNITE concatenating, FUSE merging, INTERSECT pairing and DIFF subtracting the merged
//! cut, pieces no longer than a sliver dropped. An independent construction of the same
//! semantics, kept as the test oracle for [`super::CsgTree::closest`].

use super::{CsgTree, End, Node, SLIVER};
use crate::cpu::shapes::{Crossing, Span};
use crate::cpu::Ray;
use crate::scene::CsgOp;

/// Marks an open end of an interval (±∞, no surface).
pub const NO_SURFACE: u32 = u32::MAX;

/// Whether the piece [a, b] is longer than a sliver. An infinite end (open interval) keeps
/// any piece with a < b.
fn solid(a: f64, b: f64) -> bool {
    let m = a.abs().max(b.abs());
    b - a > SLIVER * m || (a < b && m.is_infinite())
}

impl End {
    fn from_crossing(c: Crossing, leaf: u32) -> Self {
        let leaf = if c.t.is_finite() { leaf } else { NO_SURFACE };
        Self { t: c.t, leaf, face: c.face, flip: false }
    }
    fn flipped(self) -> Self {
        Self { flip: !self.flip, ..self }
    }
    fn has_surface(&self) -> bool {
        self.leaf != NO_SURFACE
    }
}

/// A piece of the line inside the solid, `enter.t ≤ exit.t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    pub enter: End,
    pub exit: End,
}

/// The intervals of the whole line of `ray` inside the tree's solid, sorted by entry.
pub fn intervals(tree: &CsgTree, ray: &Ray) -> Vec<Interval> {
    let spans: Vec<Option<Span>> = tree.leaves.iter().map(|l| l.span(ray)).collect();
    eval(&tree.root, &spans)
}

/// The smallest end with a surface inside (tmin, tmax).
pub fn closest(tree: &CsgTree, ray: &Ray) -> Option<End> {
    let mut best: Option<End> = None;
    for iv in intervals(tree, ray) {
        for e in [iv.enter, iv.exit] {
            if e.has_surface() && e.t > ray.tmin && e.t < ray.tmax && best.is_none_or(|b| e.t < b.t) {
                best = Some(e);
            }
        }
    }
    best
}

fn eval(node: &Node, spans: &[Option<Span>]) -> Vec<Interval> {
    match node {
        Node::Leaf(i) => spans[*i as usize]
            .map(|s| Interval { enter: End::from_crossing(s.enter, *i), exit: End::from_crossing(s.exit, *i) })
            .into_iter()
            .collect(),
        Node::Op(op, children) => {
            let mut lists = children.iter().map(|c| eval(c, spans));
            let Some(first) = lists.next() else { return Vec::new() };
            match op {
                CsgOp::Unite => {
                    let mut all = first;
                    lists.for_each(|l| all.extend(l));
                    sort(&mut all);
                    all
                }
                CsgOp::Fuse => {
                    let mut all = first;
                    lists.for_each(|l| all.extend(l));
                    merge(all)
                }
                CsgOp::Intersect => lists.fold(first, |a, b| intersect(&a, &b)),
                CsgOp::Diff => {
                    let cut = merge(lists.flatten().collect());
                    subtract(&first, &cut)
                }
            }
        }
    }
}

fn sort(list: &mut [Interval]) {
    list.sort_by(|a, b| a.enter.t.total_cmp(&b.enter.t));
}

/// Union into disjoint sorted intervals; touching intervals join (no surface between).
fn merge(mut list: Vec<Interval>) -> Vec<Interval> {
    sort(&mut list);
    let mut out: Vec<Interval> = Vec::with_capacity(list.len());
    for iv in list {
        match out.last_mut() {
            Some(last) if iv.enter.t <= last.exit.t => {
                if iv.exit.t > last.exit.t {
                    last.exit = iv.exit;
                }
            }
            _ => out.push(iv),
        }
    }
    out
}

/// Pairwise intersection, keeping pieces longer than a sliver.
fn intersect(a: &[Interval], b: &[Interval]) -> Vec<Interval> {
    let mut out = Vec::new();
    for x in a {
        for y in b {
            let enter = if y.enter.t > x.enter.t { y.enter } else { x.enter };
            let exit = if y.exit.t < x.exit.t { y.exit } else { x.exit };
            if solid(enter.t, exit.t) {
                out.push(Interval { enter, exit });
            }
        }
    }
    sort(&mut out);
    out
}

/// Each interval of `a` minus the disjoint sorted `cut`, keeping pieces longer than a
/// sliver; the ends contributed by `cut` are carved surfaces (flipped normals).
fn subtract(a: &[Interval], cut: &[Interval]) -> Vec<Interval> {
    let mut out = Vec::new();
    for x in a {
        let mut start = Some(x.enter);
        for y in cut {
            let Some(s) = start else { break };
            // A cut of zero length (a grazed sphere) removes nothing of positive measure.
            if y.exit.t <= s.t || y.exit.t <= y.enter.t {
                continue;
            }
            if y.enter.t >= x.exit.t {
                break;
            }
            if solid(s.t, y.enter.t) {
                out.push(Interval { enter: s, exit: y.enter.flipped() });
            }
            start = (y.exit.t < x.exit.t).then(|| y.exit.flipped());
        }
        if let Some(s) = start {
            if solid(s.t, x.exit.t) {
                out.push(Interval { enter: s, exit: x.exit });
            }
        }
    }
    sort(&mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn e(t: f64, leaf: u32) -> End {
        End { t, leaf, face: 0, flip: false }
    }
    fn iv(a: f64, b: f64, leaf: u32) -> Interval {
        Interval { enter: e(a, leaf), exit: e(b, leaf) }
    }
    fn ts(list: &[Interval]) -> Vec<(f64, f64)> {
        list.iter().map(|i| (i.enter.t, i.exit.t)).collect()
    }

    #[test]
    fn merge_joins_overlapping_and_touching() {
        let m = merge(vec![iv(5.0, 6.0, 2), iv(0.0, 2.0, 0), iv(2.0, 3.0, 1), iv(1.0, 1.5, 3)]);
        assert_eq!(ts(&m), vec![(0.0, 3.0), (5.0, 6.0)]);
        assert_eq!((m[0].enter.leaf, m[0].exit.leaf), (0, 1));
    }

    #[test]
    fn subtract_splits_trims_and_removes() {
        let a = [iv(0.0, 10.0, 0)];
        let cut = [iv(-1.0, 1.0, 1), iv(3.0, 4.0, 2), iv(6.0, 7.0, 3), iv(9.0, 12.0, 4)];
        let d = subtract(&a, &cut);
        assert_eq!(ts(&d), vec![(1.0, 3.0), (4.0, 6.0), (7.0, 9.0)]);
        assert!(d.iter().all(|i| i.enter.flip && i.exit.flip));
        assert_eq!((d[0].enter.leaf, d[0].exit.leaf), (1, 2));
        // A grazing (zero-length) cut leaves no crack.
        assert_eq!(ts(&subtract(&[iv(0.0, 2.0, 0)], &[iv(1.0, 1.0, 1)])), vec![(0.0, 2.0)]);
        // Coincident ends leave nothing of zero length.
        assert!(subtract(&[iv(0.0, 1.0, 0)], &[iv(0.0, 1.0, 1)]).is_empty());
        assert_eq!(ts(&subtract(&[iv(0.0, 2.0, 0)], &[iv(0.0, 1.0, 1)])), vec![(1.0, 2.0)]);
        // A cut that only touches keeps the original end (and its surface).
        let d = subtract(&[iv(1.0, 2.0, 0)], &[iv(0.0, 1.0, 1), iv(2.0, 3.0, 2)]);
        assert_eq!(ts(&d), vec![(1.0, 2.0)]);
        assert_eq!((d[0].enter.leaf, d[0].exit.leaf, d[0].enter.flip), (0, 0, false));
    }

    #[test]
    fn slivers_from_rounding_are_dropped() {
        // A cutter whose faces match the first operand's only up to rounding: the pieces
        // left at either end are a few ulps long and vanish; the same sizes relative to
        // larger ends too.
        for scale in [1.0, 1e-6, 1e8] {
            let (a, b) = (2.0 * scale, 4.0 * scale);
            let eps = 4.0 * f64::EPSILON * scale;
            let d = subtract(&[iv(a, b, 0)], &[iv(a + eps, 3.0 * scale, 1)]);
            assert_eq!(ts(&d), vec![(3.0 * scale, b)], "{scale}");
            assert!(subtract(&[iv(a, b, 0)], &[iv(a + eps, b - eps, 1)]).is_empty(), "{scale}");
            assert!(intersect(&[iv(a, 3.0 * scale, 0)], &[iv(3.0 * scale - eps, b, 1)]).is_empty(), "{scale}");
        }
        // A thin but real piece (1e-9 relative) stays; so do open ends.
        assert_eq!(subtract(&[iv(2.0, 4.0, 0)], &[iv(2.0 + 2e-9, 4.0, 1)]).len(), 1);
        let open = End { t: f64::NEG_INFINITY, leaf: NO_SURFACE, face: 0, flip: false };
        assert_eq!(ts(&subtract(&[Interval { enter: open, exit: e(1.0, 0) }], &[iv(0.0, 0.5, 1)])).len(), 2);
        assert!(solid(f64::NEG_INFINITY, f64::INFINITY) && !solid(1.0, 1.0) && !solid(0.0, 0.0));
    }

    #[test]
    fn intersect_pairs_and_open_ends() {
        let a = [iv(0.0, 2.0, 0), iv(3.0, 5.0, 0)];
        let b = [Interval { enter: e(1.0, 1), exit: End { t: f64::INFINITY, leaf: NO_SURFACE, face: 0, flip: false } }];
        let x = intersect(&a, &b);
        assert_eq!(ts(&x), vec![(1.0, 2.0), (3.0, 5.0)]);
        assert_eq!((x[0].enter.leaf, x[0].exit.leaf), (1, 0));
        // Touching solids have an empty (measure-zero) intersection.
        assert!(intersect(&[iv(0.0, 1.0, 0)], &[iv(1.0, 2.0, 1)]).is_empty());
    }
}
