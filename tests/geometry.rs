//! Geometry against hand-computed answers: primitives, CSG, offsets, BVH vs brute force.

use glam::{DVec2, DVec3};
use lumen::cpu::{offset_origin, Hit, Ray, World};
use lumen::scene::{CsgOp, MaterialId, Shape, ShapeKind, Transform};
use proptest::prelude::*;

const INF: f64 = f64::INFINITY;

fn prim(kind: ShapeKind, t: Transform, m: u32) -> Shape {
    Shape::primitive(kind, t, MaterialId(m))
}
fn sphere(t: Transform, m: u32) -> Shape {
    prim(ShapeKind::Sphere, t, m)
}
fn cube(t: Transform, m: u32) -> Shape {
    prim(ShapeKind::Cube, t, m)
}
fn cylinder(t: Transform, m: u32) -> Shape {
    prim(ShapeKind::Cylinder, t, m)
}
fn tr(x: f64, y: f64, z: f64) -> Transform {
    Transform::translation(DVec3::new(x, y, z))
}
fn sc(x: f64, y: f64, z: f64) -> Transform {
    Transform::scaling(DVec3::new(x, y, z))
}
fn ray(o: DVec3, d: DVec3) -> Ray {
    Ray::new(o, d, 0.0, INF)
}
fn ray_from(o: DVec3, d: DVec3, tmin: f64) -> Ray {
    Ray::new(o, d, tmin, INF)
}
fn hit(world: &World, r: Ray) -> Hit {
    world.intersect(&r).unwrap_or_else(|| panic!("expected a hit for {r:?}"))
}
fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).length() < 1e-9
}
fn check_hit(h: &Hit, t: f64, normal: DVec3, material: u32, front: bool) {
    assert!((h.t - t).abs() < 1e-9, "t {} != {t} ({h:?})", h.t);
    assert!(close(h.surface.normal, normal), "normal {} != {normal} ({h:?})", h.surface.normal);
    assert_eq!(h.material, MaterialId(material), "{h:?}");
    assert_eq!(h.surface.front_face, front, "{h:?}");
    assert!(h.surface.point.is_finite() && h.surface.uv.is_finite());
}

// ---------------------------------------------------------------- primitives

#[test]
fn sphere_hits_from_outside_inside_and_grazing() {
    let w = World::from_shapes(&[sphere(tr(5.0, 0.0, 0.0) * sc(2.0, 2.0, 2.0), 0)]);
    let h = hit(&w, ray(DVec3::ZERO, DVec3::new(0.5, 0.0, 0.0)));
    check_hit(&h, 6.0, -DVec3::X, 0, true);
    assert_eq!(h.surface.point, DVec3::new(3.0, 0.0, 0.0));
    // From inside: the far wall, back face, normal towards the origin.
    let h = hit(&w, ray(DVec3::new(5.0, 0.0, 0.0), DVec3::Z));
    check_hit(&h, 2.0, -DVec3::Z, 0, false);
    // Grazing (tangent) ray: one touching point, no NaN.
    let h = hit(&w, ray(DVec3::new(0.0, 2.0, 0.0), DVec3::X));
    assert!((h.t - 5.0).abs() < 1e-7 && h.surface.normal.is_finite() && h.surface.normal.dot(DVec3::X) <= 0.0);
    assert!(w.intersect(&ray(DVec3::new(0.0, 2.0 + 1e-9, 0.0), DVec3::X)).is_none());
    // Range is open: a hit exactly at tmax or tmin is not reported.
    assert!(w.intersect(&Ray::new(DVec3::ZERO, DVec3::X, 0.0, 3.0)).is_none());
    assert!(w.intersect(&Ray::new(DVec3::ZERO, DVec3::X, 3.0, 6.9)).is_none());
    assert!(w.occluded(&Ray::new(DVec3::ZERO, DVec3::X, 0.0, 3.0 + 1e-9)));
}

