//! The scene's geometry prepared for ray queries: closest hit and occlusion.

use crate::accel::{Bvh, Visit};
use crate::cpu::csg::{CsgHit, CsgTree};
use crate::cpu::mesh::{MeshCrossing, MeshObject};
use crate::cpu::shapes::{sphere_roots, Crossing, Instance, Span};
use crate::cpu::{Hit, Ray};
use crate::prepare::{all_round, MeshBvhs, RoundSphere, SceneBvh, CSG_DEFER_MAX};
use crate::scene::{Scene, Shape};

/// Whether a crossing at `t` of top-level shape `id` replaces the closest one so far (at
/// `best_t`, of shape `best`): nearer, or as near and earlier in the scene. The query's
/// range ends at `end_past(best_t)`, so t ≤ best_t, and a t that is not less is equal: the
/// GPU's `replaces` (shaders/nearest.wgsl) reads the same. The second rule
/// makes the hit independent of the order objects are tested in where surfaces of two
/// shapes coincide (the coplanar tops of two boxes of equal height): a BVH walk meets them
/// in an order that depends on the ray, the GPU's object list in scene order; with "first
/// met wins" the two disagreed there (`tests/gpu_random_scenes.rs` found it).
fn replaces(t: f64, id: u32, best_t: f64, best: u32) -> bool {
    t < best_t || id < best
}

/// The next f64 above `t` (finite): where a query's range ends once its closest hit is at t,
/// so that a crossing at the same t is still met (as `f64::next_up`, which is newer than
/// lumen's minimum Rust; the GPU's `end_past` in shaders/nearest.wgsl).
fn end_past(t: f64) -> f64 {
    match t.partial_cmp(&0.0) {
        Some(std::cmp::Ordering::Greater) => f64::from_bits(t.to_bits() + 1),
        Some(std::cmp::Ordering::Less) => f64::from_bits(t.to_bits() - 1),
        _ => f64::from_bits(1),
    }
}

/// Relative margin past the closest hit within which the BVH still enters boxes, so that a
/// shape tied with it is tested (`replaces`); one box test's rounding is far below it.
const TIE_CULL_SLACK: f64 = 1.0 + 1.0 / (1u64 << 40) as f64;

/// One top-level shape, prepared. Primitives (the common case) stay inline for locality.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
enum Object {
    Primitive(Instance),
    /// A sphere of a scene whose finite objects are all round spheres
    /// (`prepare::all_round`), tested in the world as the GPU's walk tests it.
    Round(Instance, RoundSphere),
    Csg(CsgTree),
    Mesh(MeshObject),
}

/// What an object reports before the full hit record is computed (only for the winner).
#[derive(Debug, Clone, Copy)]
enum Found {
    Primitive(Crossing),
    Csg(CsgHit),
    Mesh(MeshCrossing),
}

impl Found {
    fn t(&self) -> f64 {
        match self {
            Found::Primitive(c) => c.t,
            Found::Csg(h) => h.end.t,
            Found::Mesh(c) => c.t,
        }
    }
}

impl Object {
    fn closest(&self, ray: &Ray) -> Option<Found> {
        match self {
            Object::Primitive(p) => p.first_crossing(ray).map(Found::Primitive),
            Object::Round(_, r) => round_first_crossing(r, ray).map(Found::Primitive),
            Object::Csg(c) => c.closest(ray).map(Found::Csg),
            Object::Mesh(m) => m.closest(ray).map(Found::Mesh),
        }
    }

    fn occludes(&self, ray: &Ray) -> bool {
        match self {
            Object::Primitive(p) => p.first_crossing(ray).is_some(),
            Object::Round(_, r) => round_first_crossing(r, ray).is_some(),
            Object::Csg(c) => c.occluded(ray),
            Object::Mesh(m) => m.occludes(ray),
        }
    }
}

/// The first crossing of round sphere `r` with t in the open range (tmin, tmax): the
/// quadratic about its centre in the world, whose roots are the object-space test's t
/// (`Instance::first_crossing`).
fn round_first_crossing(r: &RoundSphere, ray: &Ray) -> Option<Crossing> {
    let (t0, t1) = sphere_roots(ray.origin - r.centre, ray.dir, r.radius2)?;
    Span { enter: Crossing::new(t0, 0), exit: Crossing::new(t1, 0) }.first_within(ray)
}

