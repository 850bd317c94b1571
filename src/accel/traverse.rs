//! Ordered traversal of the flattened nodes with a fixed-size stack (the GPU's algorithm).

use glam::DVec3;

use super::{Bvh, BvhNode, MAX_DEPTH};

/// What the visitor of a primitive tells the traversal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Visit {
    /// Nothing closer found.
    Continue,
    /// A hit at this t: cull everything beyond it.
    Closer(f64),
    /// Done (any-hit queries).
    Stop,
}

/// A ray prepared for slab tests against many boxes.
#[derive(Debug, Clone, Copy)]
pub struct RayBox {
    origin: DVec3,
    inv_dir: DVec3,
    /// Some 1/dir component is infinite: take the careful path.
    parallel: bool,
}

/// Widening of the far slab distance that makes the f64 slab test conservative
/// (1 + 2γ₃ as in pbrt, γₙ = nε/(1 − nε), ε = 2⁻⁵³).
const FAR_WIDEN: f64 = 1.0 + 2.0 * (3.0 * f64::EPSILON * 0.5) / (1.0 - 3.0 * f64::EPSILON * 0.5);

impl RayBox {
    /// Prepares the ray `origin + t·dir` (`dir` need not be normalised) for slab tests; a
    /// zero component of `dir` makes the ray parallel to that axis's slabs.
    pub fn new(origin: DVec3, dir: DVec3) -> Self {
        let inv_dir = dir.recip();
        Self { origin, inv_dir, parallel: !inv_dir.is_finite() }
    }

    /// The entry t of the ray into `[min, max]` within `[tmin, tmax]`, or `None`. An axis
    /// the ray runs parallel to is decided by the origin alone, so an origin lying on a
    /// slab boundary never produces 0·∞ = NaN.
    #[inline]
    pub fn hit(&self, min: DVec3, max: DVec3, tmin: f64, tmax: f64) -> Option<f64> {
        if self.parallel {
            return self.hit_parallel(min, max, tmin, tmax);
        }
        let ta = (min - self.origin) * self.inv_dir;
        let tb = (max - self.origin) * self.inv_dir;
        let t0 = ta.min(tb).max_element().max(tmin);
        let t1 = (ta.max(tb).min_element() * FAR_WIDEN).min(tmax);
        (t0 <= t1).then_some(t0)
    }

    fn hit_parallel(&self, min: DVec3, max: DVec3, tmin: f64, tmax: f64) -> Option<f64> {
        let (mut t0, mut t1) = (tmin, tmax);
        for a in 0..3 {
            if !self.inv_dir[a].is_finite() {
                if self.origin[a] < min[a] || self.origin[a] > max[a] {
                    return None;
                }
                continue;
            }
            let ta = (min[a] - self.origin[a]) * self.inv_dir[a];
            let tb = (max[a] - self.origin[a]) * self.inv_dir[a];
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb) * FAR_WIDEN);
        }
        (t0 <= t1).then_some(t0)
    }

    #[inline]
    fn node(&self, n: &BvhNode, tmin: f64, tmax: f64) -> Option<f64> {
        let min = DVec3::new(f64::from(n.min[0]), f64::from(n.min[1]), f64::from(n.min[2]));
        let max = DVec3::new(f64::from(n.max[0]), f64::from(n.max[1]), f64::from(n.max[2]));
        self.hit(min, max, tmin, tmax)
    }
}

impl Bvh {
    /// Visits the ids of every leaf whose box the ray's segment `[tmin, tmax]` enters,
    /// nearer child first, shrinking `tmax` whenever `visit` reports a closer hit and
    /// stopping when it says so. The stack holds `MAX_DEPTH + 1` entries, as on the GPU.
    pub fn traverse(&self, origin: DVec3, dir: DVec3, tmin: f64, mut tmax: f64, mut visit: impl FnMut(u32) -> Visit) {
        if self.is_empty() {
            return;
        }
        let nodes = self.nodes();
        let rb = RayBox::new(origin, dir);
        if rb.node(&nodes[0], tmin, tmax).is_none() {
            return;
        }
        let mut stack = [0u32; MAX_DEPTH + 1];
        let mut sp = 0usize;
        let mut current = 0usize;
        loop {
            let n = &nodes[current];
            if n.is_leaf() {
                let first = n.left_or_first as usize;
                for &id in &self.prim_indices()[first..first + n.count as usize] {
                    match visit(id) {
                        Visit::Continue => {}
                        Visit::Closer(t) => tmax = tmax.min(t),
                        Visit::Stop => return,
                    }
                }
            } else {
                let (l, r) = (current + 1, n.left_or_first as usize);
                let tl = rb.node(&nodes[l], tmin, tmax);
                let tr = rb.node(&nodes[r], tmin, tmax);
                match (tl, tr) {
                    (Some(a), Some(b)) => {
                        let (near, far) = if a <= b { (l, r) } else { (r, l) };
                        stack[sp] = far as u32;
                        sp += 1;
                        current = near;
                        continue;
                    }
                    (Some(_), None) => {
                        current = l;
                        continue;
                    }
                    (None, Some(_)) => {
                        current = r;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            // Pop the next deferred node that can still hold something closer.
            loop {
                if sp == 0 {
                    return;
                }
                sp -= 1;
                let next = stack[sp] as usize;
                if rb.node(&nodes[next], tmin, tmax).is_some() {
                    current = next;
                    break;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slab_test_edges_and_parallel_rays() {
        let rb = RayBox::new(DVec3::new(-1.0, 1.0, 0.0), DVec3::X);
        // Origin exactly on the y = 1 slab face, direction 0 in y: inside, no NaN.
        assert_eq!(rb.hit(DVec3::ZERO, DVec3::ONE, 0.0, f64::INFINITY), Some(1.0));
        let rb = RayBox::new(DVec3::new(-1.0, 1.0 + 1e-12, 0.0), DVec3::X);
        assert_eq!(rb.hit(DVec3::ZERO, DVec3::ONE, 0.0, f64::INFINITY), None);
        // Oblique ray (no zero component): enters through x = 0, misses when aimed past.
        let rb = RayBox::new(DVec3::new(-3.0, 0.5, 0.5), DVec3::new(1.0, 0.1, -0.1));
        assert_eq!(rb.hit(DVec3::ZERO, DVec3::ONE, 0.0, f64::INFINITY), Some(3.0));
        let rb = RayBox::new(DVec3::new(-3.0, 0.5, 0.5), DVec3::new(1.0, 0.3, -0.1));
        assert_eq!(rb.hit(DVec3::ZERO, DVec3::ONE, 0.0, f64::INFINITY), None);
        // Infinite boxes work.
        let rb = RayBox::new(DVec3::new(5.0, 5.0, 5.0), DVec3::new(1.0, -2.0, 0.5));
        assert_eq!(rb.hit(DVec3::NEG_INFINITY, DVec3::INFINITY, 0.0, 10.0), Some(0.0));
        // Segment ends before the box.
        let rb = RayBox::new(DVec3::new(-3.0, 0.5, 0.5), DVec3::X);
        assert_eq!(rb.hit(DVec3::ZERO, DVec3::ONE, 0.0, 2.9), None);
        assert_eq!(rb.hit(DVec3::ZERO, DVec3::ONE, 0.0, 3.0), Some(3.0));
    }
}
