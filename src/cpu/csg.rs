//! Constructive solid geometry by interval logic along the ray.
//!
//! Every leaf (a unit primitive, convex) meets the ray's whole line in at most one interval
//! `[enter, exit]`; each end remembers the surface that bounds it (leaf, face, and whether
//! its normal is flipped), and open ends (a plane's half-space, a ray starting inside a
//! solid) lie at ±∞ with no surface. A node combines its children's lists:
//!
//! - **UNITE** (POV-Ray `union`) concatenates them: intervals may overlap, and every
//!   child's surface stays visible, also inside the other children;
//! - **FUSE** (POV-Ray `merge`) merges overlapping or touching intervals, keeping only the
//!   outer boundary of the union;
//! - **INTERSECT** intersects every interval of one list with every interval of the other
//!   (pairwise, so the inner surfaces of a UNITE child that lie inside the other children
//!   stay visible, as in POV-Ray);
//! - **DIFF** subtracts the merged union of the second and later children from each
//!   interval of the first; ends produced by a subtracted child get their normal flipped.
//!
//! INTERSECT and DIFF are regularised: pieces no longer than [`SLIVER`] relative to their
//! ends' magnitude are dropped, so a subtracted solid whose face coincides with a face of
//! the first child, exactly or only up to rounding, leaves no sliver behind. The
//! closest hit is the smallest end with a surface inside (tmin, tmax); its normal comes
//! from the leaf that produced it, with the leaf's material.

use crate::cpu::shapes::{Crossing, Instance, Span, SurfaceHit};
use crate::cpu::Ray;
use crate::scene::{Csg, CsgOp, MaterialId, Shape, Transform};

/// Marks an open end of an interval (±∞, no surface).
pub const NO_SURFACE: u32 = u32::MAX;

/// Pieces of INTERSECT and DIFF with `exit.t − enter.t ≤ SLIVER · max(|enter.t|, |exit.t|)`
/// are dropped. Faces that coincide only up to rounding (a cutter turned by 90°, where
/// cos 90° = 6e-17) cross the ray a few ulps apart, and the piece between them is no
/// solid but a sliver that would show as a carved surface. 2⁻⁴⁴ is 256 ulps of the larger
/// end, far above the rounding of the roots and slab crossings and far below any
/// intended thickness. shaders/csg.wgsl uses 2⁻¹⁵, 256 f32 ulps.
pub const SLIVER: f64 = 1.0 / 17_592_186_044_416.0; // 2⁻⁴⁴

/// Whether the piece [a, b] is longer than a sliver. An infinite end (open interval) keeps
/// any piece with a < b.
fn solid(a: f64, b: f64) -> bool {
    let m = a.abs().max(b.abs());
    b - a > SLIVER * m || (a < b && m.is_infinite())
}

/// One end of an interval: the ray parameter and the surface that bounds the solid there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct End {
    pub t: f64,
    /// Index of the leaf in [`CsgTree::leaves`], or [`NO_SURFACE`].
    pub leaf: u32,
    pub face: u8,
    /// The leaf's outward normal points into this solid (a carved surface).
    pub flip: bool,
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

#[derive(Debug, Clone, PartialEq)]
enum Node {
    Leaf(u32),
    Op(CsgOp, Vec<Node>),
}

/// A CSG tree prepared for ray queries: leaves flattened with their full transformations.
#[derive(Debug, Clone, PartialEq)]
pub struct CsgTree {
    leaves: Vec<Instance>,
    root: Node,
}

/// The closest surface of a CSG tree along a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CsgHit {
    pub end: End,
}

impl CsgTree {
    /// Prepares any shape (a lone primitive becomes a one-leaf tree).
    pub fn new(shape: &Shape) -> Self {
        let mut leaves = Vec::new();
        let root = build(shape, &Transform::IDENTITY, &mut leaves);
        Self { leaves, root }
    }

    /// Prepares a CSG node.
    pub fn from_csg(csg: &Csg) -> Self {
        let mut leaves = Vec::new();
        let root = build_csg(csg, &Transform::IDENTITY, &mut leaves);
        Self { leaves, root }
    }

    /// The leaves, in depth-first order (what [`End::leaf`] indexes).
    pub fn leaves(&self) -> &[Instance] {
        &self.leaves
    }

    /// The intervals of the whole line of `ray` inside the solid (t range ignored), sorted
    /// by entry. Their number never exceeds [`max_intervals`] of the shape.
    pub fn intervals(&self, ray: &Ray) -> Vec<Interval> {
        let spans: Vec<Option<Span>> = self.leaves.iter().map(|l| l.span(ray)).collect();
        eval(&self.root, &spans)
    }

    /// The closest surface with t in (tmin, tmax).
    pub fn closest(&self, ray: &Ray) -> Option<CsgHit> {
        let mut best: Option<End> = None;
        for iv in self.intervals(ray) {
            for e in [iv.enter, iv.exit] {
                if e.has_surface() && e.t > ray.tmin && e.t < ray.tmax && best.is_none_or(|b| e.t < b.t) {
                    best = Some(e);
                }
            }
        }
        best.map(|end| CsgHit { end })
    }