/// Every top-level shape of a scene with its transformations precomputed, the bounded ones
/// in a BVH and the unbounded ones (planes, CSG trees with unbounded solids) in a list
/// that every ray tests.
///
/// ```
/// use lumen::cpu::{Ray, World};
/// use lumen::scene::{SceneBuilder, Transform};
/// use lumen::color::Color;
/// use glam::DVec3;
///
/// let mut b = SceneBuilder::new(4, 4);
/// let m = b.diffuse(Color::gray(0.5));
/// b.sphere(Transform::translation(DVec3::new(5.0, 0.0, 0.0)), m);
/// b.plane(Transform::translation(DVec3::new(0.0, 0.0, -1.0)), m);
/// let world = World::new(&b.build().unwrap());
///
/// let hit = world.intersect(&Ray::new(DVec3::ZERO, DVec3::X, 0.0, f64::INFINITY)).unwrap();
/// assert_eq!((hit.t, hit.shape), (4.0, 0));
/// assert_eq!(hit.surface.normal, -DVec3::X);
/// assert!(world.occluded(&Ray::new(DVec3::ZERO, -DVec3::Z, 0.0, 2.0)));
/// assert!(!world.occluded(&Ray::new(DVec3::ZERO, -DVec3::Z, 0.0, 0.5)));
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct World {
    objects: Vec<Object>,
    geometry: SceneBvh,
    /// Whether closest-hit queries evaluate CSG trees after the traversal
    /// (at most [`CSG_DEFER_MAX`] trees).
    defer_csg: bool,
}

impl World {
    /// Prepares the top-level shapes of `scene` (see [`World::from_shapes`]).
    pub fn new(scene: &Scene) -> World {
        Self::from_shapes(&scene.shapes)
    }

    /// Prepares a list of top-level shapes (index i is reported as `Hit::shape = i`).
    pub fn from_shapes(shapes: &[Shape]) -> World {
        let meshes = MeshBvhs::of(shapes);
        let round = all_round(shapes);
        let objects = shapes
            .iter()
            .map(|s| match s {
                Shape::Primitive(p) => {
                    let instance = Instance { kind: p.kind, to_world: p.transform, material: p.material };
                    match RoundSphere::of(p).filter(|_| round) {
                        Some(r) => Object::Round(instance, r),
                        None => Object::Primitive(instance),
                    }
                }
                Shape::Csg(c) => Object::Csg(CsgTree::from_csg(c)),
                Shape::Mesh(m) => {
                    let bvh = meshes.get(&m.mesh).cloned().unwrap_or_default();
                    Object::Mesh(MeshObject::new(m, bvh))
                }
            })
            .collect();
        let csg_trees = shapes.iter().filter(|s| matches!(s, Shape::Csg(_))).count();
        World { objects, geometry: SceneBvh::from_shapes(shapes), defer_csg: csg_trees <= CSG_DEFER_MAX }
    }

    /// The BVH over the bounded top-level shapes; its ids index `Scene::shapes`.
    pub fn bvh(&self) -> &Bvh {
        &self.geometry.bvh
    }

    /// Indices (into `Scene::shapes`) of the unbounded shapes, which are outside the BVH.
    pub fn unbounded(&self) -> &[u32] {
        &self.geometry.unbounded
    }

