//! Binned SAH construction with a hard depth cap.
//!
//! How it is fast (issue 13):
//! - The items are copied once into a flat array of [`Entry`]s (bounds and id), which the
//!   nodes partition in place: no node allocates.
//! - A node reads its entries twice: one pass bins them on all three axes at once, one pass
//!   partitions them (swapping only misplaced pairs) and yields the children's centroid
//!   boxes. The children's boxes are unions of the chosen side's bins.
//! - The per-entry work is short and free of data-dependent branches: boxes are kept as
//!   (min, −max) so that a union is three packed minima, centroids are never halved (the
//!   sums min + max order the same way), bin indices come from a float-to-integer trick
//!   instead of a checked conversion, and the sweep over a node's bins skips empty ones.
//!   Nodes of two entries, the commonest, take a short cut with the same result.
//! - Subtrees of at least [`PAR_THRESHOLD`] entries are built as two `rayon::join` tasks
//!   into separate node vectors, spliced afterwards in depth-first order with their child
//!   offsets moved; nodes of at least [`PAR_BIN_THRESHOLD`] entries bin and bound in chunks
//!   of fixed size, merged in chunk order.
//!
//! Every result depends only on the items, never on the number of threads or on the
//! scheduling, so the same items always give bitwise the same BVH.

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use super::BvhNode;
use crate::scene::Aabb;

/// Deepest level a leaf may sit at (root = 0). Traversal needs a stack of at most
/// `MAX_DEPTH` entries (one deferred sibling per level; `MAX_DEPTH + 1` if the root is
/// pushed first), so the GPU's fixed-size stack cannot overflow. 32 levels hold 2³²
/// leaves, far beyond any scene, and a stack of 33 `u32` is cheap per invocation.
pub const MAX_DEPTH: usize = 32;

/// Leaves hold at most this many primitives (more are always split).
pub const MAX_LEAF_SIZE: usize = 4;

/// Centroid bins per axis for the SAH sweep.
const BINS: usize = 16;
/// Cost of visiting a node relative to intersecting one primitive.
const TRAVERSAL_COST: f64 = 1.0;
/// Nodes of at least this many primitives build their two subtrees as parallel tasks.
const PAR_THRESHOLD: usize = 4096;
/// Nodes of at least this many primitives bin (and bound) in parallel chunks of [`CHUNK`]
/// entries, merged in chunk order.
const PAR_BIN_THRESHOLD: usize = 1 << 16;
const CHUNK: usize = 1 << 14;

/// One primitive to place: an id stored in [`Bvh::prim_indices`] and its bounds (finite,
/// non-empty), in whatever space the BVH is built in: world space for the scene's, a mesh's
/// object space for its triangles'.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BvhItem {
    /// The caller's index of the primitive; traversal hands it back to the visitor.
    pub id: u32,
    /// Box of the primitive (world space for the scene's BVH, object space for a mesh's),
    /// used for binning and the node boxes.
    pub bounds: Aabb,
}

/// A flattened BVH. An empty BVH has no nodes.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Bvh {
    nodes: Vec<BvhNode>,
    prim_indices: Vec<u32>,
}

impl Bvh {
    /// Builds over `items` with binned SAH (16 bins on the longest useful axes), falling
    /// back to a median split where a centroid-less axis or the depth budget requires it.
    ///
    /// Depth guarantee: a node at depth d holding n primitives keeps ⌈log₂ n⌉ ≤ MAX_DEPTH − d.
    /// An SAH split is taken only if its larger child still satisfies this one level down;
    /// otherwise the node splits at the median count, which always does. So no leaf lies
    /// deeper than [`MAX_DEPTH`] for any input of up to 2³² primitives.
    ///
    /// Large inputs are built on the rayon pool; the result is the same bit for bit
    /// whatever the number of threads and the scheduling.
    pub fn build(items: &[BvhItem]) -> Bvh {
        Self::build_with(items, PAR_THRESHOLD)
    }

    /// [`Bvh::build`] with subtrees of at least `par_threshold` primitives built as
    /// parallel tasks (the result does not depend on it).
    fn build_with(items: &[BvhItem], par_threshold: usize) -> Bvh {
        if items.is_empty() {
            return Bvh::default();
        }
        let mut entries: Vec<Entry> = if items.len() < PAR_BIN_THRESHOLD {
            items.iter().map(Entry::new).collect()
        } else {
            items.par_iter().with_min_len(CHUNK).map(Entry::new).collect()
        };
        let boxes = Boxes::of(&entries);
        let nodes = match build_par(&mut entries, 0, 0, &boxes, par_threshold.max(2)) {
            Chunk::Nodes(mut nodes) => {
                nodes.shrink_to_fit();
                nodes
            }
            chunk => {
                let mut nodes = Vec::with_capacity(chunk.len());
                chunk.emit(&mut nodes);
                nodes
            }
        };
        let prim_indices = entries.iter().map(|e| e.id).collect();
        Bvh { nodes, prim_indices }
    }