#[test]
fn tiny_sphere_far_away_and_huge_sphere_farther() {
    // Radius 1e-3 seen from 1e4 away.
    let w = World::from_shapes(&[sphere(tr(1e4, 0.0, 0.0) * sc(1e-3, 1e-3, 1e-3), 0)]);
    for k in 0..20 {
        let y = (k as f64 - 10.0) * 1e-4; // offsets of the target, radius 1e-3
        let h = hit(&w, ray(DVec3::new(0.0, y, 0.0), DVec3::X));
        let want = 1e4 - (1e-6 - y * y).sqrt();
        assert!((h.t - want).abs() < 4e-12, "y = {y}: {} vs {want}", h.t);
        assert!(((h.surface.point - DVec3::new(1e4, 0.0, 0.0)).length() - 1e-3).abs() < 4e-12);
    }
    assert!(w.intersect(&ray(DVec3::new(0.0, 1.001e-3, 0.0), DVec3::X)).is_none());
    // Radius 1e6 at 1e8.
    let w = World::from_shapes(&[sphere(tr(1e8, 0.0, 0.0) * sc(1e6, 1e6, 1e6), 0)]);
    let h = hit(&w, ray(DVec3::ZERO, DVec3::X));
    assert!((h.t - (1e8 - 1e6)).abs() <= 3e-8, "{}", h.t); // 2 ulps
    let h = hit(&w, ray(DVec3::new(0.0, 6e5, 0.0), DVec3::X));
    assert!((h.t - (1e8 - 8e5)).abs() < 1e-6, "{}", h.t);
}

#[test]
fn plane_from_both_sides_and_parallel() {
    let w = World::from_shapes(&[prim(ShapeKind::Plane, tr(0.0, 0.0, -1.0), 3)]);
    let h = hit(&w, ray(DVec3::ZERO, DVec3::new(1.0, 0.0, -0.5)));
    check_hit(&h, 2.0, DVec3::Z, 3, true);
    assert_eq!(h.surface.point, DVec3::new(2.0, 0.0, -1.0));
    let h = hit(&w, ray(DVec3::new(0.0, 0.0, -3.0), DVec3::Z));
    check_hit(&h, 2.0, -DVec3::Z, 3, false);
    assert!(w.intersect(&ray(DVec3::ZERO, DVec3::X)).is_none());
    assert!(w.intersect(&ray(DVec3::new(0.0, 0.0, -1.0), DVec3::X)).is_none());
    assert_eq!(w.unbounded(), &[0]);
}

#[test]
fn cube_faces_edges_corners() {
    let w = World::from_shapes(&[cube(tr(0.0, 0.0, 0.0) * sc(2.0, 2.0, 2.0), 1)]);
    for axis in 0..3 {
        for s in [-1.0, 1.0] {
            let mut o = DVec3::ZERO;
            o[axis] = 5.0 * s;
            let h = hit(&w, ray(o, -o / 5.0));
            let mut n = DVec3::ZERO;
            n[axis] = s;
            check_hit(&h, 4.0, n, 1, true);
        }
    }
    // Along an edge (y = z = 1): enters at x = −1.
    let h = hit(&w, ray(DVec3::new(-3.0, 1.0, 1.0), DVec3::X));
    assert_eq!(h.t, 2.0);
    assert!(h.surface.normal.is_finite() && h.surface.normal.dot(DVec3::X) <= 0.0);
    // Through a corner diagonally.
    let h = hit(&w, ray(DVec3::splat(-3.0), DVec3::ONE));
    assert_eq!(h.t, 2.0);
    assert_eq!(h.surface.point, DVec3::splat(-1.0));
    // Origin on a face plane, direction parallel to it: grazes the face, no NaN.
    let h = hit(&w, ray(DVec3::new(-3.0, 1.0, 0.0), DVec3::X));
    assert_eq!(h.t, 2.0);
    assert!(h.surface.normal.is_finite());
    // Inside: exits.
    let h = hit(&w, ray(DVec3::ZERO, DVec3::new(0.0, 0.0, -2.0)));
    check_hit(&h, 0.5, DVec3::Z, 1, false);
}

#[test]
fn cylinder_side_caps_rim() {
    let w = World::from_shapes(&[cylinder(sc(2.0, 2.0, 2.0), 2)]); // radius 1, |z| ≤ 1
    check_hit(&hit(&w, ray(DVec3::new(-5.0, 0.0, 0.0), DVec3::X)), 4.0, -DVec3::X, 2, true);
    check_hit(&hit(&w, ray(DVec3::new(0.3, 0.2, 5.0), -DVec3::Z)), 4.0, DVec3::Z, 2, true);
    check_hit(&hit(&w, ray(DVec3::new(0.3, 0.2, -5.0), DVec3::Z)), 4.0, -DVec3::Z, 2, true);
    // Diagonal through the rim of the top cap at x = −1, z = 1.
    let h = hit(&w, ray(DVec3::new(-2.0, 0.0, 2.0), DVec3::new(1.0, 0.0, -1.0)));
    assert!((h.t - 1.0).abs() < 1e-12 && h.surface.normal.is_finite());
    // Parallel to the axis just outside / on the side surface.
    assert!(w.intersect(&ray(DVec3::new(1.0 + 1e-9, 0.0, -5.0), DVec3::Z)).is_none());
    let h = hit(&w, ray(DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0)));
    check_hit(&h, 1.0, -DVec3::Y, 2, false);
}

