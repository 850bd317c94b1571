//! Watertight ray–triangle intersection in f64, after Woop, Benthin and Wald 2013,
//! "Watertight Ray/Triangle Intersection" (JCGT 2(1)).
//!
//! Why this test and not Möller–Trumbore: a ray through a shared edge or vertex of a closed
//! mesh must hit at least one of the triangles there, or light leaks through the seams. The
//! algorithm gets that by construction: the ray is moved to the origin and sheared so that
//! it runs along +z, and each edge is then decided by the sign of a 2D edge function of the
//! *transformed vertices*. A vertex shared by two triangles transforms to the same numbers
//! in both (it is the same f64 input to the same operations), and the edge function of a
//! shared edge evaluated in the opposite order is the exact negation of the other
//! triangle's (`x·y − z·w` vs `z·w − x·y`: products commute exactly and `a − b = −(b − a)`
//! in IEEE arithmetic), so neighbours never disagree about which side of their edge the
//! ray passes. Only an edge function of exactly zero is ambiguous; see
//! `difference_of_products` for what is done then.

use glam::DVec3;

/// Relative error bound of `n` chained f64 roundings: γₙ = nu/(1 − nu), u = 2⁻⁵³ (Higham;
/// pbrt's `gamma`).
const fn gamma(n: u32) -> f64 {
    let nu = n as f64 * (f64::EPSILON * 0.5);
    nu / (1.0 - nu)
}

/// A ray prepared for many triangle tests: the permutation and shear of Woop et al., computed
/// once per ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShearedRay {
    origin: DVec3,
    /// Axis of the largest |dir| component: it becomes z, so the shear divides by the
    /// largest component and stays bounded (|sx|, |sy| ≤ 1).
    kz: usize,
    /// The other two axes, in the cyclic order that keeps the coordinate frame right-handed;
    /// swapped when `dir[kz] < 0` so that the mapped frame keeps each triangle's winding
    /// (this matters for the sign of the edge functions, not for which triangles are hit).
    kx: usize,
    ky: usize,
    /// Shear coefficients: x' = x − sx·z, y' = y − sy·z, z' = sz·z maps `dir` to (0, 0, 1).
    sx: f64,
    sy: f64,
    sz: f64,
}

/// Where a ray crosses a triangle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriangleHit {
    /// Ray parameter of the crossing, in (0, tmax).
    pub t: f64,
    /// Barycentric weights of p0, p1 and p2: the hit point is `b0·p0 + b1·p1 + b2·p2`. Each
    /// is in [0, 1] and their sum is 1 up to rounding.
    pub b0: f64,
    /// Barycentric weight of p1.
    pub b1: f64,
    /// Barycentric weight of p2.
    pub b2: f64,
    /// Conservative (to first order) bound on |t − t_exact|, t_exact being the parameter at
    /// which the exact ray meets the exact plane of the f64 vertices. Callers that spawn
    /// rays from the hit can widen their offsets by it, and reject `t ≤ t_error` when a hit
    /// that close to the origin cannot be told from one behind it.
    pub t_error: f64,
}

impl ShearedRay {
    /// Prepares `origin + t·dir` for triangle tests. `dir` need not be normalised; a zero or
    /// non-finite `dir` gives a ray that misses everything (its shear is NaN).
    pub fn new(origin: DVec3, dir: DVec3) -> Self {
        let a = dir.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        // One rounding each (a division, not dir·(1/dir_z)): the error analysis below counts
        // the shear coefficients as correctly rounded.
        let (dz, dx, dy) = (dir[kz], dir[kx], dir[ky]);
        Self { origin, kx, ky, kz, sx: dx / dz, sy: dy / dz, sz: 1.0 / dz }
    }