    /// The nodes in depth-first order, root first (see [`BvhNode`] for how children and
    /// leaves are linked); empty for an empty BVH.
    pub fn nodes(&self) -> &[BvhNode] {
        &self.nodes
    }

    /// Leaf `i` covers `prim_indices[first .. first + count]`; entries are [`BvhItem::id`]s.
    pub fn prim_indices(&self) -> &[u32] {
        &self.prim_indices
    }

    /// Whether the BVH was built over no items (it then has no nodes, not even a root).
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Depth of the deepest leaf (root = 0; 0 for an empty BVH).
    pub fn depth(&self) -> usize {
        fn walk(nodes: &[BvhNode], i: usize, d: usize) -> usize {
            let n = &nodes[i];
            if n.is_leaf() {
                d
            } else {
                walk(nodes, i + 1, d + 1).max(walk(nodes, n.left_or_first as usize, d + 1))
            }
        }
        if self.nodes.is_empty() {
            0
        } else {
            walk(&self.nodes, 0, 0)
        }
    }
}

/// A box stored as (min, −max) in three lane pairs, (min.x, min.y), (−max.x, −max.y) and
/// (min.z, −max.z), so that a union is three lane-wise minima (packed `minpd`) and the
/// centroid sums of x and y one packed subtraction. The negations are exact:
/// [`Packed::min`] and [`Packed::max`] give back the box's own numbers.
#[derive(Clone, Copy)]
struct Packed([DVec2; 3]);

impl Packed {
    const EMPTY: Packed = Packed([DVec2::splat(f64::INFINITY); 3]);

    fn new(min: DVec3, max: DVec3) -> Self {
        Packed([DVec2::new(min.x, min.y), DVec2::new(-max.x, -max.y), DVec2::new(min.z, -max.z)])
    }

    #[inline(always)]
    fn min(&self) -> DVec3 {
        DVec3::new(self.0[0].x, self.0[0].y, self.0[2].x)
    }

    #[inline(always)]
    fn max(&self) -> DVec3 {
        DVec3::new(-self.0[1].x, -self.0[1].y, -self.0[2].y)
    }

    #[inline(always)]
    fn union(&mut self, o: &Packed) {
        for (a, b) in self.0.iter_mut().zip(&o.0) {
            *a = a.min(*b);
        }
    }

    /// `Aabb::area` of a non-empty box (the same arithmetic, so the same bits).
    #[inline(always)]
    fn area(&self) -> f64 {
        let e = self.max() - self.min();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    fn aabb(&self) -> Aabb {
        Aabb::new(self.min(), self.max())
    }
}

/// A primitive being placed. Its zeros are stored as +0, so that a min or max never has to
/// choose between −0 and +0.
#[derive(Clone, Copy)]
struct Entry {
    bounds: Packed,
    id: u32,
}

impl Entry {
    fn new(it: &BvhItem) -> Self {
        Entry { bounds: Packed::new(it.bounds.min + DVec3::ZERO, it.bounds.max + DVec3::ZERO), id: it.id }
    }