#[test]
fn uv_of_every_shape_per_spec() {
    // Sphere radius 2 at (10, 0, 0): hit at object point (0, −1, 0) → u = 3/4, v = 1/2.
    let w = World::from_shapes(&[sphere(tr(10.0, 0.0, 0.0) * sc(2.0, 2.0, 2.0), 0)]);
    let h = hit(&w, ray(DVec3::new(10.0, -5.0, 0.0), DVec3::Y));
    assert!((h.surface.uv - DVec2::new(0.75, 0.5)).length() < 1e-12, "{}", h.surface.uv);
    // From above at 45° latitude in the +x,+y quadrant direction: u = 1/8, v = acos(z)/π.
    let p = DVec3::new(1.0, 1.0, 2f64.sqrt()).normalize();
    let h = hit(&w, ray(DVec3::new(10.0, 0.0, 0.0) + 4.0 * p, -p));
    assert!((h.surface.uv - DVec2::new(0.125, 0.25)).length() < 1e-12, "{}", h.surface.uv);
    // Plane, translated: uv from the object-space point.
    let w = World::from_shapes(&[prim(ShapeKind::Plane, tr(0.5, 0.0, 0.0), 0)]);
    let h = hit(&w, ray(DVec3::new(2.75, -0.25, 1.0), -DVec3::Z));
    assert!((h.surface.uv - DVec2::new(0.25, 0.75)).length() < 1e-12, "{}", h.surface.uv);
    // Cube: each face centre lands in the centre of its cell of the cross.
    let cells = [(0, 1), (2, 1), (1, 0), (1, 2), (1, 1), (3, 1)]; // −x +x −y +y −z +z
    let w = World::from_shapes(&[cube(Transform::IDENTITY, 0)]);
    for (face, (c, r)) in cells.iter().enumerate() {
        let mut n = DVec3::ZERO;
        n[face / 2] = if face % 2 == 1 { 1.0 } else { -1.0 };
        let h = hit(&w, ray(3.0 * n, -n));
        let want = DVec2::new((*c as f64 + 0.5) / 4.0, (*r as f64 + 0.5) / 3.0);
        assert!((h.surface.uv - want).length() < 1e-12, "face {face}: {}", h.surface.uv);
    }
    // +x face at (y, z) = (0.25, −0.25): u = (2 + (z/0.5 + 1)/2)/4, v = (1 + (y/0.5 + 1)/2)/3.
    let h = hit(&w, ray(DVec3::new(3.0, 0.25, -0.25), -DVec3::X));
    assert!((h.surface.uv - DVec2::new(2.25 / 4.0, 1.75 / 3.0)).length() < 1e-12, "{}", h.surface.uv);
    // Cylinder: side and both caps.
    let w = World::from_shapes(&[cylinder(Transform::IDENTITY, 0)]);
    let h = hit(&w, ray(DVec3::new(0.0, -3.0, 0.25), DVec3::Y));
    let want = DVec2::new(0.75, (-0.25 + 1.0) / 2.0);
    assert!((h.surface.uv - want).length() < 1e-12, "{}", h.surface.uv);
    let h = hit(&w, ray(DVec3::new(0.25, -0.125, 3.0), -DVec3::Z));
    assert!((h.surface.uv - DVec2::new((3.0 - 0.5) / 4.0, (3.0 + 0.25) / 4.0)).length() < 1e-12, "{}", h.surface.uv);
    let h = hit(&w, ray(DVec3::new(0.25, -0.125, -3.0), DVec3::Z));
    assert!((h.surface.uv - DVec2::new((3.0 - 0.5) / 4.0, (1.0 - 0.25) / 4.0)).length() < 1e-12, "{}", h.surface.uv);
}

