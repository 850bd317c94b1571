//! Axis-aligned bounding boxes, possibly infinite, for the BVH and for CSG culling.

use glam::DVec3;

use super::Transform;

/// An axis-aligned box `[min, max]`. Infinite extents are allowed (planes); an empty box has
/// `min > max` on some axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// The low corner: the least x, y and z inside (may be −∞).
    pub min: DVec3,
    /// The high corner: the greatest x, y and z inside (may be +∞).
    pub max: DVec3,
}

impl Aabb {
    /// The box holding nothing (min +∞, max −∞): the starting point of [`Self::union`] and
    /// [`Self::grow`] folds.
    pub const EMPTY: Self = Self { min: DVec3::splat(f64::INFINITY), max: DVec3::splat(f64::NEG_INFINITY) };

    /// The box from corner `min` to corner `max`, as given (`min > max` on an axis makes it
    /// empty).
    pub fn new(min: DVec3, max: DVec3) -> Self {
        Self { min, max }
    }
    /// Whether the box holds no point: `min > max` on some axis.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }
    /// Whether every corner coordinate is finite: false for a box with an infinite extent (a
    /// plane's) and for [`Self::EMPTY`].
    pub fn is_finite(&self) -> bool {
        self.min.is_finite() && self.max.is_finite()
    }
    /// The smallest box holding both boxes.
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb { min: self.min.min(o.min), max: self.max.max(o.max) }
    }
    /// The box both boxes hold (empty when they do not overlap).
    pub fn intersection(&self, o: &Aabb) -> Aabb {
        Aabb { min: self.min.max(o.min), max: self.max.min(o.max) }
    }
    /// The smallest box holding this one and the point `p`.
    pub fn grow(&self, p: DVec3) -> Aabb {
        Aabb { min: self.min.min(p), max: self.max.max(p) }
    }
    /// The side lengths, `max − min` per axis (negative on some axis for an empty box).
    pub fn extent(&self) -> DVec3 {
        self.max - self.min
    }
    /// Surface area (for the SAH); 0 for empty boxes.
    pub fn area(&self) -> f64 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// The box of the transformed box. Finite boxes map their 8 corners; a box with an
    /// infinite extent stays finite only along axes the transform does not mix it into.
    pub fn transformed(&self, t: &Transform) -> Aabb {
        if self.is_empty() {
            return *self;
        }
        if self.is_finite() {
            let mut out = Aabb::EMPTY;
            for i in 0..8 {
                let c = DVec3::new(
                    if i & 1 == 0 { self.min.x } else { self.max.x },
                    if i & 2 == 0 { self.min.y } else { self.max.y },
                    if i & 4 == 0 { self.min.z } else { self.max.z },
                );
                out = out.grow(t.point(c));
            }
            return out;
        }
        // Interval arithmetic per output axis, avoiding inf * 0 = NaN.
        let m = t.matrix();
        let mut min = DVec3::ZERO;
        let mut max = DVec3::ZERO;
        for row in 0..3 {
            let (mut lo, mut hi) = (m.col(3)[row], m.col(3)[row]);
            for col in 0..3 {
                let a = m.col(col)[row];
                if a == 0.0 {
                    continue;
                }
                let (x0, x1) = (a * self.min[col], a * self.max[col]);
                lo += x0.min(x1);
                hi += x0.max(x1);
            }
            min[row] = lo;
            max[row] = hi;
        }
        Aabb { min, max }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn infinite_slab_keeps_its_finite_axis() {
        // The plane's half-space box translated and scaled stays bounded in z only.
        let b = Aabb::new(
            DVec3::new(f64::NEG_INFINITY, f64::NEG_INFINITY, 0.0),
            DVec3::new(f64::INFINITY, f64::INFINITY, 0.0),
        );
        let t = Transform::translation(DVec3::new(0.0, 0.0, 2.0)) * Transform::scaling(DVec3::splat(3.0));
        let r = b.transformed(&t);
        assert_eq!(r.min.z, 2.0);
        assert_eq!(r.max.z, 2.0);
        assert!(r.min.x.is_infinite() && r.max.y.is_infinite());
        assert!(!r.min.is_nan() && !r.max.is_nan());
    }

    #[test]
    fn rotated_unit_box() {
        let b = Aabb::new(DVec3::splat(-0.5), DVec3::splat(0.5));
        let r = b.transformed(&Transform::rotation_z(45.0));
        assert!((r.max.x - 0.5 * 2f64.sqrt()).abs() < 1e-12);
        assert!((r.max.z - 0.5).abs() < 1e-12);
    }
}