    /// The ray's origin, as given to [`ShearedRay::new`] (in the caller's space).
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// The ray's crossing of the triangle (p0, p1, p2) with t in the open range (0, tmax), or
    /// `None`. Both windings are hit (two-sided); edges and vertices count as inside, so a
    /// ray through a shared edge hits at least one of the triangles sharing it. A degenerate
    /// triangle, one seen exactly edge-on, or NaN input is a miss.
    #[inline]
    pub fn intersect(&self, p0: DVec3, p1: DVec3, p2: DVec3, tmax: f64) -> Option<TriangleHit> {
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        let a = (p0 - self.origin).to_array();
        let b = (p1 - self.origin).to_array();
        let c = (p2 - self.origin).to_array();

        // Sheared x and y of the vertices (the ray is now the +z axis).
        let (ax, ay) = (a[kx] - self.sx * a[kz], a[ky] - self.sy * a[kz]);
        let (bx, by) = (b[kx] - self.sx * b[kz], b[ky] - self.sy * b[kz]);
        let (cx, cy) = (c[kx] - self.sx * c[kz], c[ky] - self.sy * c[kz]);

        // Edge functions: u for edge (p1, p2), hence p0's weight, and cyclically.
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        // Rounding is monotonic, so a non-zero result above already has the exact sign of
        // the 2×2 determinant of these inputs (the two products can round to equal, never
        // cross). Zero is the one ambiguous value: Woop et al. recompute in double from
        // float inputs, which is exact. Here the inputs are already f64, so the fallback is
        // an FMA-based difference of products whose sign is exact (see its doc); all three
        // are recomputed, as in the paper, and the non-zero ones keep their sign.
        if u == 0.0 || v == 0.0 || w == 0.0 {
            u = difference_of_products(cx, by, cy, bx);
            v = difference_of_products(ax, cy, ay, cx);
            w = difference_of_products(bx, ay, by, ax);
        }

        // Inside iff the three edge functions agree in sign (either sign: two-sided).
        let nonneg = u >= 0.0 && v >= 0.0 && w >= 0.0;
        let nonpos = u <= 0.0 && v <= 0.0 && w <= 0.0;
        if !(nonneg || nonpos) {
            return None;
        }
        // Same-sign terms: the sum is 0 only if all are (ray in the triangle's plane, or a
        // degenerate triangle as seen along the ray).
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }

        let (az, bz, cz) = (self.sz * a[kz], self.sz * b[kz], self.sz * c[kz]);
        let t_scaled = u * az + v * bz + w * cz;
        let inv_det = 1.0 / det;
        let t = t_scaled * inv_det;
        // NaN fails both comparisons: a miss.
        if !(t > 0.0 && t < tmax) {
            return None;
        }

        // Error bound in pbrt-v4's style (Pharr, Jakob, Humphreys, "Physically Based
        // Rendering" 4th ed., 6.5.3 and 6.8): the translated, permuted, sheared coordinates
        // carry γ₃ (z) and γ₅ (x, y) relative error, the edge functions δe, the numerator
        // δt_scaled. pbrt divides δt_scaled by |det| only, because it uses the bound for the
        // sign of t; for an absolute bound the error of det itself (three edge functions
        // and two additions) scales t as well, and the final multiply rounds once more.
        let max_zt = az.abs().max(bz.abs()).max(cz.abs());
        let max_xt = ax.abs().max(bx.abs()).max(cx.abs());
        let max_yt = ay.abs().max(by.abs()).max(cy.abs());
        let delta_z = gamma(3) * max_zt;
        let delta_x = gamma(5) * (max_xt + max_zt);
        let delta_y = gamma(5) * (max_yt + max_zt);
        let delta_e = 2.0 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
        let max_e = u.abs().max(v.abs()).max(w.abs());
        let delta_t_scaled = 3.0 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e);
        let delta_det = 3.0 * delta_e + gamma(2) * det.abs();
        let t_error = (delta_t_scaled + t * delta_det) * inv_det.abs() + gamma(2) * t;

        Some(TriangleHit { t, b0: u * inv_det, b1: v * inv_det, b2: w * inv_det, t_error })
    }
}

/// `origin + t·dir` against the triangle (p0, p1, p2) on (0, tmax): [`ShearedRay::intersect`]
/// for a single test. Prepare a [`ShearedRay`] once instead when testing many triangles.
pub fn intersect_triangle(
    origin: DVec3,
    dir: DVec3,
    p0: DVec3,
    p1: DVec3,
    p2: DVec3,
    tmax: f64,
) -> Option<TriangleHit> {
    ShearedRay::new(origin, dir).intersect(p0, p1, p2, tmax)
}