    /// min + max: twice the centroid, exactly, without the halving. Binning and
    /// partitioning only compare these, so they stand in for the centroids.
    #[inline(always)]
    fn sum(&self) -> DVec3 {
        let [a, b, c] = self.bounds.0;
        let xy = a - b; // min − (−max), bit for bit min + max
        DVec3::new(xy.x, xy.y, c.x - c.y)
    }
}

/// A node's box and the box of its entries' [`Entry::sum`]s (its centroid box, doubled).
#[derive(Clone, Copy)]
struct Boxes {
    bounds: Aabb,
    sums: Aabb,
}

impl Boxes {
    fn of(entries: &[Entry]) -> Boxes {
        let fold = |entries: &[Entry]| {
            let (mut bounds, mut sums) = (Packed::EMPTY, Aabb::EMPTY);
            for e in entries {
                bounds.union(&e.bounds);
                sums = sums.grow(e.sum());
            }
            (bounds, sums)
        };
        let (bounds, sums) = if entries.len() < PAR_BIN_THRESHOLD {
            fold(entries)
        } else {
            let parts: Vec<(Packed, Aabb)> = entries.par_chunks(CHUNK).map(fold).collect();
            parts.iter().fold((Packed::EMPTY, Aabb::EMPTY), |(mut b, s), (pb, ps)| {
                b.union(pb);
                (b, s.union(ps))
            })
        };
        Boxes { bounds: bounds.aabb(), sums }
    }
}

/// Maps sums (doubled centroids) to bins along the axes of a node's sum box: bin k holds
/// about the k-th sixteenth of the box's extent. With q = (s − lo) · scale in [0, 16], the
/// bin is round(q − ½) (= ⌊q⌋ but at ties), computed branch-free by the 1.5 · 2⁵² trick:
/// the float add rounds to an integer that lands in the low mantissa bits. It only has to
/// be one monotone function, the same in the binning and in the partition.
#[derive(Clone, Copy)]
struct Binning {
    lo: DVec3,
    scale: DVec3,
    /// `lo` and `scale` of x and y, for the packed computation.
    lo_xy: DVec2,
    scale_xy: DVec2,
    /// Axes whose extent is positive and finite; the others are never swept (their bins
    /// get any index in range).
    usable: [bool; 3],
}

const MAGIC: f64 = 6_755_399_441_055_744.0; // 1.5 · 2⁵²

impl Binning {
    fn new(sums: &Aabb) -> Self {
        let extent = sums.extent();
        let scale = BINS as f64 / extent;
        let usable = [0, 1, 2].map(|a| (extent[a] > 0.0) & extent[a].is_finite() & scale[a].is_finite());
        let (lo, lo_xy, scale_xy) = (sums.min, DVec2::new(sums.min.x, sums.min.y), DVec2::new(scale.x, scale.y));
        Binning { lo, scale, lo_xy, scale_xy, usable }
    }

    /// The bin of a position q (`0..BINS` for any q, NaN too). On a usable axis 0 ≤ s − lo ≤
    /// extent after rounding too, so q − ½ lies in [−½, 15.5 + ε] and rounds into 0..=16.
    #[inline(always)]
    fn index(q: f64) -> usize {
        let r = ((q - 0.5) + MAGIC).to_bits().wrapping_sub(MAGIC.to_bits()) as usize;
        (r & 31).min(BINS - 1)
    }

    /// The bin of sum `s` along `axis` (arrays, not `DVec3` indexing, which branches).
    #[inline(always)]
    fn bin(&self, s: DVec3, axis: usize) -> usize {
        Self::index((s.to_array()[axis] - self.lo.to_array()[axis]) * self.scale.to_array()[axis])
    }

    /// [`Binning::bin`] on all three axes, x and y packed (the same operations per lane).
    #[inline(always)]
    fn bins(&self, s: DVec3) -> [usize; 3] {
        let qxy = (DVec2::new(s.x, s.y) - self.lo_xy) * self.scale_xy;
        let qz = (s.z - self.lo.z) * self.scale.z;
        [Self::index(qxy.x), Self::index(qxy.y), Self::index(qz)]
    }
}

/// The box and count of the entries in one bin; one cache line, so that no lane pair
/// straddles two.
#[derive(Clone, Copy)]
#[repr(align(64))]
struct Bin {
    bounds: Packed,
    count: usize,
}

impl Bin {
    const EMPTY: Bin = Bin { bounds: Packed::EMPTY, count: 0 };

    #[inline(always)]
    fn merge(&mut self, o: &Bin) {
        self.bounds.union(&o.bounds);
        self.count += o.count;
    }
}

/// Per axis, the count and the box of the entries whose sums fall in each bin.
type Bins = [[Bin; BINS]; 3];

const EMPTY_BINS: Bins = [[Bin::EMPTY; BINS]; 3];

/// Adds `entries` to `bins`.
fn fill(bins: &mut Bins, entries: &[Entry], binning: &Binning) {
    for e in entries {
        let b = binning.bins(e.sum());
        for (axis, bins) in bins.iter_mut().enumerate() {
            let bin = &mut bins[b[axis]];
            bin.bounds.union(&e.bounds);
            bin.count += 1;
        }
    }
}

/// Bins `entries` into `bins` (all empty on entry), in parallel chunks merged in chunk
/// order if there are many.
fn bin_entries(bins: &mut Bins, entries: &[Entry], binning: &Binning) {
    if entries.len() < PAR_BIN_THRESHOLD {
        return fill(bins, entries, binning);
    }
    let parts: Vec<Bins> = entries
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut bins = EMPTY_BINS;
            fill(&mut bins, chunk, binning);
            bins
        })
        .collect();
    for part in &parts {
        for (bins, part) in bins.iter_mut().zip(part) {
            for (b, p) in bins.iter_mut().zip(part) {
                b.merge(p);
            }
        }
    }
}