    /// The closest hit with t in the open range (tmin, tmax): the least t, and of crossings
    /// at the same t the shape's that comes first in the scene, whatever order the
    /// traversal meets them in (where surfaces of two shapes coincide; DESIGN.md "Closest
    /// hit among objects").
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut best: Option<(u32, Found)> = None;
        let mut tmax = ray.tmax;
        let mut test = |id: u32, tmax: &mut f64| {
            // Once something is hit, a crossing at its t still has to be seen (a tie).
            let end = if best.is_some() { end_past(*tmax) } else { *tmax };
            if let Some(f) = self.objects[id as usize].closest(&Ray { tmax: end, ..*ray }) {
                if best.is_none_or(|(b, found)| replaces(f.t(), id, found.t(), b)) {
                    *tmax = f.t();
                    best = Some((id, f));
                    // Boxes are culled a little beyond it, so that a tie's box is entered
                    // even where its slab distance rounds above the tie's t.
                    return Visit::Closer(f.t() * TIE_CULL_SLACK);
                }
            }
            Visit::Continue
        };
        // CSG trees met on the way, evaluated after the traversal (see [`CSG_DEFER_MAX`]).
        let mut deferred = [0u32; CSG_DEFER_MAX];
        let mut n_deferred = 0;
        let mut defer = |id: u32| {
            let csg = self.defer_csg && matches!(self.objects[id as usize], Object::Csg(_));
            if csg {
                deferred[n_deferred] = id;
                n_deferred += 1;
            }
            csg
        };
        for &id in &self.geometry.unbounded {
            if !defer(id) {
                test(id, &mut tmax);
            }
        }
        let mut t = tmax;
        // (tmax < ray.tmax once a plane was hit: its ties are to be met in the BVH too.)
        let cull = if tmax < ray.tmax { tmax * TIE_CULL_SLACK } else { tmax };
        self.geometry.bvh.traverse(ray.origin, ray.dir, ray.tmin, cull, |id| {
            if defer(id) {
                Visit::Continue
            } else {
                test(id, &mut t)
            }
        });
        for &id in &deferred[..n_deferred] {
            test(id, &mut t);
        }
        let (id, found) = best?;
        let (s, material) = match (&self.objects[id as usize], found) {
            (Object::Primitive(p) | Object::Round(p, _), Found::Primitive(c)) => {
                (p.surface_hit(ray, c, false), p.material)
            }
            (Object::Csg(c), Found::Csg(h)) => c.surface_hit(ray, h),
            (Object::Mesh(m), Found::Mesh(c)) => (m.surface_hit(ray, c), m.material),
            _ => unreachable!("objects report their own kind of hit"),
        };
        Some(Hit { t: found.t(), surface: s, material, shape: id })
    }

    /// Whether anything lies on the ray with t in (tmin, tmax); stops at the first hit found.
    pub fn occluded(&self, ray: &Ray) -> bool {
        if self.geometry.unbounded.iter().any(|&id| self.objects[id as usize].occludes(ray)) {
            return true;
        }
        let mut hit = false;
        self.geometry.bvh.traverse(ray.origin, ray.dir, ray.tmin, ray.tmax, |id| {
            if self.objects[id as usize].occludes(ray) {
                hit = true;
                Visit::Stop
            } else {
                Visit::Continue
            }
        });
        hit
    }

    /// Closest hit by testing every shape (no BVH): the reference the BVH is checked against.
    pub fn intersect_brute_force(&self, ray: &Ray) -> Option<f64> {
        let mut tmax = ray.tmax;
        for o in &self.objects {
            if let Some(f) = o.closest(&Ray { tmax, ..*ray }) {
                tmax = f.t();
            }
        }
        (tmax < ray.tmax).then_some(tmax)
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::color::Color;
    use crate::scene::{SceneBuilder, Transform};

    /// In a scene of round spheres the world-space test finds the object-space test's
    /// crossings (to f64 rounding); one ellipsoid among them turns it off for all.
    #[test]
    fn round_spheres_are_crossed_where_their_object_space_test_crosses_them() {
        let build = |egg: bool| {
            let mut b = SceneBuilder::new(4, 4);
            let m = b.diffuse(Color::gray(0.5));
            for k in 0..12 {
                let r = 0.1 + 0.05 * f64::from(k);
                let at = Transform::translation(DVec3::new(3.0 + f64::from(k), 0.3 * f64::from(k % 3), -0.2));
                b.sphere(at * Transform::rotation_z(29.0 * f64::from(k)) * Transform::scaling(DVec3::new(-r, r, r)), m);
            }
            if egg {
                b.sphere(Transform::translation(DVec3::Z * 9.0) * Transform::scaling(DVec3::new(1.0, 1.0, 1.5)), m);
            }
            World::new(&b.build().unwrap())
        };
        let round = build(false);
        assert!(round.objects.iter().all(|o| matches!(o, Object::Round(..))));
        assert!(build(true).objects.iter().all(|o| matches!(o, Object::Primitive(_))));
        let mut hits = 0;
        for i in 0..200 {
            let a = f64::from(i) * 0.013;
            let ray = Ray::new(
                DVec3::new(0.0, -0.2, 0.0),
                DVec3::new(1.0, a.sin() * 0.2, a.cos() * 0.05),
                0.0,
                f64::INFINITY,
            );
            let want = round.objects.iter().filter_map(|o| match o {
                Object::Round(p, _) => p.first_crossing(&ray),
                _ => None,
            });
            let want = want.map(|c| c.t).fold(f64::INFINITY, f64::min);
            match round.intersect(&ray) {
                Some(h) => {
                    assert!((h.t / want - 1.0).abs() < 1e-12, "ray {i}: {} vs {want}", h.t);
                    hits += 1;
                }
                None => assert!(want.is_infinite(), "ray {i}: missed a crossing at {want}"),
            }
        }
        assert!(hits > 50, "{hits}");
    }
}