/// `a·b − c·d` by Kahan's algorithm with fused multiply-adds: `e = c·d − fl(c·d)` is
/// exact, and the result's relative error is at most 2u (Jeannerod, Louvet and Muller 2013,
/// "Further analysis of Kahan's algorithm for the accurate computation of 2×2
/// determinants"). So the sign is the exact determinant's, and an exact zero comes out as
/// exactly zero (then `fl(a·b − fl(c·d)) = −e`); the proof needs the products to neither
/// underflow nor overflow, i.e. sheared coordinates of magnitude within about 1e-150..1e150
/// of the ray origin. This is the f64 counterpart of the paper's float → double fallback.
#[inline]
fn difference_of_products(a: f64, b: f64, c: f64, d: f64) -> f64 {
    let cd = c * d;
    let err = (-c).mul_add(d, cd);
    let dop = a.mul_add(b, -cd);
    dop + err
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;
    use crate::scene::mesh::icosphere;
    use rayon::prelude::*;

    const P0: DVec3 = DVec3::new(0.0, 0.0, 0.0);
    const P1: DVec3 = DVec3::new(1.0, 0.0, 0.0);
    const P2: DVec3 = DVec3::new(0.0, 1.0, 0.0);

    #[test]
    fn hand_computed_hit() {
        // Straight down onto (0.25, 0.5): weights x for p1, y for p2, the rest for p0.
        let h = intersect_triangle(DVec3::new(0.25, 0.5, 2.0), DVec3::new(0.0, 0.0, -1.0), P0, P1, P2, 10.0).unwrap();
        assert_eq!(h.t, 2.0);
        assert_eq!((h.b0, h.b1, h.b2), (0.25, 0.25, 0.5));
        assert!(h.t_error > 0.0 && h.t_error < 1e-13, "{}", h.t_error);

        // Unnormalised oblique direction: origin (1, 1, 1), towards (0.2, 0.3, 0) over t = 1,
        // given as half the vector so t = 2.
        let o = DVec3::new(1.0, 1.0, 1.0);
        let target = DVec3::new(0.2, 0.3, 0.0);
        let h = intersect_triangle(o, (target - o) * 0.5, P0, P1, P2, f64::INFINITY).unwrap();
        assert!((h.t - 2.0).abs() <= 4.0 * f64::EPSILON, "{}", h.t);
        assert!((h.b1 - 0.2).abs() < 1e-15 && (h.b2 - 0.3).abs() < 1e-15 && (h.b0 - 0.5).abs() < 1e-15);
        let p = h.b0 * P0 + h.b1 * P1 + h.b2 * P2;
        assert!((p - target).length() < 1e-15);
        assert!((h.b0 + h.b1 + h.b2 - 1.0).abs() < 1e-15);
    }

    #[test]
    fn both_windings_and_both_sides_hit() {
        let o = DVec3::new(0.25, 0.5, 2.0);
        let down = DVec3::new(0.0, 0.0, -1.0);
        let ccw = intersect_triangle(o, down, P0, P1, P2, 10.0).unwrap();
        let cw = intersect_triangle(o, down, P0, P2, P1, 10.0).unwrap();
        assert_eq!(ccw.t, cw.t);
        // The weights follow the vertices, not the order.
        assert_eq!((cw.b0, cw.b1, cw.b2), (ccw.b0, ccw.b2, ccw.b1));
        // From below, looking up.
        let up = intersect_triangle(DVec3::new(0.25, 0.5, -3.0), -down, P0, P1, P2, 10.0).unwrap();
        assert_eq!(up.t, 3.0);
        assert_eq!((up.b0, up.b1, up.b2), (0.25, 0.25, 0.5));
        // Every axis as the dominant one, both signs (exercises the permutation and the swap).
        let tri = [DVec3::new(1.0, -1.0, -1.0), DVec3::new(-1.0, 1.0, -1.0), DVec3::new(-1.0, -1.0, 1.0)];
        let centroid = (tri[0] + tri[1] + tri[2]) / 3.0;
        for axis in 0..3 {
            for sign in [-1.0, 1.0] {
                let mut d = DVec3::splat(0.1);
                d[axis] = sign;
                let h = intersect_triangle(centroid - 5.0 * d, d, tri[0], tri[1], tri[2], 10.0)
                    .unwrap_or_else(|| panic!("axis {axis} sign {sign}"));
                assert!((h.t - 5.0).abs() < 1e-14);
                for b in [h.b0, h.b1, h.b2] {
                    assert!((b - 1.0 / 3.0).abs() < 1e-14);
                }
            }
        }
    }

    #[test]
    fn misses() {
        let down = DVec3::new(0.0, 0.0, -1.0);
        // Outside the hypotenuse.
        assert!(intersect_triangle(DVec3::new(0.6, 0.6, 1.0), down, P0, P1, P2, 10.0).is_none());
        // Outside a leg.
        assert!(intersect_triangle(DVec3::new(-0.01, 0.5, 1.0), down, P0, P1, P2, 10.0).is_none());
        // Behind the origin.
        assert!(intersect_triangle(DVec3::new(0.2, 0.2, 1.0), -down, P0, P1, P2, 10.0).is_none());
        // Beyond tmax, and the open end: t = tmax is a miss.
        let o = DVec3::new(0.2, 0.2, 1.0);
        assert!(intersect_triangle(o, down, P0, P1, P2, 0.5).is_none());
        assert!(intersect_triangle(o, down, P0, P1, P2, 1.0).is_none());
        assert!(intersect_triangle(o, down, P0, P1, P2, 1.0 + 1e-12).is_some());
        // Origin on the triangle: t = 0 is not in (0, tmax).
        assert!(intersect_triangle(DVec3::new(0.2, 0.2, 0.0), down, P0, P1, P2, 10.0).is_none());
        // Degenerate triangle, zero and NaN directions, NaN vertices.
        assert!(intersect_triangle(o, down, P0, P1, P1 * 2.0, 10.0).is_none());
        assert!(intersect_triangle(o, DVec3::ZERO, P0, P1, P2, 10.0).is_none());
        assert!(intersect_triangle(o, DVec3::NAN, P0, P1, P2, 10.0).is_none());
        assert!(intersect_triangle(o, down, DVec3::NAN, P1, P2, 10.0).is_none());
    }

    #[test]
    fn parallel_rays_miss() {
        // In the triangle's plane, through its interior: edge-on, det = 0.
        assert!(intersect_triangle(DVec3::new(-1.0, 0.25, 0.0), DVec3::X, P0, P1, P2, 10.0).is_none());
        // Parallel above the plane.
        assert!(intersect_triangle(DVec3::new(-1.0, 0.25, 0.5), DVec3::X, P0, P1, P2, 10.0).is_none());
        assert!(intersect_triangle(DVec3::new(0.2, 0.2, 0.5), DVec3::new(1.0, 1.0, 0.0), P0, P1, P2, 10.0).is_none());
    }

    #[test]
    fn edges_and_vertices_are_inside() {
        let down = DVec3::new(0.0, 0.0, -1.0);
        for (x, y) in [(0.5, 0.0), (0.0, 0.5), (0.5, 0.5), (0.0, 0.0), (1.0, 0.0), (0.0, 1.0)] {
            let h = intersect_triangle(DVec3::new(x, y, 1.0), down, P0, P1, P2, 10.0);
            assert!(h.is_some(), "({x}, {y})");
        }
        // The two halves of a quad both claim rays through points exactly on their shared
        // diagonal x + y = 1, and at least one claims rays through points that rounding put
        // a hair to either side (1 − 0.1 + 0.1 ≠ 1 in f64).
        let q = DVec3::new(1.0, 1.0, 0.0);
        let halves = |s: f64| {
            let o = DVec3::new(1.0 - s, s, 1.0);
            (
                intersect_triangle(o, down, P1, P2, P0, 10.0).is_some(),
                intersect_triangle(o, down, P2, P1, q, 10.0).is_some(),
            )
        };
        for s in [0.25, 0.5, 0.75] {
            assert_eq!(halves(s), (true, true), "{s}");
        }
        for s in [0.1, 0.3, 1.0 / 3.0, 0.7, 0.9] {
            let (a, b) = halves(s);
            assert!(a || b, "{s}");
        }
    }

    #[test]
    fn exact_fallback_decides_zero_edges() {
        // a = b = 1 + ε, c = 1 + 2ε, d = 1: a·b = 1 + 2ε + ε² rounds to c·d, so plain
        // arithmetic says 0 while the exact determinant is ε² (and −ε² swapped).
        let e = f64::EPSILON;
        let (a, b, c, d) = (1.0 + e, 1.0 + e, 1.0 + 2.0 * e, 1.0);
        assert_eq!(a * b - c * d, 0.0);
        assert_eq!(difference_of_products(a, b, c, d), e * e);
        assert_eq!(difference_of_products(c, d, a, b), -(e * e));
        // Exact zeros stay zero.
        assert_eq!(difference_of_products(0.1, 0.3, 0.3, 0.1), 0.0);
        assert_eq!(difference_of_products(3.0, 7.0, 21.0, 1.0), 0.0);
    }

    #[test]
    fn t_error_bounds_the_error() {
        // Triangles in the plane z = c (exact), arbitrary rays: the exact t is
        // (c − o.z)/d.z, which f64 computes to within half an ulp.
        let mut rng = Pcg32::new(7, 11);
        let mut r = |lo: f64, hi: f64| lo + (hi - lo) * rng.next_f64();
        let mut max_ratio: f64 = 0.0;
        for i in 0..20_000 {
            let scale = [1e-3, 1.0, 1e3, 1e5][i % 4];
            let c = r(-1.0, 1.0) * scale;
            let p = [0, 1, 2].map(|_| DVec3::new(r(-1.0, 1.0) * scale, r(-1.0, 1.0) * scale, c));
            let (b1, b2) = (r(0.0, 0.5), r(0.0, 0.5));
            let target = p[0] + b1 * (p[1] - p[0]) + b2 * (p[2] - p[0]);
            let o = target + DVec3::new(r(-1.0, 1.0), r(-1.0, 1.0), r(-1.0, 1.0)) * scale * 3.0;
            let d = target - o;
            let Some(h) = ShearedRay::new(o, d).intersect(p[0], p[1], p[2], f64::INFINITY) else {
                continue;
            };
            let exact = (c - o.z) / d.z;
            let err = (h.t - exact).abs();
            let slack = exact.abs() * 2.0 * f64::EPSILON;
            assert!(err <= h.t_error + slack, "case {i}: t {} exact {exact} err {err} bound {}", h.t, h.t_error);
            if h.t_error > 0.0 {
                max_ratio = max_ratio.max(err / h.t_error);
            }
        }
        // The bound is conservative but not absurd.
        assert!(max_ratio > 1e-6, "bound looser than expected: {max_ratio}");
    }

    #[test]
    fn icosphere_is_closed_and_outward() {
        let (v, t) = icosphere(2);
        assert_eq!((v.len(), t.len()), (162, 320));
        for [a, b, c] in &t {
            let (a, b, c) = (v[*a as usize], v[*b as usize], v[*c as usize]);
            assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
        }
    }

    /// Watertightness: rays from inside a closed mesh (the centre and random interior
    /// points) aimed exactly at its vertices, at its edge midpoints and in random directions
    /// all hit it; the shared vertices and edges are where a non-watertight test leaks.
    #[test]
    fn rays_from_inside_an_icosphere_never_escape() {
        let (verts, tris) = icosphere(2);
        let mut edges: Vec<(u32, u32)> =
            tris.iter().flat_map(|&[a, b, c]| [(a, b), (b, c), (c, a)]).map(|(a, b)| (a.min(b), a.max(b))).collect();
        edges.sort_unstable();
        edges.dedup();
        assert_eq!(edges.len(), 480);
        let mut targets: Vec<DVec3> = verts.clone();
        targets.extend(edges.iter().map(|&(a, b)| (verts[a as usize] + verts[b as usize]) * 0.5));
        // Also points a hair to either side of each edge, along the edge's normal in the
        // sphere: the rays cross exactly where the two triangles' decisions meet.
        targets.extend(edges.iter().flat_map(|&(a, b)| {
            let (pa, pb) = (verts[a as usize], verts[b as usize]);
            let m = (pa + pb) * 0.5;
            let side = (pb - pa).cross(m).normalize() * 1e-15;
            [m + side, m - side]
        }));
        let random_per_origin = 200;
        let origins: Vec<DVec3> = std::iter::once(DVec3::ZERO)
            .chain((0..700u64).map(|i| {
                let mut rng = Pcg32::new(i, 3);
                loop {
                    let p = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 1.6 - 0.8;
                    if p.length() < 0.8 {
                        return p;
                    }
                }
            }))
            .collect();

        let (rays, escaped): (usize, Vec<String>) = origins
            .par_iter()
            .enumerate()
            .map(|(i, &o)| {
                let mut rng = Pcg32::new(1000 + i as u64, 5);
                let random = (0..random_per_origin).map(|_| {
                    // Uniform on the sphere.
                    let z = 2.0 * rng.next_f64() - 1.0;
                    let phi = std::f64::consts::TAU * rng.next_f64();
                    let r = (1.0 - z * z).sqrt();
                    DVec3::new(r * phi.cos(), r * phi.sin(), z)
                });
                let dirs: Vec<DVec3> = targets.iter().map(|&p| p - o).chain(random).collect();
                let mut escaped = Vec::new();
                for &d in &dirs {
                    let ray = ShearedRay::new(o, d);
                    let hit = tris.iter().any(|&[a, b, c]| {
                        ray.intersect(verts[a as usize], verts[b as usize], verts[c as usize], f64::INFINITY).is_some()
                    });
                    if !hit {
                        escaped.push(format!("origin {o:?} dir {d:?}"));
                    }
                }
                (dirs.len(), escaped)
            })
            .reduce(
                || (0, Vec::new()),
                |(n, mut e), (m, f)| {
                    (n + m, {
                        e.extend(f);
                        e
                    })
                },
            );
        assert!(rays >= 1_000_000, "only {rays} rays");
        assert!(
            escaped.is_empty(),
            "{} of {rays} rays escaped, e.g. {:?}",
            escaped.len(),
            &escaped[..escaped.len().min(5)]
        );
    }
}