/// How a node divides: the first `mid` entries go left.
struct Split {
    mid: usize,
    left: Boxes,
    right: Boxes,
}

/// A built subtree: nodes whose interior `left_or_first` count from the chunk's own first
/// node (leaves already hold global `prim_indices` offsets), or a node over two chunks.
enum Chunk {
    Nodes(Vec<BvhNode>),
    Join { node: BvhNode, len: usize, left: Box<Chunk>, right: Box<Chunk> },
}

impl Chunk {
    fn len(&self) -> usize {
        match self {
            Chunk::Nodes(v) => v.len(),
            Chunk::Join { len, .. } => *len,
        }
    }

    /// Appends the subtree depth-first (node, left subtree, right subtree), moving the
    /// right-child offsets by where each chunk lands.
    fn emit(self, out: &mut Vec<BvhNode>) {
        match self {
            Chunk::Nodes(v) => {
                let base = out.len() as u32;
                out.extend(v.into_iter().map(|n| {
                    if n.is_leaf() {
                        n
                    } else {
                        BvhNode { left_or_first: n.left_or_first + base, ..n }
                    }
                }));
            }
            Chunk::Join { node, left, right, .. } => {
                let index = out.len();
                out.push(node);
                left.emit(out);
                out[index].left_or_first = out.len() as u32;
                right.emit(out);
            }
        }
    }
}

/// Builds the subtree over `entries` (which start at `first` in the final `prim_indices`),
/// its two children as parallel tasks while it holds at least `par_threshold` entries.
fn build_par(entries: &mut [Entry], first: u32, depth: usize, boxes: &Boxes, par_threshold: usize) -> Chunk {
    let n = entries.len();
    if n < par_threshold {
        let (mut nodes, mut bins) = (Vec::with_capacity(2 * n), EMPTY_BINS);
        build_serial(&mut nodes, &mut bins, entries, first, depth, boxes);
        return Chunk::Nodes(nodes);
    }
    let node = BvhNode::new(&boxes.bounds, 0, 0);
    let mut bins = EMPTY_BINS;
    let Some(s) = split(&mut bins, entries, boxes, depth) else {
        return Chunk::Nodes(vec![BvhNode { left_or_first: first, count: n as u32, ..node }]);
    };
    let (l, r) = entries.split_at_mut(s.mid);
    let (left, right) = rayon::join(
        || build_par(l, first, depth + 1, &s.left, par_threshold),
        || build_par(r, first + s.mid as u32, depth + 1, &s.right, par_threshold),
    );
    Chunk::Join { node, len: 1 + left.len() + right.len(), left: Box::new(left), right: Box::new(right) }
}

/// Appends the subtree over `entries` to `nodes` depth-first; right-child offsets count
/// from `nodes[0]`. `bins` is scratch, all empty on entry and on return.
fn build_serial(
    nodes: &mut Vec<BvhNode>,
    bins: &mut Bins,
    entries: &mut [Entry],
    first: u32,
    depth: usize,
    boxes: &Boxes,
) {
    if entries.len() == 2 && depth < MAX_DEPTH {
        return build_pair(nodes, entries, first, boxes);
    }
    let node = BvhNode::new(&boxes.bounds, 0, 0);
    let Some(s) = split(bins, entries, boxes, depth) else {
        nodes.push(BvhNode { left_or_first: first, count: entries.len() as u32, ..node });
        return;
    };
    let index = nodes.len();
    nodes.push(node);
    let (l, r) = entries.split_at_mut(s.mid);
    build_serial(nodes, bins, l, first, depth + 1, &s.left);
    nodes[index].left_or_first = nodes.len() as u32;
    build_serial(nodes, bins, r, first + s.mid as u32, depth + 1, &s.right);
}

/// [`build_serial`] over two entries (the commonest node), short-cut: the same decisions
/// as [`choose_split`] without bins. Each usable axis that puts the two sums in different
/// bins offers one split, an entry a side, at the same cost, so the first such axis is the
/// one kept; the entry in the lower bin goes left.
fn build_pair(nodes: &mut Vec<BvhNode>, entries: &mut [Entry], first: u32, boxes: &Boxes) {
    let node = BvhNode::new(&boxes.bounds, 0, 0);
    let binning = Binning::new(&boxes.sums);
    let (s0, s1) = (entries[0].sum(), entries[1].sum());
    let axis = (0..3).find(|&a| binning.usable[a] && binning.bin(s0, a) != binning.bin(s1, a));
    let cost = entries[0].bounds.area() + entries[1].bounds.area();
    let area = boxes.bounds.area();
    let leaf = match axis {
        Some(_) if cost.is_finite() => area.is_finite() && area > 0.0 && 2.0 <= TRAVERSAL_COST + cost / area,
        _ => true, // no split, and two entries fit a leaf
    };
    if leaf {
        nodes.push(BvhNode { left_or_first: first, count: 2, ..node });
        return;
    }
    let a = axis.unwrap();
    if binning.bin(s0, a) > binning.bin(s1, a) {
        entries.swap(0, 1);
    }
    let index = nodes.len() as u32;
    nodes.push(BvhNode { left_or_first: index + 2, ..node });
    for (i, e) in entries.iter().enumerate() {
        nodes.push(BvhNode::new(&e.bounds.aabb(), first + i as u32, 1));
    }
}

