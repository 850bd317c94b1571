//! Binned SAH construction with a hard depth cap.

use glam::DVec3;

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

/// One primitive to place: an id stored in [`Bvh::prim_indices`] and its world bounds
/// (finite, non-empty).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BvhItem {
    pub id: u32,
    pub bounds: Aabb,
}

/// A flattened BVH. An empty BVH has no nodes.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Bvh {
    nodes: Vec<BvhNode>,
    prim_indices: Vec<u32>,
}

struct Entry {
    id: u32,
    bounds: Aabb,
    centroid: DVec3,
}

impl Bvh {
    /// Builds over `items` with binned SAH (16 bins on the longest useful axes), falling
    /// back to a median split where a centroid-less axis or the depth budget requires it.
    ///
    /// Depth guarantee: a node at depth d holding n primitives keeps ⌈log₂ n⌉ ≤ MAX_DEPTH − d.
    /// An SAH split is taken only if its larger child still satisfies this one level down;
    /// otherwise the node splits at the median count, which always does. So no leaf lies
    /// deeper than [`MAX_DEPTH`] for any input of up to 2³² primitives.
    pub fn build(items: &[BvhItem]) -> Bvh {
        let mut entries: Vec<Entry> =
            items.iter().map(|it| Entry { id: it.id, bounds: it.bounds, centroid: it.bounds.center() }).collect();
        let mut bvh = Bvh { nodes: Vec::with_capacity(2 * items.len()), prim_indices: Vec::with_capacity(items.len()) };
        if !entries.is_empty() {
            bvh.build_node(&mut entries, 0);
        }
        bvh
    }

    pub fn nodes(&self) -> &[BvhNode] {
        &self.nodes
    }

    /// Leaf `i` covers `prim_indices[first .. first + count]`; entries are [`BvhItem::id`]s.
    pub fn prim_indices(&self) -> &[u32] {
        &self.prim_indices
    }

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

    fn build_node(&mut self, entries: &mut [Entry], depth: usize) {
        let index = self.nodes.len();
        let bounds = entries.iter().fold(Aabb::EMPTY, |b, e| b.union(&e.bounds));
        self.nodes.push(BvhNode::new(&bounds, 0, 0));
        let n = entries.len();
        let budget = MAX_DEPTH - depth;
        let split = if n == 1 || budget == 0 { None } else { choose_split(entries, &bounds, budget) };
        let Some(mid) = split else {
            let first = self.prim_indices.len() as u32;
            self.prim_indices.extend(entries.iter().map(|e| e.id));
            self.nodes[index] = BvhNode::new(&bounds, first, n as u32);
            return;
        };
        let (left, right) = entries.split_at_mut(mid);
        self.build_node(left, depth + 1);
        let right_index = self.nodes.len() as u32;
        self.build_node(right, depth + 1);
        self.nodes[index].left_or_first = right_index;
    }
}

fn ceil_log2(n: usize) -> usize {
    n.next_power_of_two().trailing_zeros() as usize
}

/// Partitions `entries` and returns the split position, or `None` for a leaf.
fn choose_split(entries: &mut [Entry], bounds: &Aabb, budget: usize) -> Option<usize> {
    let n = entries.len();
    let centroids = entries.iter().fold(Aabb::EMPTY, |b, e| b.grow(e.centroid));
    let extent = centroids.extent();
    let mut best: Option<(f64, usize, usize)> = None; // (cost, axis, bins on the left)
    for axis in 0..3 {
        if !extent[axis].is_finite() || extent[axis] <= 0.0 {
            continue;
        }
        let mut counts = [0usize; BINS];
        let mut boxes = [Aabb::EMPTY; BINS];
        for e in entries.iter() {
            let b = bin_of(e.centroid[axis], centroids.min[axis], extent[axis]);
            counts[b] += 1;
            boxes[b] = boxes[b].union(&e.bounds);
        }
        // Sweep from the right to get the area × count of every right part.
        let mut right_cost = [0.0; BINS];
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for i in (1..BINS).rev() {
            acc = acc.union(&boxes[i]);
            cnt += counts[i];
            right_cost[i] = acc.area() * cnt as f64;
        }
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for i in 0..BINS - 1 {
            acc = acc.union(&boxes[i]);
            cnt += counts[i];
            if cnt == 0 || cnt == n {
                continue;
            }
            let cost = acc.area() * cnt as f64 + right_cost[i + 1];
            if cost.is_finite() && best.is_none_or(|b| cost < b.0) {
                best = Some((cost, axis, i + 1));
            }
        }
    }
    let area = bounds.area();
    if let Some((cost, axis, left_bins)) = best {
        let split_cost = TRAVERSAL_COST + cost / area;
        if n <= MAX_LEAF_SIZE && area.is_finite() && area > 0.0 && n as f64 <= split_cost {
            return None;
        }
        let (lo, ext) = (centroids.min[axis], extent[axis]);
        let mid = partition(entries, |e| bin_of(e.centroid[axis], lo, ext) < left_bins);
        // Depth budget: both children must fit in one level less.
        if ceil_log2(mid.max(n - mid)) < budget {
            return Some(mid);
        }
    } else if n <= MAX_LEAF_SIZE {
        // All centroids coincide: splitting cannot separate anything.
        return None;
    }
    Some(median_split(entries, &centroids))
}

fn bin_of(c: f64, lo: f64, extent: f64) -> usize {
    let b = ((c - lo) / extent * BINS as f64) as usize;
    b.min(BINS - 1)
}

/// Moves entries satisfying `left` to the front; returns how many.
fn partition(entries: &mut [Entry], left: impl Fn(&Entry) -> bool) -> usize {
    let mut mid = 0;
    for i in 0..entries.len() {
        if left(&entries[i]) {
            entries.swap(i, mid);
            mid += 1;
        }
    }
    mid
}

/// Splits at half the count along the widest centroid axis (any order if all centroids
/// coincide), so each child holds at most ⌈n/2⌉ primitives.
fn median_split(entries: &mut [Entry], centroids: &Aabb) -> usize {
    let mid = entries.len() / 2;
    let e = centroids.extent();
    let axis = if e.x >= e.y && e.x >= e.z {
        0
    } else if e.y >= e.z {
        1
    } else {
        2
    };
    if e[axis] > 0.0 {
        entries.select_nth_unstable_by(mid, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
    }
    mid
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
}
