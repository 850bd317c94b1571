//! Constructive solid geometry: the closest visible surface of a tree along a ray.
//!
//! Every leaf (a unit primitive, convex) meets the ray's whole line in at most one interval
//! `[enter, exit]`; open ends (a plane's half-space, a ray starting inside a solid) lie at
//! ±∞ and have no surface. A node's solid and its visible surfaces follow POV-Ray:
//!
//! - **UNITE** (POV-Ray `union`): the union of the children's solids; every child's
//!   surface stays visible, also inside the other children;
//! - **FUSE** (POV-Ray `merge`): the union, showing only its outer boundary;
//! - **INTERSECT**: the intersection; a child's visible surface shows where it lies inside
//!   every other child (so the inner surfaces of a UNITE child stay visible there);
//! - **DIFF**: the first child minus the union of the others; the first child's surfaces
//!   show outside the cut, the cut's boundary shows inside the first child with its normal
//!   flipped (a carved surface).
//!
//! The evaluation classifies crossings instead of building interval lists: the leaves'
//! crossings are visited in order of t (ties by leaf, then enter before exit), and each is
//! classified by computing, at every node, whether the node's solid lies just before and
//! just after the crossing and whether the crossing is where a piece of that solid begins
//! or ends (`fold`, `finish`). The first crossing the root shows is the closest hit. Memory
//! is one span per leaf and a few words per node, whatever the tree; an interval list can
//! instead grow with the product of its UNITE operands' sizes, and its list operations are
//! the slow part of CSG on SIMD software GPUs.
//!
//! A query's first crossings are classified by one walk of the whole tree each (`walk`;
//! shaders/csg.wgsl does only this). A ray can pass up to 2n hidden crossings of a tree of
//! n leaves (a DIFF that carves away all it has), which would cost O(n²), so later ones are
//! classified by two sweeps, one per probe, that move along the ray with the crossings.
//! Nodes off the crossing's path only say whether their solids hold the probes, and those
//! answers change only where a probe passes a leaf's span end: each sweep keeps, per node,
//! how many children hold its probe, updated from a leaf up to the first ancestor whose
//! answer stays the same (`Sweep`). A classification then folds the crossing's own bits up
//! its path (`classify`), so such a ray costs O(n log n).
//!
//! "Just before" and "just after" are the probes `t ∓ SLIVER·|t|`: a piece of a solid no
//! longer than [`SLIVER`] relative to t does not count, so a subtracted solid whose face
//! coincides with a face of the first child, exactly or only up to rounding, leaves no
//! sliver behind, and solids that touch neither intersect nor show the touching faces once
//! fused. The crossing's own leaf is taken as exactly entered or left at t.

use crate::cpu::shapes::{Crossing, Instance, Span, SurfaceHit};
use crate::cpu::Ray;
use crate::scene::{Csg, CsgOp, MaterialId, Shape, Transform};

#[cfg(test)]
mod interval_oracle;

/// The probes that classify a crossing at t lie at `t ∓ SLIVER·|t|`. Faces that coincide
/// only up to rounding (a cutter turned by 90°, where cos 90° = 6e-17) cross the ray a few
/// ulps apart, and the piece between them is no solid but a sliver that would show as a
/// carved surface. 2⁻⁴⁴ is 256 ulps of t, far above the rounding of the roots and slab
/// crossings and far below any intended thickness. shaders/csg.wgsl uses 2⁻¹⁵, 256 f32 ulps.
pub const SLIVER: f64 = 1.0 / 17_592_186_044_416.0; // 2⁻⁴⁴

/// A visible surface crossing: the ray parameter and the surface there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct End {
    /// Ray parameter of the crossing.
    pub t: f64,
    /// Index of the leaf in [`CsgTree::leaves`].
    pub leaf: u32,
    /// Which face of the leaf's primitive was crossed (as in `shapes::Crossing::face`).
    pub face: u8,
    /// The leaf's outward normal points into this solid (a carved surface).
    pub flip: bool,
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
    /// The nodes depth first, the root first: what the sweeps and classifications walk.
    nodes: Vec<FlatNode>,
    /// Each leaf's index in `nodes`.
    leaf_node: Vec<u32>,
    /// The tree as built, for the interval-list oracle of the tests.
    #[cfg(test)]
    root: Node,
}