/// Partitions `entries` for a node at `depth`, or returns `None` for a leaf. `bins` is
/// scratch, all empty on entry and on return.
fn split(bins: &mut Bins, entries: &mut [Entry], boxes: &Boxes, depth: usize) -> Option<Split> {
    let budget = MAX_DEPTH - depth;
    if entries.len() == 1 || budget == 0 {
        return None;
    }
    let split = choose_split(bins, entries, boxes, budget);
    *bins = EMPTY_BINS;
    split
}

fn ceil_log2(n: usize) -> usize {
    n.next_power_of_two().trailing_zeros() as usize
}

/// Partitions `entries` and returns the split, or `None` for a leaf.
fn choose_split(bins: &mut Bins, entries: &mut [Entry], boxes: &Boxes, budget: usize) -> Option<Split> {
    let n = entries.len();
    let binning = Binning::new(&boxes.sums);
    bin_entries(bins, entries, &binning);
    let best = best_split_binned(bins, &binning);
    let area = boxes.bounds.area();
    if let Some((cost, axis, left_bins)) = best {
        let split_cost = TRAVERSAL_COST + cost / area;
        if n <= MAX_LEAF_SIZE && area.is_finite() && area > 0.0 && n as f64 <= split_cost {
            return None;
        }
        // `binning.bin(s, axis) < left_bins`, with the axis fixed in each instance.
        let (lo, scale) = (binning.lo.to_array()[axis], binning.scale.to_array()[axis]);
        let left = |c: f64| Binning::index((c - lo) * scale) < left_bins;
        let (mid, left_sums, right_sums) = match axis {
            0 => partition(entries, |s| left(s.x)),
            1 => partition(entries, |s| left(s.y)),
            _ => partition(entries, |s| left(s.z)),
        };
        // Depth budget: both children must fit in one level less.
        if ceil_log2(mid.max(n - mid)) < budget {
            let side = |bins: &[Bin]| {
                let mut acc = Bin::EMPTY;
                for b in bins {
                    acc.merge(b);
                }
                acc.bounds.aabb()
            };
            let (l, r) = bins[axis].split_at(left_bins);
            return Some(Split {
                mid,
                left: Boxes { bounds: side(l), sums: left_sums },
                right: Boxes { bounds: side(r), sums: right_sums },
            });
        }
    } else if n <= MAX_LEAF_SIZE {
        // All centroids coincide: splitting cannot separate anything.
        return None;
    }
    Some(median_split(entries, &boxes.sums))
}

/// The cheapest split between bins as (SAH cost, axis, bins on the left), over filled
/// `bins`; on equal costs the first axis, then the first position, wins.
fn best_split_binned(bins: &Bins, binning: &Binning) -> Option<(f64, usize, usize)> {
    let mut best = Best::NONE;
    for (axis, bins) in bins.iter().enumerate() {
        if !binning.usable[axis] {
            continue;
        }
        // Only the non-empty bins: a split next to an empty bin costs the same as the one
        // before it, and the first of equal costs wins.
        let mut used = [0usize; BINS];
        let mut k = 0;
        for (i, b) in bins.iter().enumerate() {
            used[k] = i;
            k += usize::from(b.count > 0);
        }
        // Sweep from the right to get the area × count of every right part.
        let mut right_cost = [0.0; BINS];
        let mut acc = Bin::EMPTY;
        for j in (1..k).rev() {
            acc.merge(&bins[used[j]]);
            right_cost[j] = acc.bounds.area() * acc.count as f64;
        }
        let mut acc = Bin::EMPTY;
        for j in 0..k.saturating_sub(1) {
            acc.merge(&bins[used[j]]);
            let cost = acc.bounds.area() * acc.count as f64 + right_cost[j + 1];
            best.offer(cost, axis, used[j] + 1);
        }
    }
    best.get()
}

/// The cheapest split so far, kept without branches: costs come in axis and position order
/// and only a strictly lower one replaces it, so the first of equal costs wins.
struct Best {
    cost: f64,
    axis: usize,
    left_bins: usize,
}