    /// Whether any surface lies in (tmin, tmax).
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.intervals(ray)
            .iter()
            .flat_map(|iv| [iv.enter, iv.exit])
            .any(|e| e.has_surface() && e.t > ray.tmin && e.t < ray.tmax)
    }

    /// World-space surface data and material at a hit found by [`Self::closest`].
    pub fn surface_hit(&self, ray: &Ray, hit: CsgHit) -> (SurfaceHit, MaterialId) {
        let leaf = &self.leaves[hit.end.leaf as usize];
        let s = leaf.surface_hit(ray, Crossing::new(hit.end.t, hit.end.face), hit.end.flip);
        (s, leaf.material)
    }
}

fn build(shape: &Shape, parent: &Transform, leaves: &mut Vec<Instance>) -> Node {
    match shape {
        Shape::Primitive(p) => {
            leaves.push(Instance { kind: p.kind, to_world: *parent * p.transform, material: p.material });
            Node::Leaf((leaves.len() - 1) as u32)
        }
        Shape::Csg(c) => build_csg(c, parent, leaves),
        // `Scene::validate` refuses meshes inside CSG; an empty leaf set if one got here.
        Shape::Mesh(_) => Node::Leaf(u32::MAX),
    }
}

fn build_csg(c: &Csg, parent: &Transform, leaves: &mut Vec<Instance>) -> Node {
    let t = *parent * c.transform;
    Node::Op(c.op, c.children.iter().map(|ch| build(ch, &t, leaves)).collect())
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

    /// The BVH renders a top-level UNITE as its parts (`Shape::top_level_parts`): the
    /// interval evaluation of the whole tree must give the same closest hit (t, leaf
    /// surface, flip) and occlusion as the parts queried one by one, including nested
    /// UNITEs, transformed nodes, a plane's half-space and a DIFF part.
    #[test]
    fn a_unite_hits_like_its_top_level_parts() {
        use crate::scene::{ShapeKind, Transform};
        use glam::DVec3;
        let m = MaterialId(0);
        let p = |k: ShapeKind, t: Transform| Shape::primitive(k, t, m);
        let carved = Shape::csg(
            CsgOp::Diff,
            vec![
                p(ShapeKind::Cube, Transform::IDENTITY),
                p(
                    ShapeKind::Sphere,
                    Transform::translation(DVec3::new(0.4, 0.0, 0.3)) * Transform::scaling(DVec3::splat(0.5)),
                ),
            ],
            Transform::translation(DVec3::new(0.0, 1.0, 0.0)),
        );
        let inner = Shape::csg(
            CsgOp::Unite,
            vec![p(ShapeKind::Cylinder, Transform::scaling(DVec3::new(0.3, 0.3, 2.0))), carved],
            Transform::rotation_z(30.0) * Transform::translation(DVec3::new(0.5, 0.0, 0.0)),
        );
        let unite = Shape::csg(
            CsgOp::Unite,
            vec![
                p(ShapeKind::Sphere, Transform::scaling(DVec3::splat(0.8))),
                inner,
                p(ShapeKind::Plane, Transform::translation(DVec3::new(0.0, 0.0, -1.5))),
            ],
            Transform::translation(DVec3::new(3.0, 0.0, 0.0)) * Transform::rotation_x(20.0),
        );
        let tree = CsgTree::new(&unite);
        let parts: Vec<CsgTree> = unite.clone().top_level_parts().iter().map(CsgTree::new).collect();
        assert_eq!(parts.len(), 4, "sphere, cylinder, carved cube, plane");
        // Parts list their leaves in the tree's depth-first order, so leaf k of part i is
        // leaf (offset of i) + k of the whole tree.
        let offsets: Vec<u32> = parts
            .iter()
            .scan(0u32, |n, t| {
                let o = *n;
                *n += t.leaves().len() as u32;
                Some(o)
            })
            .collect();
        let mut rng = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut hits = 0;
        for _ in 0..4000 {
            let origin = DVec3::new(-1.0 + 2.0 * next(), -3.0 + 6.0 * next(), -3.0 + 6.0 * next());
            let target = DVec3::new(2.0 + 2.0 * next(), -1.5 + 3.0 * next(), -2.0 + 4.0 * next());
            let ray = Ray::new(origin, target - origin, 1e-9, 0.5 + 2.0 * next());
            let whole = tree.closest(&ray).map(|h| (h.end.t, h.end.leaf, h.end.face, h.end.flip));
            let best = parts
                .iter()
                .zip(&offsets)
                .filter_map(|(t, &o)| t.closest(&ray).map(|h| (h.end.t, o + h.end.leaf, h.end.face, h.end.flip)))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            assert_eq!(whole, best, "{ray:?}");
            assert_eq!(tree.occluded(&ray), parts.iter().any(|t| t.occluded(&ray)), "{ray:?}");
            hits += usize::from(whole.is_some());
        }
        assert!(hits > 1000 && hits < 3900, "{hits} of 4000 rays hit: a weak test");
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