#[test]
fn unnormalised_directions_scale_t_only() {
    let shapes = [
        sphere(tr(3.0, 0.2, -0.1), 0),
        cube(tr(-4.0, 0.0, 0.0) * Transform::rotation_z(20.0), 1),
        cylinder(tr(0.0, 5.0, 0.0) * Transform::rotation_x(70.0), 2),
    ];
    let w = World::from_shapes(&shapes);
    for d in [DVec3::X, -DVec3::X, DVec3::Y] {
        let base = hit(&w, ray(DVec3::new(0.0, 0.1, 0.05), d));
        for scale in [1e-6, 3.0, 1e7] {
            let h = hit(&w, ray(DVec3::new(0.0, 0.1, 0.05), d * scale));
            assert!((h.t * scale - base.t).abs() < 1e-12 * base.t, "{d} × {scale}");
            assert!(
                close(h.surface.point, base.surface.point)
                    && close(h.surface.normal, base.surface.normal)
                    && h.material == base.material
            );
        }
    }
    // On the cylinder's side surface, parallel to its axis: enters through the cap rim.
    let w = World::from_shapes(&[cylinder(Transform::IDENTITY, 0)]);
    let h = hit(&w, ray(DVec3::new(0.5, 0.0, -5.0), DVec3::Z));
    check_hit(&h, 4.5, -DVec3::Z, 0, true);
}

#[test]
fn normals_use_the_inverse_transpose() {
    // Sphere squashed to an ellipsoid x²/4 + y² + z² = 1; at (√2, √0.5, 0) the normal is
    // ∝ (x/4, y, 0).
    let w = World::from_shapes(&[sphere(sc(2.0, 1.0, 1.0), 0)]);
    let p = DVec3::new(2f64.sqrt(), 0.5f64.sqrt(), 0.0);
    let h = hit(&w, ray(p + DVec3::new(0.0, 3.0, 0.0), -DVec3::Y));
    let want = DVec3::new(p.x / 4.0, p.y, 0.0).normalize();
    assert!(close(h.surface.normal, want), "{} vs {want}", h.surface.normal);
    assert!(close(h.surface.point, p));
}

// ---------------------------------------------------------------- CSG

/// Two unit spheres at x = 0 (material 0) and x = 1 (material 1); rays along +x from x = −5.
fn two_spheres(op: CsgOp) -> World {
    World::from_shapes(&[Shape::csg(
        op,
        vec![sphere(Transform::IDENTITY, 0), sphere(tr(1.0, 0.0, 0.0), 1)],
        Transform::IDENTITY,
    )])
}

#[test]
fn csg_operations_on_two_spheres() {
    let o = DVec3::new(-5.0, 0.0, 0.0);
    let x = DVec3::X;
    // UNITE keeps the inner surface of the second sphere (at x = 0, t = 5).
    let w = two_spheres(CsgOp::Unite);
    check_hit(&hit(&w, ray(o, x)), 4.0, -x, 0, true);
    check_hit(&hit(&w, ray_from(o, x, 4.5)), 5.0, -x, 1, true);
    check_hit(&hit(&w, ray_from(o, x, 5.5)), 6.0, -x, 0, false);
    // FUSE drops it: next after 4.5 is the exit of sphere 1 at x = 2.
    let w = two_spheres(CsgOp::Fuse);
    check_hit(&hit(&w, ray(o, x)), 4.0, -x, 0, true);
    check_hit(&hit(&w, ray_from(o, x, 4.5)), 7.0, -x, 1, false);
    // INTERSECT: the lens between x = 0 and x = 1.
    let w = two_spheres(CsgOp::Intersect);
    check_hit(&hit(&w, ray(o, x)), 5.0, -x, 1, true);
    check_hit(&hit(&w, ray_from(o, x, 5.5)), 6.0, -x, 0, false);
    assert!(w.intersect(&ray_from(o, x, 6.5)).is_none());
    // DIFF: sphere 0 minus sphere 1, the carved surface has sphere 1's material and a
    // flipped normal (the ray leaves the solid there).
    let w = two_spheres(CsgOp::Diff);
    check_hit(&hit(&w, ray(o, x)), 4.0, -x, 0, true);
    check_hit(&hit(&w, ray_from(o, x, 4.5)), 5.0, -x, 1, false);
    assert!(w.intersect(&ray_from(o, x, 5.5)).is_none());
    // From the other side the ray crosses the carved-away sphere 1 and enters the solid
    // through the carved surface at x = 0 (front face).
    let back = DVec3::new(5.0, 0.0, 0.0);
    check_hit(&hit(&w, ray(back, -x)), 5.0, x, 1, true);
}

#[test]
fn fuse_hides_touching_faces_unite_shows_them() {
    let pair = |op| {
        World::from_shapes(&[Shape::csg(
            op,
            vec![cube(Transform::IDENTITY, 0), cube(tr(1.0, 0.0, 0.0), 1)],
            Transform::IDENTITY,
        )])
    };
    let o = DVec3::new(-5.0, 0.1, 0.2);
    let w = pair(CsgOp::Fuse);
    check_hit(&hit(&w, ray_from(o, DVec3::X, 4.6)), 6.5, -DVec3::X, 1, false);
    // UNITE keeps the shared face x = 0.5 (both cubes have a surface there).
    let w = pair(CsgOp::Unite);
    assert_eq!(hit(&w, ray_from(o, DVec3::X, 4.6)).t, 5.5);
}