impl Best {
    const NONE: Best = Best { cost: f64::INFINITY, axis: 0, left_bins: 0 };

    /// Takes `cost` if lower; `cost < self.cost` also turns away infinite and NaN costs
    /// (a cost is never −∞).
    #[inline(always)]
    fn offer(&mut self, cost: f64, axis: usize, left_bins: usize) {
        let take = cost < self.cost;
        self.cost = if take { cost } else { self.cost };
        self.axis = if take { axis } else { self.axis };
        self.left_bins = if take { left_bins } else { self.left_bins };
    }

    /// (SAH cost, axis, bins on the left).
    fn get(&self) -> Option<(f64, usize, usize)> {
        (self.cost < f64::INFINITY).then_some((self.cost, self.axis, self.left_bins))
    }
}

/// Moves the entries whose sum satisfies `left` to the front (Hoare's scheme: only
/// misplaced pairs swap); returns how many, and the sum boxes of both parts.
fn partition(entries: &mut [Entry], left: impl Fn(DVec3) -> bool) -> (usize, Aabb, Aabb) {
    let (mut ls, mut rs) = (Aabb::EMPTY, Aabb::EMPTY);
    let (mut i, mut j) = (0, entries.len());
    loop {
        while i < j {
            let s = entries[i].sum();
            if !left(s) {
                break;
            }
            ls = ls.grow(s);
            i += 1;
        }
        while i < j {
            let s = entries[j - 1].sum();
            if left(s) {
                break;
            }
            rs = rs.grow(s);
            j -= 1;
        }
        if i == j {
            return (i, ls, rs);
        }
        // entries[i] goes right, entries[j - 1] left, and i < j - 1.
        entries.swap(i, j - 1);
        ls = ls.grow(entries[i].sum());
        rs = rs.grow(entries[j - 1].sum());
        i += 1;
        j -= 1;
    }
}