/// The parent of the root.
const NO_PARENT: u32 = u32::MAX;

/// A node as the classifications need it: a walk goes down the tree (a node's children
/// follow it, each after the subtree of the one before), a sweep up from a leaf.
#[derive(Debug, Clone, Copy, PartialEq)]
struct FlatNode {
    /// The operation, or `None` for a leaf.
    op: Option<CsgOp>,
    /// A leaf's index in [`CsgTree::leaves`] (`u32::MAX` for a node).
    leaf: u32,
    parent: u32,
    /// The node's position among its parent's children.
    pos: u32,
    children: u32,
    /// The nodes of its subtree, itself included.
    size: u32,
}

/// Appends `node`'s subtree to `nodes` depth first and records where each leaf went.
fn flatten(node: &Node, parent: u32, pos: u32, nodes: &mut Vec<FlatNode>, leaf_node: &mut [u32]) {
    let k = nodes.len();
    match node {
        Node::Leaf(i) => {
            nodes.push(FlatNode { op: None, leaf: *i, parent, pos, children: 0, size: 1 });
            if let Some(slot) = leaf_node.get_mut(*i as usize) {
                *slot = k as u32;
            }
        }
        Node::Op(op, children) => {
            let n = children.len() as u32;
            nodes.push(FlatNode { op: Some(*op), leaf: u32::MAX, parent, pos, children: n, size: 1 });
            for (j, c) in children.iter().enumerate() {
                flatten(c, k as u32, j as u32, nodes, leaf_node);
            }
            nodes[k].size = (nodes.len() - k) as u32;
        }
    }
}

/// How many of a query's crossings are classified by walking the whole tree before the
/// sweeps take over. Most rays stop at their first crossing or soon after, and a walk
/// classifies one in the tree's size, where the sweeps first sort every span end (with 8,
/// streetlamp.sl's shadow rays, which start inside the lamps, rendered about 5 % slower).
/// A ray that passes more hidden crossings costs these walks and the sweeps' O(n log n).
const WALKED_CROSSINGS: usize = 16;

/// The closest surface of a CSG tree along a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CsgHit {
    /// The crossing the tree shows; [`CsgTree::surface_hit`] turns it into a surface.
    pub end: End,
}

impl CsgTree {
    /// Prepares any shape (a lone primitive becomes a one-leaf tree).
    pub fn new(shape: &Shape) -> Self {
        let mut leaves = Vec::new();
        let root = build(shape, &Transform::IDENTITY, &mut leaves);
        Self::prepared(leaves, root)
    }

    /// Prepares a CSG node.
    pub fn from_csg(csg: &Csg) -> Self {
        let mut leaves = Vec::new();
        let root = build_csg(csg, &Transform::IDENTITY, &mut leaves);
        Self::prepared(leaves, root)
    }

    fn prepared(leaves: Vec<Instance>, root: Node) -> Self {
        let mut nodes = Vec::new();
        let mut leaf_node = vec![NO_PARENT; leaves.len()];
        flatten(&root, NO_PARENT, 0, &mut nodes, &mut leaf_node);
        Self {
            leaves,
            nodes,
            leaf_node,
            #[cfg(test)]
            root,
        }
    }

    /// The leaves, in depth-first order (what [`End::leaf`] indexes).
    pub fn leaves(&self) -> &[Instance] {
        &self.leaves
    }

    /// The closest surface with t in (tmin, tmax): the first leaf crossing in that range,
    /// in the order (t, leaf, enter before exit), that the tree shows.
    pub fn closest(&self, ray: &Ray) -> Option<CsgHit> {
        self.closest_walking(ray, WALKED_CROSSINGS)
    }