#[test]
fn csg_diff_order_and_carved_normals() {
    // Sphere 1 minus sphere 0: solid x ∈ [1, 2]; its entry is sphere 0's exit, flipped.
    let w = World::from_shapes(&[Shape::csg(
        CsgOp::Diff,
        vec![sphere(tr(1.0, 0.0, 0.0), 1), sphere(Transform::IDENTITY, 0)],
        Transform::IDENTITY,
    )]);
    check_hit(&hit(&w, ray(DVec3::new(-5.0, 0.0, 0.0), DVec3::X)), 6.0, -DVec3::X, 0, true);
}

/// A three-level tree with node transformations:
/// UNITE[translate (10,0,0)](
///   DIFF[rotate z 90°](
///     INTERSECT(cube ×2 (m0), sphere ×1.3 (m1)),
///     UNITE(cylinder ×(1,1,4) (m2), cylinder rotated onto x (m3))),
///   sphere ×0.5 at (0,0,3) (m4))
fn nested() -> Shape {
    let block = Shape::csg(
        CsgOp::Intersect,
        vec![cube(sc(2.0, 2.0, 2.0), 0), sphere(sc(1.3, 1.3, 1.3), 1)],
        Transform::IDENTITY,
    );
    let drills = Shape::csg(
        CsgOp::Unite,
        vec![cylinder(sc(1.0, 1.0, 4.0), 2), cylinder(Transform::rotation_y(90.0) * sc(1.0, 1.0, 4.0), 3)],
        Transform::IDENTITY,
    );
    let drilled = Shape::csg(CsgOp::Diff, vec![block, drills], Transform::rotation_z(90.0));
    Shape::csg(CsgOp::Unite, vec![drilled, sphere(tr(0.0, 0.0, 3.0) * sc(0.5, 0.5, 0.5), 4)], tr(10.0, 0.0, 0.0))
}

#[test]
fn csg_three_levels_deep() {
    let shape = nested();
    assert_eq!(shape.csg_depth(), 3);
    let w = World::from_shapes(&[shape]);
    let down = -DVec3::Z;
    // Straight down the axis: the small sphere, then nothing (the z drill is a through hole).
    check_hit(&hit(&w, ray(DVec3::new(10.0, 0.0, 10.0), down)), 6.5, DVec3::Z, 4, true);
    assert!(w.intersect(&ray_from(DVec3::new(10.0, 0.0, 10.0), down, 7.6)).is_none());
    // At world (10.75, 0): DIFF space (0, −0.75): no drill; the cube's top face at z = 1.
    check_hit(&hit(&w, ray(DVec3::new(10.75, 0.0, 10.0), down)), 9.0, DVec3::Z, 0, true);
    // At world (10, 0.75): DIFF space (0.75, 0): the x drill (rotated onto world y) carves
    // |z| ≤ 0.5, leaving two slabs.
    let o = DVec3::new(10.0, 0.75, 10.0);
    check_hit(&hit(&w, ray(o, down)), 9.0, DVec3::Z, 0, true);
    check_hit(&hit(&w, ray_from(o, down, 9.2)), 9.5, DVec3::Z, 3, false);
    check_hit(&hit(&w, ray_from(o, down, 9.6)), 10.5, DVec3::Z, 3, true);
    check_hit(&hit(&w, ray_from(o, down, 10.6)), 11.0, DVec3::Z, 0, false);
    assert!(w.intersect(&ray_from(o, down, 11.1)).is_none());
    // Near a corner of the cube the sphere (m1) bounds the block.
    let p = DVec3::new(0.9, 0.9, 0.0);
    let z = (1.69f64 - 0.81 - 0.81).sqrt();
    let h = hit(&w, ray(DVec3::new(10.0 + p.x, p.y, 10.0), down));
    assert!((h.t - (10.0 - z)).abs() < 1e-9 && h.material == MaterialId(1), "{h:?}");
    assert!(close(h.surface.normal, DVec3::new(0.9, 0.9, z) / 1.3));
    // Occlusion agrees.
    assert!(w.occluded(&Ray::new(o, down, 9.6, 10.6)));
    assert!(!w.occluded(&Ray::new(o, down, 9.6, 10.4)));
}