/// Splits at half the count along the widest centroid axis (any order if all centroids
/// coincide), so each child holds at most ⌈n/2⌉ primitives.
fn median_split(entries: &mut [Entry], sums: &Aabb) -> Split {
    let mid = entries.len() / 2;
    let e = sums.extent();
    let axis = if e.x >= e.y && e.x >= e.z {
        0
    } else if e.y >= e.z {
        1
    } else {
        2
    };
    if e[axis] > 0.0 {
        entries.select_nth_unstable_by(mid, |a, b| a.sum().to_array()[axis].total_cmp(&b.sum().to_array()[axis]));
    }
    let (l, r) = entries.split_at(mid);
    Split { mid, left: Boxes::of(l), right: Boxes::of(r) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;

    fn sphere_items(n: usize, rng: &mut Pcg32, spread: f64, radius: f64) -> Vec<BvhItem> {
        (0..n)
            .map(|i| {
                let c = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * spread;
                let r = radius * (0.1 + rng.next_f64());
                BvhItem { id: i as u32, bounds: Aabb::new(c - r, c + r) }
            })
            .collect()
    }

    /// Every id reachable exactly once, every node's box contains its children's (and its
    /// primitives'), the depth bound holds.
    fn check(bvh: &Bvh, items: &[BvhItem]) {
        assert!(bvh.depth() <= MAX_DEPTH, "depth {}", bvh.depth());
        let mut seen = vec![0u32; items.len()];
        let nodes = bvh.nodes();
        let contains =
            |outer: &Aabb, inner: &Aabb| outer.min.cmple(inner.min).all() && outer.max.cmpge(inner.max).all();
        let mut stack = vec![0usize];
        let mut visited = 0;
        while let Some(i) = stack.pop() {
            visited += 1;
            let n = &nodes[i];
            let b = n.bounds();
            if n.is_leaf() {
                assert!(n.count as usize <= MAX_LEAF_SIZE);
                for &id in &bvh.prim_indices()[n.left_or_first as usize..(n.left_or_first + n.count) as usize] {
                    seen[id as usize] += 1;
                    assert!(contains(&b, &items[id as usize].bounds));
                }
            } else {
                let (l, r) = (i + 1, n.left_or_first as usize);
                assert!(r > l && r < nodes.len());
                assert!(contains(&b, &nodes[l].bounds()) && contains(&b, &nodes[r].bounds()));
                stack.push(l);
                stack.push(r);
            }
        }
        assert_eq!(visited, nodes.len(), "unreachable nodes");
        assert!(seen.iter().all(|&s| s == 1), "a primitive is missing or duplicated");
        assert_eq!(bvh.prim_indices().len(), items.len());
    }

    #[test]
    fn random_spheres_100k() {
        let mut rng = Pcg32::new(1, 2);
        let items = sphere_items(100_000, &mut rng, 100.0, 0.5);
        let bvh = Bvh::build(&items);
        check(&bvh, &items);
    }

    #[test]
    fn all_at_the_same_point() {
        let items: Vec<BvhItem> =
            (0..50_000).map(|i| BvhItem { id: i, bounds: Aabb::new(DVec3::splat(1.0), DVec3::splat(2.0)) }).collect();
        let bvh = Bvh::build(&items);
        check(&bvh, &items);
        assert!(bvh.depth() <= 16, "median split keeps log depth: {}", bvh.depth());
    }

    #[test]
    fn adversarial_scales_respect_the_depth_cap() {
        // Exponentially spaced spheres: SAH alone would peel one primitive per level.
        let items: Vec<BvhItem> = (0..3000)
            .map(|i| {
                let x = 1.01f64.powi(i);
                BvhItem { id: i as u32, bounds: Aabb::new(DVec3::splat(x), DVec3::splat(x * 1.001)) }
            })
            .collect();
        let bvh = Bvh::build(&items);
        check(&bvh, &items);
    }

    /// Traversal (with `Continue`) visits exactly the items whose own boxes the ray's
    /// segment enters, on a deep tree, so the fixed stack and the ordering lose nothing.
    #[test]
    fn traversal_visits_exactly_the_boxes_hit() {
        use crate::accel::{RayBox, Visit};
        let mut rng = Pcg32::new(8, 9);
        let mut items = sphere_items(3000, &mut rng, 30.0, 1.0);
        items.extend((0..400).map(|i| {
            let x = 1.02f64.powi(i);
            BvhItem { id: 3000 + i as u32, bounds: Aabb::new(DVec3::splat(x), DVec3::splat(x * 1.01)) }
        }));
        let bvh = Bvh::build(&items);
        check(&bvh, &items);
        for _ in 0..500 {
            let o = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 40.0 - 5.0;
            let d = DVec3::new(rng.next_f64() - 0.5, rng.next_f64() - 0.5, rng.next_f64() - 0.5);
            let tmax = rng.next_f64() * 50.0;
            let rb = RayBox::new(o, d);
            let mut want: Vec<u32> = items
                .iter()
                .filter(|it| rb.hit(it.bounds.min, it.bounds.max, 0.0, tmax).is_some())
                .map(|it| it.id)
                .collect();
            let mut got = Vec::new();
            bvh.traverse(o, d, 0.0, tmax, |id| {
                got.push(id);
                Visit::Continue
            });
            want.sort_unstable();
            got.sort_unstable();
            // Leaves may offer extra items (their siblings), never miss one or repeat one.
            assert!(want.iter().all(|id| got.binary_search(id).is_ok()), "missed a box");
            assert!(got.windows(2).all(|w| w[0] != w[1]), "visited twice");
        }
    }

    #[test]
    fn small_inputs() {
        assert!(Bvh::build(&[]).is_empty());
        let one = [BvhItem { id: 7, bounds: Aabb::new(DVec3::ZERO, DVec3::ONE) }];
        let bvh = Bvh::build(&one);
        assert_eq!(bvh.nodes().len(), 1);
        assert_eq!(bvh.prim_indices(), &[7]);
        assert_eq!(bvh.depth(), 0);
    }

    #[test]
    fn sah_build_of_10k_spheres() {
        let mut rng = Pcg32::new(3, 4);
        let items = sphere_items(10_000, &mut rng, 50.0, 0.3);
        let bvh = Bvh::build(&items);
        check(&bvh, &items);
        // A sensible SAH tree on uniform input is far shallower than the cap.
        assert!(bvh.depth() < 30);
    }

    /// A torus of `rings × sides` quads, two triangles each, as the mesh bench builds.
    fn torus_items(rings: usize, sides: usize) -> Vec<BvhItem> {
        let point = |i: usize, j: usize| {
            let (u, v) = (
                std::f64::consts::TAU * (i % rings) as f64 / rings as f64,
                std::f64::consts::TAU * (j % sides) as f64 / sides as f64,
            );
            let r = 1.0 + 0.35 * v.cos();
            DVec3::new(r * u.cos(), r * u.sin(), 0.35 * v.sin())
        };
        let mut items = Vec::new();
        for i in 0..rings {
            for j in 0..sides {
                let (a, b, c, d) = (point(i, j), point(i + 1, j), point(i + 1, j + 1), point(i, j + 1));
                for [p, q, r] in [[a, b, c], [a, c, d]] {
                    let id = items.len() as u32;
                    items.push(BvhItem { id, bounds: Aabb::new(p.min(q).min(r), p.max(q).max(r)) });
                }
            }
        }
        items
    }

    /// The splicing of parallel subtrees, the pair short cut and the parallel binning change
    /// nothing: any parallel threshold gives the serial build's bits.
    #[test]
    fn parallel_and_serial_builds_agree_bit_for_bit() {
        let mut rng = Pcg32::new(5, 6);
        let sets = [
            sphere_items(20_000, &mut rng, 100.0, 0.5),
            torus_items(60, 40),
            (0..5000).map(|i| BvhItem { id: i, bounds: Aabb::new(DVec3::splat(1.0), DVec3::splat(2.0)) }).collect(),
            (0..3000)
                .map(|i| {
                    let x = 1.01f64.powi(i);
                    BvhItem { id: i as u32, bounds: Aabb::new(DVec3::splat(x), DVec3::splat(x * 1.001)) }
                })
                .collect(),
        ];
        for items in &sets {
            let serial = Bvh::build_with(items, usize::MAX);
            check(&serial, items);
            for threshold in [2, 3, 100, PAR_THRESHOLD] {
                assert!(Bvh::build_with(items, threshold) == serial, "parallel threshold {threshold}");
            }
        }
    }

    /// The same BVH, bit for bit, on pools of 1 to 4 threads and on repeated builds; the
    /// input is large enough for the root to bin and bound in parallel chunks.
    #[test]
    fn same_bvh_on_any_number_of_threads() {
        let mut rng = Pcg32::new(7, 8);
        let items = sphere_items(PAR_BIN_THRESHOLD + 12_345, &mut rng, 100.0, 0.5);
        let reference = Bvh::build_with(&items, usize::MAX);
        check(&reference, &items);
        for threads in 1..=4 {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            for _ in 0..2 {
                assert!(pool.install(|| Bvh::build(&items)) == reference, "{threads} threads");
            }
        }
    }

    /// A flat sheet of unit squares in z = ±0, corners at ±0 too: an axis without extent and
    /// both zeros, which must neither lose a box nor make the result depend on order.
    #[test]
    fn flat_sheet_with_signed_zeros() {
        let z = |k: usize| if k % 2 == 0 { 0.0 } else { -0.0 };
        let mut items = Vec::new();
        for i in 0..60usize {
            for j in 0..40usize {
                let (x, y) = (i as f64 - 30.0, j as f64 - 20.0);
                let (x, y) = (if x == 0.0 { z(j) } else { x }, if y == 0.0 { z(i) } else { y });
                let min = DVec3::new(x, y, z(i + j));
                let max = DVec3::new(x + 1.0, y + 1.0, z(i + j + 1));
                items.push(BvhItem { id: items.len() as u32, bounds: Aabb::new(min, max) });
            }
        }
        let bvh = Bvh::build(&items);
        check(&bvh, &items);
        assert!(Bvh::build_with(&items, 2) == bvh);
        let mut reversed = items.clone();
        reversed.reverse();
        for (i, it) in reversed.iter_mut().enumerate() {
            it.id = i as u32;
        }
        check(&Bvh::build(&reversed), &reversed);
    }

    /// Sums a few ulps apart far from the origin: bins of less than an ulp must still map
    /// every entry into range and keep every box in its node.
    #[test]
    fn boxes_an_ulp_apart_far_away() {
        let base = 1.0e9f64;
        let items: Vec<BvhItem> = (0..200)
            .map(|i| {
                let mut x = base;
                for _ in 0..i % 7 {
                    x = f64::from_bits(x.to_bits() + 1);
                }
                let c = DVec3::new(x, base + (i / 7) as f64 * 1e-3, -x);
                BvhItem { id: i, bounds: Aabb::new(c, c) }
            })
            .collect();
        let bvh = Bvh::build(&items);
        check(&bvh, &items);
    }

    #[test]
    fn bin_indices_are_in_range_and_monotone() {
        for q in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -1e300, -3.0, -0.5, 0.0, 16.0, 17.5, 1e300, f64::MAX] {
            assert!(Binning::index(q) < BINS, "{q}");
        }
        assert_eq!([0.0, 0.99, 1.01, 7.5, 15.01, 16.0].map(Binning::index), [0, 0, 1, 7, 15, 15]);
        let mut last = 0;
        for i in 0..=16_000 {
            let q = f64::from(i) / 1000.0;
            let b = Binning::index(q);
            assert!(b >= last && (b as f64 - q.floor().min(15.0)).abs() <= 1.0, "{q} → {b}");
            last = b;
        }
    }
}