    /// [`Self::closest`], its first `walked` crossings classified by walks of the tree and
    /// the rest by the sweeps (the tests choose either throughout).
    fn closest_walking(&self, ray: &Ray, walked: usize) -> Option<CsgHit> {
        // The spans and crossings live in buffers kept per thread: a query allocating two
        // vectors made csg.sl render about 12 % slower on the CPU.
        SCRATCH.with(|scratch| {
            let Scratch { spans, crossings, ends, sweeps } = &mut *scratch.borrow_mut();
            spans.clear();
            spans.extend(self.leaves.iter().map(|l| l.span(ray)));
            crossings.clear();
            crossings.extend(
                spans
                    .iter()
                    .zip(0u32..)
                    .filter_map(|(s, leaf)| s.map(|s| [(s.enter, leaf, false), (s.exit, leaf, true)]))
                    .flatten()
                    .filter(|(c, _, _)| c.t.is_finite() && c.t > ray.tmin && c.t < ray.tmax),
            );
            if crossings.is_empty() {
                return None;
            }
            crossings.sort_by(|a, b| a.0.t.total_cmp(&b.0.t).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
            crossings.iter().enumerate().find_map(|(i, &(c, leaf, exit))| {
                let s = SLIVER * c.t.abs();
                let probe = Probe { leaf, exit, before: c.t - s, after: c.t + s };
                let b = if i < walked {
                    self.walk(0, spans, &probe)
                } else {
                    if i == walked {
                        ends.fill(spans);
                        for sweep in sweeps.iter_mut() {
                            sweep.reset(self.nodes.len());
                        }
                    }
                    // The probes only move forward (t ∓ SLIVER·|t| grows with t).
                    sweeps[0].advance(self, ends, spans, probe.before);
                    sweeps[1].advance(self, ends, spans, probe.after);
                    self.classify(sweeps, leaf, exit)
                };
                (b & (ENTERS | EXITS) != 0)
                    .then_some(CsgHit { end: End { t: c.t, leaf, face: c.face, flip: b & FLIP != 0 } })
            })
        })
    }

    /// Whether any surface lies in (tmin, tmax).
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.closest(ray).is_some()
    }

    /// What node `k` says about the crossing of `probe`, by one walk of its subtree.
    fn walk(&self, k: usize, spans: &[Option<Span>], probe: &Probe) -> u16 {
        let node = self.nodes[k];
        let Some(op) = node.op else {
            if node.leaf == probe.leaf {
                return own_bits(probe.exit);
            }
            let span = spans.get(node.leaf as usize).copied().flatten();
            return bit(inside(&span, probe.before), BEFORE) | bit(inside(&span, probe.after), AFTER);
        };
        let mut acc = 0;
        let mut child = k + 1;
        for i in 0..node.children as usize {
            acc = fold(op, acc, i, self.walk(child, spans, probe));
            child += self.nodes[child].size as usize;
        }
        finish(op, acc)
    }