#[test]
fn any_hit_through_intersect_and_diff() {
    let x = DVec3::X;
    let o = DVec3::new(-5.0, 0.0, 0.0);
    let w = two_spheres(CsgOp::Intersect);
    // The lens spans t ∈ [5, 6]: a segment ending before it sees nothing even though it
    // crosses sphere 0's surface at t = 4.
    assert!(!w.occluded(&Ray::new(o, x, 0.0, 4.9)));
    assert!(w.occluded(&Ray::new(o, x, 0.0, 5.1)));
    assert!(!w.occluded(&Ray::new(o, x, 6.1, INF)));
    let w = two_spheres(CsgOp::Diff);
    // Solid t ∈ [4, 5]: a segment inside the carved part (5, 7) sees nothing even though it
    // crosses sphere 0's exit at t = 6.
    assert!(!w.occluded(&Ray::new(o, x, 5.1, 7.5)));
    assert!(w.occluded(&Ray::new(o, x, 4.5, 5.5)));
}

#[test]
fn coincident_face_diff_does_not_leak() {
    // [−1,1]³ minus [0,1]×[−1,1]²: the subtracted box shares the faces y = ±1, z = ±1, x = 1.
    let w = World::from_shapes(&[Shape::csg(
        CsgOp::Diff,
        vec![cube(sc(2.0, 2.0, 2.0), 0), cube(tr(0.5, 0.0, 0.0) * sc(1.0, 2.0, 2.0), 1)],
        Transform::IDENTITY,
    )]);
    for k in 0..50 {
        let (x, y) = (0.01 + 0.0198 * k as f64, -0.99 + 0.0396 * k as f64);
        assert!(w.intersect(&ray(DVec3::new(x, y, 5.0), -DVec3::Z)).is_none(), "leak at {x} {y}");
        assert!(w.intersect(&ray(DVec3::new(x, 5.0, y), -DVec3::Y)).is_none(), "leak at {x} {y}");
    }
    // From +x the first surface is the carved face x = 0 (material 1, facing the ray).
    check_hit(&hit(&w, ray(DVec3::new(5.0, 0.3, 0.2), -DVec3::X)), 5.0, DVec3::X, 1, true);
    // The same pair placed by a rotating, translating parent node, rays from random
    // points above the shared top face in random downward directions.
    let place = tr(3.0, -2.0, 1.0) * Transform::rotation_z(37.0) * Transform::rotation_x(21.0);
    let w = World::from_shapes(&[Shape::csg(
        CsgOp::Diff,
        vec![cube(sc(2.0, 2.0, 2.0), 0), cube(tr(0.5, 0.0, 0.0) * sc(1.0, 2.0, 2.0), 1)],
        place,
    )]);
    let mut rng = lumen::sampling::Pcg32::new(2, 3);
    for _ in 0..5000 {
        let p = DVec3::new(0.1 + 0.8 * rng.next_f64(), -0.98 + 1.96 * rng.next_f64(), 1.0);
        let d = DVec3::new(0.02 * (rng.next_f64() - 0.5), 0.5 * (rng.next_f64() - 0.5), -1.0);
        let r = ray(place.point(p - 3.0 * d), place.vector(d));
        assert!(w.intersect(&r).is_none(), "leak at {p}");
    }
    // A solid minus itself is empty.
    let w = World::from_shapes(&[Shape::csg(
        CsgOp::Diff,
        vec![sphere(Transform::rotation_x(30.0), 0), sphere(Transform::rotation_x(30.0), 1)],
        Transform::IDENTITY,
    )]);
    for k in 0..50 {
        let d = DVec3::new(1.0, 0.02 * k as f64 - 0.5, 0.013 * k as f64 - 0.3);
        assert!(w.intersect(&ray(DVec3::new(-5.0, 0.0, 0.0), d)).is_none());
    }
}

#[test]
fn csg_with_a_plane_half_space() {
    // A unit sphere cut by the half-space z ≤ 0: a hemisphere with a flat top (the plane's
    // material), including for rays starting inside the (unbounded) half-space.
    let w = World::from_shapes(&[Shape::csg(
        CsgOp::Intersect,
        vec![sphere(Transform::IDENTITY, 0), prim(ShapeKind::Plane, Transform::IDENTITY, 5)],
        Transform::IDENTITY,
    )]);
    assert!(w.unbounded().is_empty());
    check_hit(&hit(&w, ray(DVec3::new(0.2, 0.0, 5.0), -DVec3::Z)), 5.0, DVec3::Z, 5, true);
    check_hit(&hit(&w, ray(DVec3::new(0.0, 0.0, -5.0), DVec3::Z)), 4.0, -DVec3::Z, 0, true);
    // Sphere minus the half-space: the upper hemisphere; rays from below enter at z = 0.
    let w = World::from_shapes(&[Shape::csg(
        CsgOp::Diff,
        vec![sphere(Transform::IDENTITY, 0), prim(ShapeKind::Plane, Transform::IDENTITY, 5)],
        Transform::IDENTITY,
    )]);
    check_hit(&hit(&w, ray(DVec3::new(0.0, 0.3, -5.0), DVec3::Z)), 5.0, -DVec3::Z, 5, true);
}

