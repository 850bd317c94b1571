//! Unit cube: the box [−0.5, 0.5]³.

use glam::{DVec2, DVec3};

use super::{slab, Crossing, Span, SurfacePoint};

/// Where one cube face lands in the 4×3 cross of the uv square: the cell `(col, row)`
/// (counted from u = 0, v = 0) and which signed object axis runs along u and along v in
/// that cell. Within the cell, `u = (col + (s_u·p[axis_u]/0.5 + 1)/2)/4` and likewise v
/// over 3 rows. The layout is Raytracer.jl's: −z in the centre cell (1, 1), the middle row
/// −x, −z, +x, +z, the middle column −y, −z, +y; neighbouring cells share the cube edge
/// between their faces, so the uv map is continuous across the cross's inner edges.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CubeFace {
    pub col: u8,
    pub row: u8,
    pub axis_u: u8,
    pub sign_u: i8,
    pub axis_v: u8,
    pub sign_v: i8,
}

/// Indexed by face = `2·axis + (1 if the + side)`: −x, +x, −y, +y, −z, +z.
pub const CUBE_FACE_LAYOUT: [CubeFace; 6] = [
    CubeFace { col: 0, row: 1, axis_u: 2, sign_u: -1, axis_v: 1, sign_v: 1 },
    CubeFace { col: 2, row: 1, axis_u: 2, sign_u: 1, axis_v: 1, sign_v: 1 },
    CubeFace { col: 1, row: 0, axis_u: 0, sign_u: 1, axis_v: 2, sign_v: -1 },
    CubeFace { col: 1, row: 2, axis_u: 0, sign_u: 1, axis_v: 2, sign_v: 1 },
    CubeFace { col: 1, row: 1, axis_u: 0, sign_u: 1, axis_v: 1, sign_v: 1 },
    CubeFace { col: 3, row: 1, axis_u: 0, sign_u: -1, axis_v: 1, sign_v: 1 },
];

/// The box as three slabs ([`slab::clip`] says how ties and parallel lines are decided);
/// the inclusive `enter ≤ exit` test keeps hits exactly on edges.
pub(super) fn span(o: DVec3, d: DVec3) -> Option<Span> {
    let mut enter = Crossing::open(f64::NEG_INFINITY);
    let mut exit = Crossing::open(f64::INFINITY);
    for axis in 0..3 {
        let face = 2 * axis as u8;
        if !slab::clip(&mut enter, &mut exit, o[axis], d[axis], face, face + 1) {
            return None;
        }
    }
    (enter.t <= exit.t).then_some(Span { enter, exit })
}

pub(super) fn surface(p: DVec3, face: u8) -> SurfacePoint {
    let face = usize::from(face.min(5));
    let axis = face / 2;
    let s = if face % 2 == 1 { 0.5 } else { -0.5 };
    let mut point = p.clamp(DVec3::splat(-0.5), DVec3::splat(0.5));
    point[axis] = s;
    let mut normal = DVec3::ZERO;
    normal[axis] = s * 2.0;
    let l = CUBE_FACE_LAYOUT[face];
    let cu = f64::from(l.sign_u) * point[usize::from(l.axis_u)] * 2.0;
    let cv = f64::from(l.sign_v) * point[usize::from(l.axis_v)] * 2.0;
    let uv = DVec2::new((f64::from(l.col) + 0.5 * (cu + 1.0)) / 4.0, (f64::from(l.row) + 0.5 * (cv + 1.0)) / 3.0);
    SurfacePoint { point, normal, uv }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn face_centres_land_in_their_cells() {
        for (face, l) in CUBE_FACE_LAYOUT.iter().enumerate() {
            let mut p = DVec3::ZERO;
            p[face / 2] = if face % 2 == 1 { 0.5 } else { -0.5 };
            let s = surface(p, face as u8);
            let want = DVec2::new((f64::from(l.col) + 0.5) / 4.0, (f64::from(l.row) + 0.5) / 3.0);
            assert!((s.uv - want).length() < 1e-15, "face {face}: {}", s.uv);
            assert_eq!(s.normal, p * 2.0);
        }
    }

    #[test]
    fn cross_is_continuous_across_shared_edges() {
        // −z (centre) and +x share the edge x = 0.5, z = −0.5.
        let a = surface(DVec3::new(0.5, 0.2, -0.5), 4).uv;
        let b = surface(DVec3::new(0.5, 0.2, -0.5), 1).uv;
        assert!((a - b).length() < 1e-15);
        // −z and +y share y = 0.5, z = −0.5; −z and −y share y = −0.5.
        assert!(
            (surface(DVec3::new(0.1, 0.5, -0.5), 4).uv - surface(DVec3::new(0.1, 0.5, -0.5), 3).uv).length() < 1e-15
        );
        assert!(
            (surface(DVec3::new(0.1, -0.5, -0.5), 4).uv - surface(DVec3::new(0.1, -0.5, -0.5), 2).uv).length() < 1e-15
        );
        // +x and +z share x = 0.5, z = 0.5; −x and −z share x = −0.5, z = −0.5.
        assert!((surface(DVec3::new(0.5, 0.3, 0.5), 1).uv - surface(DVec3::new(0.5, 0.3, 0.5), 5).uv).length() < 1e-15);
        assert!(
            (surface(DVec3::new(-0.5, 0.3, -0.5), 0).uv - surface(DVec3::new(-0.5, 0.3, -0.5), 4).uv).length() < 1e-15
        );
        // A known interior value: +x at (y, z) = (0.25, 0) → col 2 + 0.5, row 1 + 0.75.
        let s = surface(DVec3::new(0.5, 0.25, 0.0), 1).uv;
        assert!((s - DVec2::new(2.5 / 4.0, 1.75 / 3.0)).length() < 1e-15);
    }

    #[test]
    fn edges_corners_and_parallel_rays() {
        // Exactly through the edge y = z = 0.5.
        let s = span(DVec3::new(-2.0, 0.5, 0.5), DVec3::X).unwrap();
        assert_eq!((s.enter.t, s.exit.t), (1.5, 2.5));
        // Diagonal through two corners.
        let s = span(DVec3::splat(-1.0), DVec3::ONE).unwrap();
        assert_eq!((s.enter.t, s.exit.t), (0.5, 1.5));
        // Origin on a slab boundary, direction zero in that axis: no NaN.
        let s = span(DVec3::new(-1.0, 0.5, 0.0), DVec3::X).unwrap();
        assert_eq!((s.enter.t, s.exit.t), (0.5, 1.5));
        assert!(span(DVec3::new(-1.0, 0.500_000_001, 0.0), DVec3::X).is_none());
        // Grazing a face from outside at t where enter == exit (corner touch).
        let s = span(DVec3::new(-1.0, 0.0, 0.0), DVec3::new(1.0, 1.0, 0.0)).unwrap();
        assert_eq!((s.enter.t, s.exit.t), (0.5, 0.5));
    }
}