    /// What the root says about the crossing of `leaf` (its exit, or its entry), the
    /// sweeps standing at its two probes: the crossing's own bits folded up its path. At
    /// each node the other children enter `fold` as one child whose solid holds a probe
    /// where any of them does (all of them, in an INTERSECT), which is what folding them
    /// one by one gives; a DIFF's first child is folded on its own, before its cutters.
    fn classify(&self, sweeps: &[Sweep; 2], leaf: u32, exit: bool) -> u16 {
        let mut k = self.leaf_node[leaf as usize] as usize;
        let mut b = own_bits(exit);
        while let Some(&node) = self.nodes.get(k) {
            let p = node.parent as usize;
            let Some(&FlatNode { op: Some(op), children, .. }) = self.nodes.get(p) else { break };
            let own_is_first = op == CsgOp::Diff && node.pos == 0;
            let (mut others, mut first) = (0, 0);
            for (sweep, probe) in sweeps.iter().zip([BEFORE, AFTER]) {
                // Children other than this one (cutters, in a DIFF) that hold the probe.
                let n = sweep.count[p] - u32::from(sweep.inside[k] && !own_is_first);
                others |= bit(if op == CsgOp::Intersect { n + 1 == children } else { n > 0 }, probe);
                first |= bit(sweep.first[p], probe);
            }
            let acc = if op == CsgOp::Diff && !own_is_first {
                fold(op, fold(op, fold(op, 0, 0, first), 1, others), 2, b)
            } else {
                fold(op, fold(op, 0, 0, b), 1, others)
            };
            b = finish(op, acc);
            k = p;
        }
        b
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

/// A query's working memory: each leaf's span, the crossings in range with their leaf and
/// side, the span ends in order and the two sweeps. `closest` never runs inside another
/// query, so one per thread serves all.
#[derive(Default)]
struct Scratch {
    spans: Vec<Option<Span>>,
    crossings: Vec<(Crossing, u32, bool)>,
    ends: SpanEnds,
    sweeps: [Sweep; 2],
}

/// Every leaf's span ends along the line, entries and exits each sorted by t: where a
/// point moving along the ray enters and leaves each leaf's solid.
#[derive(Default)]
struct SpanEnds {
    enters: Vec<(f64, u32)>,
    exits: Vec<(f64, u32)>,
}

impl SpanEnds {
    fn fill(&mut self, spans: &[Option<Span>]) {
        self.enters.clear();
        self.exits.clear();
        for (span, leaf) in spans.iter().zip(0u32..) {
            // A NaN end holds no point (as `inside` says): such a leaf never counts.
            if let Some(s) = span.filter(|s| !s.enter.t.is_nan() && !s.exit.t.is_nan()) {
                self.enters.push((s.enter.t, leaf));
                self.exits.push((s.exit.t, leaf));
            }
        }
        self.enters.sort_by(|a, b| a.0.total_cmp(&b.0));
        self.exits.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
}

/// Which nodes' solids hold a probe point that only moves forward along the ray.
#[derive(Default)]
struct Sweep {
    /// Per node: whether its solid holds the point.
    inside: Vec<bool>,
    /// Per node: how many children hold it (a DIFF's cutters only).
    count: Vec<u32>,
    /// Per node: whether a DIFF's first child holds it.
    first: Vec<bool>,
    /// The next entry and exit in [`SpanEnds`] that the point has not passed.
    next_enter: usize,
    next_exit: usize,
}

impl Sweep {
    /// The point before every span: no solid holds it.
    fn reset(&mut self, nodes: usize) {
        for v in [&mut self.inside, &mut self.first] {
            v.clear();
            v.resize(nodes, false);
        }
        self.count.clear();
        self.count.resize(nodes, 0);
        self.next_enter = 0;
        self.next_exit = 0;
    }

    /// Moves the point to `x`, past every span entry before it and every exit at or before
    /// it: only those leaves' answers (`inside`: enter < x < exit, read from the span) can
    /// have changed. (shaders/csg.wgsl's sweeps do the same.)
    fn advance(&mut self, tree: &CsgTree, ends: &SpanEnds, spans: &[Option<Span>], x: f64) {
        while let Some(&(_, leaf)) = ends.enters.get(self.next_enter).filter(|e| e.0 < x) {
            self.leaf_changed(tree, leaf, inside(&spans[leaf as usize], x));
            self.next_enter += 1;
        }
        while let Some(&(_, leaf)) = ends.exits.get(self.next_exit).filter(|e| e.0 <= x) {
            self.leaf_changed(tree, leaf, inside(&spans[leaf as usize], x));
            self.next_exit += 1;
        }
    }

    /// Sets whether `leaf` holds the point and updates its ancestors, up to the first node
    /// whose answer stays the same.
    fn leaf_changed(&mut self, tree: &CsgTree, leaf: u32, holds: bool) {
        let mut k = tree.leaf_node[leaf as usize] as usize;
        if k >= tree.nodes.len() || self.inside[k] == holds {
            return;
        }
        self.inside[k] = holds;
        while let Some(&FlatNode { op: Some(op), children, .. }) = tree.nodes.get(tree.nodes[k].parent as usize) {
            let p = tree.nodes[k].parent as usize;
            if op == CsgOp::Diff && tree.nodes[k].pos == 0 {
                self.first[p] = self.inside[k];
            } else if self.inside[k] {
                self.count[p] += 1;
            } else {
                self.count[p] -= 1;
            }
            let holds = match op {
                CsgOp::Unite | CsgOp::Fuse => self.count[p] > 0,
                CsgOp::Intersect => children > 0 && self.count[p] == children,
                CsgOp::Diff => self.first[p] && self.count[p] == 0,
            };
            if self.inside[p] == holds {
                return;
            }
            self.inside[p] = holds;
            k = p;
        }
    }
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

// What a node says about the crossing (bits of a u16; shaders/csg.wgsl uses the same).
/// Its solid holds the probe just before the crossing.
const BEFORE: u16 = 1;
/// Its solid holds the probe just after.
const AFTER: u16 = 2;
/// A piece of its solid with a visible surface begins at the crossing.
const ENTERS: u16 = 4;
/// A piece of its solid with a visible surface ends at the crossing.
const EXITS: u16 = 8;
/// The crossing's leaf is in this subtree.
const OWN: u16 = 16;
/// The crossing's surface is carved here (its normal flipped).
const FLIP: u16 = 32;
// A DIFF's accumulator only: the same for the union of its second and later children.
const CUT_BEFORE: u16 = 64;
const CUT_AFTER: u16 = 128;
const CUT_OWN: u16 = 256;
/// Both probes.
const SOLID: u16 = BEFORE | AFTER;

/// The crossing being classified: its leaf and side, and the two probe points.
struct Probe {
    leaf: u32,
    exit: bool,
    before: f64,
    after: f64,
}

/// What the crossing's own leaf says: it is entered or left exactly at t.
fn own_bits(exit: bool) -> u16 {
    OWN | if exit { BEFORE | EXITS } else { AFTER | ENTERS }
}

/// Strictly inside a leaf's span.
fn inside(span: &Option<Span>, t: f64) -> bool {
    span.is_some_and(|s| s.enter.t < t && t < s.exit.t)
}

fn bit(on: bool, bit: u16) -> u16 {
    if on {
        bit
    } else {
        0
    }
}

/// Adds child number `i`'s classification `b` to a node's accumulator (0 before the first).
fn fold(op: CsgOp, acc: u16, i: usize, b: u16) -> u16 {
    match op {
        CsgOp::Unite | CsgOp::Fuse => acc | b,
        _ if i == 0 => b,
        CsgOp::Intersect => (acc & b & SOLID) | ((acc | b) & !SOLID),
        CsgOp::Diff => {
            let cut = (b & SOLID) * CUT_BEFORE;
            if b & OWN != 0 {
                // The crossing is on the cut: carved, whatever it was below.
                acc | cut | OWN | CUT_OWN | ((b & FLIP) ^ FLIP)
            } else {
                acc | cut
            }
        }
    }
}

/// A node's classification from its accumulator.
fn finish(op: CsgOp, acc: u16) -> u16 {
    let has = |bit: u16| acc & bit != 0;
    let (before, after) = match op {
        CsgOp::Diff => (has(BEFORE) && !has(CUT_BEFORE), has(AFTER) && !has(CUT_AFTER)),
        _ => (has(BEFORE), has(AFTER)),
    };
    let (enters, exits) = match op {
        CsgOp::Unite => (has(ENTERS), has(EXITS)),
        CsgOp::Fuse => (has(OWN) && !before && after, has(OWN) && before && !after),
        CsgOp::Intersect => (has(ENTERS) && after, has(EXITS) && before),
        CsgOp::Diff if has(CUT_OWN) => {
            (has(CUT_BEFORE) && !has(CUT_AFTER) && has(AFTER), !has(CUT_BEFORE) && has(CUT_AFTER) && has(BEFORE))
        }
        CsgOp::Diff => (has(ENTERS) && !has(CUT_AFTER), has(EXITS) && !has(CUT_BEFORE)),
    };
    bit(before, BEFORE) | bit(after, AFTER) | bit(enters, ENTERS) | bit(exits, EXITS) | (acc & (OWN | FLIP))
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::scene::ShapeKind;
    use glam::DVec3;

    /// A xorshift stream of numbers in [0, 1).
    fn uniform(seed: u64) -> impl FnMut() -> f64 {
        let mut rng = seed;
        move || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    fn prim(kind: ShapeKind, t: Transform) -> Shape {
        Shape::primitive(kind, t, MaterialId(0))
    }

    /// A random tree of the four operations over randomly placed spheres, cubes,
    /// cylinders and (rarely) planes.
    fn random_tree(next: &mut impl FnMut() -> f64, depth: u32) -> Shape {
        let place = |next: &mut dyn FnMut() -> f64| {
            Transform::translation(DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5))
                * Transform::rotation_z(360.0 * next())
                * Transform::rotation_x(360.0 * next())
                * Transform::scaling(DVec3::new(0.5 + next(), 0.5 + next(), 0.5 + next()))
        };
        if depth == 0 || next() < 0.25 {
            let kind = match (4.0 * next()) as u32 {
                0 => ShapeKind::Sphere,
                1 => ShapeKind::Cube,
                2 => ShapeKind::Cylinder,
                _ if next() < 0.3 => ShapeKind::Plane,
                _ => ShapeKind::Sphere,
            };
            return prim(kind, place(next));
        }
        let op = [CsgOp::Unite, CsgOp::Intersect, CsgOp::Diff, CsgOp::Fuse][(4.0 * next()) as usize];
        let n = 2 + (2.0 * next()) as usize;
        let children = (0..n).map(|_| random_tree(next, depth - 1)).collect();
        Shape::csg(op, children, place(next))
    }

    fn hit_key(h: Option<CsgHit>) -> Option<(f64, u32, u8, bool)> {
        h.map(|h| (h.end.t, h.end.leaf, h.end.face, h.end.flip))
    }

    /// Classifying crossings gives the closest hit (t, leaf surface, face, flip) that the
    /// interval lists give, an independent construction of the same operations, on random
    /// trees up to four levels deep and random rays through them (also rays starting
    /// inside solids and ending short of them).
    #[test]
    fn closest_hits_agree_with_interval_lists() {
        let mut next = uniform(0x2545_F491_4F6C_DD1D);
        let (mut hits, mut carved, mut rays) = (0, 0, 0);
        for _ in 0..400 {
            let shape = random_tree(&mut next, 4);
            let tree = CsgTree::new(&shape);
            for _ in 0..40 {
                let origin = DVec3::new(4.0 * next() - 2.0, 4.0 * next() - 2.0, 4.0 * next() - 2.0);
                let target = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
                let ray = Ray::new(origin, target - origin, 1e-9 * next(), 0.5 + 3.0 * next());
                let want = interval_oracle::closest(&tree, &ray).map(|end| CsgHit { end });
                let got = tree.closest(&ray);
                assert_eq!(hit_key(got), hit_key(want), "{shape:?}\n{ray:?}");
                assert_eq!(tree.occluded(&ray), want.is_some());
                // Each classification alone: walks throughout, sweeps throughout.
                for walked in [usize::MAX, 0] {
                    assert_eq!(hit_key(tree.closest_walking(&ray, walked)), hit_key(want), "{walked}: {ray:?}");
                }
                rays += 1;
                hits += usize::from(got.is_some());
                carved += usize::from(got.is_some_and(|h| h.end.flip));
            }
        }
        assert!(
            hits > rays / 5 && hits < rays * 9 / 10 && carved > rays / 50,
            "{hits} hits, {carved} carved of {rays}"
        );
    }

    /// Trees built from copies of one subtree (as SceneLang's SET names share them) cross
    /// the ray at exactly the same t in many leaves. Walks and sweeps give the same hit,
    /// the lowest-numbered of the tied leaves (the order `closest` documents), at the t the
    /// interval lists give; those may end a tied interval on another of the copies.
    #[test]
    fn shared_subtrees_agree_with_interval_lists() {
        let mut next = uniform(0x9E37_79B9_7F4A_7C15);
        let ops = [CsgOp::Unite, CsgOp::Fuse, CsgOp::Intersect, CsgOp::Diff];
        let mut hits = 0;
        for _ in 0..300 {
            let mut shape = random_tree(&mut next, 2);
            for _ in 0..3 {
                let op = ops[(next() * 4.0) as usize % 4];
                let other = random_tree(&mut next, 1);
                let children = match (next() * 3.0) as u32 {
                    0 => vec![shape.clone(), shape],
                    1 => vec![shape.clone(), other, shape],
                    _ => vec![other, shape.clone(), shape],
                };
                shape = Shape::csg(op, children, Transform::IDENTITY);
            }
            let tree = CsgTree::new(&shape);
            for _ in 0..20 {
                let origin = DVec3::new(4.0 * next() - 2.0, 4.0 * next() - 2.0, 4.0 * next() - 2.0);
                let target = DVec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
                let ray = Ray::new(origin, target - origin, 1e-9 * next(), 0.5 + 3.0 * next());
                let want = interval_oracle::closest(&tree, &ray);
                let walks = hit_key(tree.closest_walking(&ray, usize::MAX));
                assert_eq!(walks.map(|h| h.0), want.map(|e| e.t), "{shape:?}\n{ray:?}");
                for walked in [WALKED_CROSSINGS, 0] {
                    assert_eq!(hit_key(tree.closest_walking(&ray, walked)), walks, "{walked}: {ray:?}");
                }
                hits += usize::from(want.is_some());
            }
        }
        assert!(hits > 300, "{hits} hits: a weak test");
    }

    /// `SET a1 DIFF(a0, a0) … SET a16 DIFF(a15, a15)`: 65,536 copies of one sphere, each
    /// DIFF carving away all of its first child, so every one of a ray's 131,072 crossings
    /// is hidden. Walking the tree for each took minutes per ray (found by tests/fuzz_cli.rs);
    /// the sweeps take milliseconds. The same chain with FUSE shows the sphere.
    #[test]
    fn a_chain_that_carves_everything_away() {
        let chain = |op| {
            let mut s = prim(ShapeKind::Sphere, Transform::IDENTITY);
            for _ in 0..16 {
                s = Shape::csg(op, vec![s.clone(), s], Transform::IDENTITY);
            }
            CsgTree::new(&s)
        };
        let (diff, fuse) = (chain(CsgOp::Diff), chain(CsgOp::Fuse));
        assert_eq!(diff.leaves().len(), 1 << 16);
        for (o, d) in [(DVec3::new(-3.0, 0.1, 0.2), DVec3::X), (DVec3::new(0.3, -0.2, 5.0), -DVec3::Z)] {
            let ray = Ray::new(o, d, 0.0, 100.0);
            assert_eq!(diff.closest(&ray), None);
            let h = fuse.closest(&ray).expect("the fused sphere").end;
            assert!((h.t - (o.length() - 1.0)).abs() < 0.1 && !h.flip, "{h:?}");
        }
    }

    /// A cutter whose faces match the first operand's only up to rounding (a box turned by
    /// 90°, cos 90° = 6e-17) leaves no sliver: where the cube lies inside it, nothing shows.
    /// Where it sticks out, the uncut part shows its own faces and the carved face.
    #[test]
    fn a_cutter_matching_faces_up_to_rounding_leaves_no_sliver() {
        let cube = prim(ShapeKind::Cube, Transform::IDENTITY);
        let cutter = prim(ShapeKind::Cube, Transform::rotation_z(90.0) * Transform::scaling(DVec3::new(1.0, 2.0, 1.0)));
        let tree = CsgTree::new(&Shape::csg(CsgOp::Diff, vec![cube, cutter.clone()], Transform::IDENTITY));
        for (o, d) in [(DVec3::new(0.2, -2.0, 0.1), DVec3::Y), (DVec3::new(-2.0, 0.1, 0.3), DVec3::X)] {
            assert_eq!(tree.closest(&Ray::new(o, d, 0.0, 10.0)), None, "{o} {d}");
        }
        // A taller first operand sticks out below and above the cutter: along +z at
        // (0.1, 0.1) its bottom (z = -1.5), the cutter's faces carved (z = ∓0.5), its top.
        let tall = prim(ShapeKind::Cube, Transform::scaling(DVec3::new(1.0, 1.0, 3.0)));
        let tree = CsgTree::new(&Shape::csg(CsgOp::Diff, vec![tall, cutter], Transform::IDENTITY));
        let mut tmin = 0.0;
        for (t, leaf, flip) in [(1.5, 0, false), (2.5, 1, true), (3.5, 1, true), (4.5, 0, false)] {
            let h = tree.closest(&Ray::new(DVec3::new(0.1, 0.1, -3.0), DVec3::Z, tmin, 10.0)).unwrap().end;
            assert!((h.t - t).abs() < 1e-12 && h.leaf == leaf && h.flip == flip, "{h:?}");
            tmin = h.t;
        }
        assert_eq!(tree.closest(&Ray::new(DVec3::new(0.1, 0.1, -3.0), DVec3::Z, tmin, 10.0)), None);
    }

    /// Boxes that touch: FUSE shows no face between them, INTERSECT is empty, UNITE shows
    /// the touching faces (both at t = 2.5: the first box's comes first, and moving tmin
    /// past it passes the other), DIFF keeps the first box whole.
    #[test]
    fn touching_solids() {
        let a = prim(ShapeKind::Cube, Transform::IDENTITY);
        let b = prim(ShapeKind::Cube, Transform::translation(DVec3::X));
        let tree = |op| CsgTree::new(&Shape::csg(op, vec![a.clone(), b.clone()], Transform::IDENTITY));
        let ts = |tree: &CsgTree| {
            // Every hit along +x through both boxes, each found by moving tmin past the last.
            let mut out = Vec::new();
            let mut tmin = 0.0;
            while let Some(h) = tree.closest(&Ray::new(DVec3::new(-2.0, 0.1, 0.2), DVec3::X, tmin, 10.0)) {
                out.push((h.end.t, h.end.leaf, h.end.flip));
                tmin = h.end.t;
            }
            out
        };
        assert_eq!(ts(&tree(CsgOp::Fuse)), vec![(1.5, 0, false), (3.5, 1, false)]);
        assert_eq!(ts(&tree(CsgOp::Intersect)), vec![]);
        assert_eq!(ts(&tree(CsgOp::Unite)), vec![(1.5, 0, false), (2.5, 0, false), (3.5, 1, false)]);
        assert_eq!(ts(&tree(CsgOp::Diff)), vec![(1.5, 0, false), (2.5, 0, false)]);
    }

    /// An INTERSECT of 24 two-sphere UNITEs has up to 2²⁴ intervals along a ray, which the
    /// interval lists would build; classifying crossings needs one span per leaf. The
    /// solid is the smallest UNITE's two spheres, and its surfaces are the ones that show.
    #[test]
    fn an_intersect_of_many_unites_is_cheap() {
        let unites = (0..24)
            .map(|k| {
                let r = 1.0 + 0.01 * f64::from(k);
                let sphere = |x: f64| {
                    prim(
                        ShapeKind::Sphere,
                        Transform::translation(DVec3::new(x, 0.0, 0.0)) * Transform::scaling(DVec3::splat(r)),
                    )
                };
                Shape::csg(CsgOp::Unite, vec![sphere(0.0), sphere(5.0)], Transform::IDENTITY)
            })
            .collect();
        let tree = CsgTree::new(&Shape::csg(CsgOp::Intersect, unites, Transform::IDENTITY));
        let h = tree.closest(&Ray::new(DVec3::new(-3.0, 0.0, 0.0), DVec3::X, 0.0, 100.0)).unwrap().end;
        assert_eq!((h.t, h.leaf), (2.0, 0));
        // Leaving the first sphere (its exit, at x = 1), then entering the second at x = 4.
        let h = tree.closest(&Ray::new(DVec3::new(-3.0, 0.0, 0.0), DVec3::X, 2.5, 100.0)).unwrap().end;
        assert_eq!((h.t, h.leaf), (4.0, 0));
        let h = tree.closest(&Ray::new(DVec3::new(-3.0, 0.0, 0.0), DVec3::X, 4.5, 100.0)).unwrap().end;
        assert_eq!((h.t, h.leaf), (7.0, 1));
    }

    /// The BVH renders a top-level UNITE as its parts (`Shape::top_level_parts`): the
    /// evaluation of the whole tree must give the same closest hit (t, leaf
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
}