// ---------------------------------------------------------------- offsets

/// Rays leaving surfaces far from the origin and on tiny shapes do not re-hit them.
#[test]
fn spawned_rays_do_not_rehit_their_surface() {
    let mut rng = lumen::sampling::Pcg32::new(5, 6);
    let placements = [
        (tr(1e5, -1e5, 1e5), 1.0),
        (tr(0.0, 0.0, 0.0) * sc(1e-4, 1e-4, 1e-4), 1e-4),
        (tr(1e5, 3e4, -2e5) * sc(1e-4, 1e-4, 1e-4), 1e-4),
        (tr(-1e5, 0.0, 0.0) * Transform::rotation_z(33.0) * sc(3e2, 1.0, 5.0), 3e2),
    ];
    for kind in [ShapeKind::Sphere, ShapeKind::Cube, ShapeKind::Plane, ShapeKind::Cylinder] {
        for (t, size) in placements {
            let w = World::from_shapes(&[prim(kind, t, 0)]);
            let mut tested = 0;
            for _ in 0..400 {
                let dir = random_dir(&mut rng);
                let target = t.point(random_dir(&mut rng) * 0.45);
                let origin = target - dir * 10.0 * size;
                let Some(h) = w.intersect(&ray(origin, dir)) else { continue };
                tested += 1;
                // Leaving outwards: nothing to hit on a convex shape.
                let outward = if h.surface.front_face { h.surface.normal } else { -h.surface.normal };
                let mut out = random_dir(&mut rng);
                if out.dot(outward) < 0.0 {
                    out = -out;
                }
                let o = offset_origin(h.surface.point, h.surface.scale, h.surface.normal, out);
                let again = w.intersect(&ray(o, out));
                assert!(again.is_none(), "{kind:?} {t:?}: re-hit {again:?} from {h:?}");
                // Shadow ray to a point outside: not occluded.
                let light = h.surface.point + out * 5.0 * size;
                let o2 = offset_origin(light, light.abs().max_element(), -out, -out);
                assert!(!w.occluded(&Ray::new(o, o2 - o, 0.0, 1.0)), "{kind:?}: self-shadow");
                // Going in (solid shapes): the next hit is the far side, not this surface.
                if kind == ShapeKind::Sphere {
                    let mut inward = random_dir(&mut rng);
                    if inward.dot(outward) > -0.2 {
                        inward = (inward - outward * (inward.dot(outward) + 0.5)).normalize();
                    }
                    let o = offset_origin(h.surface.point, h.surface.scale, h.surface.normal, inward);
                    let far = w.intersect(&ray(o, inward)).expect("the far side");
                    assert!(far.t > 1e-6 * size, "{t:?}: re-hit at t = {}", far.t);
                    assert!(!far.surface.front_face);
                }
            }
            assert!(tested > 20, "{kind:?} {t:?}: only {tested} hits");
        }
    }
}

// ---------------------------------------------------------------- BVH vs brute force

fn random_dir(rng: &mut lumen::sampling::Pcg32) -> DVec3 {
    let z = 2.0 * rng.next_f64() - 1.0;
    let phi = std::f64::consts::TAU * rng.next_f64();
    let r = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(r * phi.cos(), r * phi.sin(), z)
}

fn random_ray(rng: &mut lumen::sampling::Pcg32, spread: f64) -> Ray {
    let o = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 2.0 * spread - spread;
    let d = random_dir(rng) * (0.5 + rng.next_f64());
    Ray::new(o, d, rng.next_f64() * 0.1, INF)
}

fn random_transform(rng: &mut lumen::sampling::Pcg32, spread: f64) -> Transform {
    let p = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 2.0 * spread - spread;
    let s = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 1.5 + 0.2;
    Transform::translation(p)
        * Transform::rotation_z(360.0 * rng.next_f64())
        * Transform::rotation_x(360.0 * rng.next_f64())
        * Transform::scaling(s)
}

fn random_shape(rng: &mut lumen::sampling::Pcg32, depth: u32) -> Shape {
    let pick = rng.next_u32() % 8;
    if depth == 0 || pick < 4 {
        let kind = ShapeKind::ALL[(rng.next_u32() % 4) as usize];
        let kind = if kind == ShapeKind::Plane && rng.next_u32() % 3 != 0 { ShapeKind::Sphere } else { kind };
        return prim(kind, random_transform(rng, 1.0), rng.next_u32() % 5);
    }
    let op = [CsgOp::Unite, CsgOp::Intersect, CsgOp::Diff, CsgOp::Fuse][(rng.next_u32() % 4) as usize];
    let n = 2 + rng.next_u32() % 2;
    let children = (0..n).map(|_| random_shape(rng, depth - 1)).collect();
    Shape::csg(op, children, random_transform(rng, 0.5))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn bvh_matches_brute_force(seed in any::<u64>(), n in 1usize..120) {
        let mut rng = lumen::sampling::Pcg32::new(seed, 17);
        let mut shapes: Vec<Shape> = (0..n).map(|_| {
            let mut s = random_shape(&mut rng, 2);
            if let Shape::Csg(c) = &mut s {
                c.transform = Transform::translation(DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 20.0 - 10.0) * c.transform;
            } else if let Shape::Primitive(p) = &mut s {
                p.transform = random_transform(&mut rng, 10.0);
            }
            s
        }).collect();
        if rng.next_u32() % 2 == 0 {
            shapes.push(prim(ShapeKind::Plane, random_transform(&mut rng, 10.0), 0));
        }
        let w = World::from_shapes(&shapes);
        for _ in 0..200 {
            let r = random_ray(&mut rng, 12.0);
            let fast = w.intersect(&r);
            let slow = w.intersect_brute_force(&r);
            prop_assert_eq!(fast.map(|h| h.t), slow, "{:?}", r);
            prop_assert_eq!(w.occluded(&r), slow.is_some());
            if let Some(h) = fast {
                prop_assert!(h.surface.normal.is_finite() && h.surface.point.is_finite() && h.surface.uv.is_finite());
                prop_assert!(h.surface.normal.dot(r.dir) <= 0.0);
            }
        }
    }
}

/// Closest-hit queries evaluate up to `CSG_DEFER_MAX` CSG trees after the BVH traversal
/// (more: where the traversal meets them). Both ways must find what testing every shape
/// finds, with CSG trees in front of, behind and among primitives, planes included.
#[test]
fn deferred_and_immediate_csg_trees_find_the_brute_force_hit() {
    use lumen::prepare::CSG_DEFER_MAX;
    use lumen::sampling::Pcg32;
    for trees in [3, CSG_DEFER_MAX, CSG_DEFER_MAX + 5] {
        let mut rng = Pcg32::new(trees as u64, 99);
        let mut at = || DVec3::new(rng.next_f64() * 20.0 - 10.0, rng.next_f64() * 20.0 - 10.0, rng.next_f64() * 4.0);
        let mut shapes = vec![prim(ShapeKind::Plane, tr(0.0, 0.0, -0.5), 9)];
        let mut centres = Vec::new();
        for i in 0..trees {
            let c = at();
            shapes.push(Shape::csg(
                [CsgOp::Diff, CsgOp::Intersect, CsgOp::Unite, CsgOp::Fuse][i % 4],
                vec![cube(sc(1.6, 1.6, 1.6), 1), sphere(tr(0.3, 0.2, 0.4), 2)],
                tr(c.x, c.y, c.z),
            ));
            let p = at();
            shapes.push(sphere(tr(p.x, p.y, p.z) * sc(0.7, 0.7, 0.7), 3));
            centres.extend([c, p]);
        }
        let w = World::from_shapes(&shapes);
        let mut rng = Pcg32::new(7, trees as u64);
        let mut hits = 0;
        for k in 0..4000 {
            let o = DVec3::new(rng.next_f64() * 30.0 - 15.0, rng.next_f64() * 30.0 - 15.0, 8.0);
            // Aimed near a shape's centre: through CSG trees, grazing them, or missing.
            let jitter = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 2.0 - DVec3::ONE;
            let d = centres[k % centres.len()] + jitter - o;
            let r = ray(o, d);
            let got = w.intersect(&r).map(|h| h.t);
            let want = w.intersect_brute_force(&r);
            assert_eq!(got, want, "{trees} trees, ray {r:?}");
            hits += usize::from(got.is_some_and(|t| (o + d * t).z > -0.49));
        }
        assert!(hits > 2000, "the rays must hit shapes, not only the floor ({hits})");
    }
}
