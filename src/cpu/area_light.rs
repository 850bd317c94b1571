//! Sampling points on area lights (emissive top-level spheres, cubes and mesh instances) as
//! seen from a shading point, and the solid-angle density of doing so (for MIS). A mesh
//! light is sampled uniformly over its world area ([`crate::prepare::MeshLight`]).
//!
//! Two strategies, chosen by the same test in [`AreaLight::uses_cone`] whether sampling or
//! evaluating the density, so that MIS weights stay consistent:
//! - **cone**: a sphere whose transform is a similarity (a true sphere in world space),
//!   seen from a point outside it that does not lie on it: directions uniform in the cone
//!   it subtends (pdf 1 / (2π(1 − cos θmax))).
//! - **area**: otherwise (cubes, ellipsoids, points inside or on the light). Spheres: a
//!   point uniform in object space on the unit sphere, mapped to the world; Nanson's formula
//!   gives the world area density `1 / (4π · |det M| · |M⁻ᵀ n_obj|)`. Cubes: see below.
//!   Either is converted to solid angle by `d² / |cos θ_light|`.
//!
//! **Cubes sample the faces the shading point is in front of** ([`CubeFaces`]): a point
//! outside the (parallelepiped) light sees at most one face of each pair, the one on its
//! side of the pair's two planes, and a closed convex light hides every other face behind
//! itself. So a face is chosen among those by world area and a point drawn uniformly on it
//! (density `1 / Σ visible areas`). Uniform sampling over the whole surface wasted about
//! half its samples on hidden faces: on `scenes/cornell.sl`'s flat lamp, the top face
//! against the ceiling, whose shadow rays all ended on the lamp itself. A point inside the
//! light, on it, or within [`CUBE_FACE_MARGIN`] of every pair's planes samples the whole
//! surface uniformly, as before. The density for MIS (`pdf`) applies the same rule from the
//! same point, so it is 0 on the faces sampling skips and the estimate stays unbiased.
//!
//! **Within the chosen face, a rectangular face is sampled by solid angle**
//! ([`AreaLight::solid_angle_face`], [`super::spherical_rectangle`]) when it subtends
//! between [`SOLID_ANGLE_MIN`] and [`SOLID_ANGLE_MAX`] from the point: uniform area
//! sampling's weight d²/(A cos θ) swings by orders of magnitude across a face seen from
//! close by (the ceiling beside `scenes/cornell.sl`'s lamp, lit by its thin side faces, held
//! about 40 % of that image's variance), while drawn by solid angle each sample weighs the
//! face's Ω. The face choice stays by area, so the density of a point y on face k is
//! P(k) / Ω_k there, and P(k)·d²/(A_k cos θ) = d²/(Σ A cos θ) on faces sampled by area.
//! Sheared cubes (parallelogram faces), points sampling both faces of a pair, and faces
//! outside that range of Ω keep area sampling.

use std::f64::consts::PI;

use glam::{DVec2, DVec3};

use crate::color::Color;
use crate::scene::{Pigment, Scene, ShapeKind};

use super::normalize_scaled;
use super::offset::error_scale;
use super::spherical_rectangle::{may_subtend, SphericalRectangle};
use super::warp::{cone_one_minus_cos, uniform_cone, uniform_cone_pdf, uniform_sphere};

pub use crate::prepare::{AreaLight, LightSurface, MeshLight, CUBE_FACE_MARGIN, SOLID_ANGLE_MAX, SOLID_ANGLE_MIN};

/// A point sampled on a light, seen from the shading point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightPoint {
    /// World point on the light.
    pub point: DVec3,
    /// Error scale of `point` (`offset::error_scale`), for offsetting the shadow ray's end.
    pub scale: f64,
    /// Unit geometric normal of the light there (outward in object space).
    pub normal: DVec3,
    /// Object-space point (for the emitted pigment's uv).
    pub object_point: DVec3,
    /// Meshes: the uv there (the file's, else barycentric), which the object point alone
    /// does not give.
    pub uv: Option<DVec2>,
    /// Solid-angle density at the shading point (0: unusable sample).
    pub pdf: f64,
}

impl AreaLight {
    /// Whether directions toward this light are drawn from its cone, for a shading point
    /// `x` lying on shape `x_shape`.
    pub fn uses_cone(&self, x: DVec3, x_shape: u32) -> Option<(DVec3, f64, f64)> {
        let LightSurface::Sphere { round: Some((c, r)), .. } = self.surface else { return None };
        let d = (c - x).length();
        (x_shape != self.shape && d > r).then_some((c, r, d))
    }

    /// Samples a point on the light from shading point `x` (on shape `x_shape`) with the
    /// vertex draws ξ1, ξ2.
    pub fn sample(&self, x: DVec3, x_shape: u32, xi0: f64, xi1: f64) -> LightPoint {
        match self.uses_cone(x, x_shape) {
            Some((c, r, d)) => {
                let (point, normal, pdf) = sample_cone(c, r, d, x, xi0, xi1);
                // point = c + r·normal, so its terms are |c| and r·|normal|.
                let scale = (c.abs() + (r * normal).abs()).max_element();
                LightPoint { point, scale, normal, object_point: self.transform.inverse().point(point), pdf, uv: None }
            }
            None => match &self.surface {
                LightSurface::Mesh(m) => self.sample_mesh(m, x, xi0, xi1),
                LightSurface::Sphere { det, .. } => self.sample_sphere(*det, x, xi0, xi1),
                LightSurface::Cube { .. } => self.sample_cube(x, x_shape, xi0, xi1),
            },
        }
    }

    /// Solid-angle density of [`Self::sample`] producing the point `y` on the light (a
    /// point that a ray from `x` reached, where the light's geometric normal is `n_y`:
    /// meshes need it, the analytic shapes compute theirs).
    pub fn pdf(&self, x: DVec3, x_shape: u32, y: DVec3, n_y: DVec3) -> f64 {
        if let Some((_, r, d)) = self.uses_cone(x, x_shape) {
            return uniform_cone_pdf(cone_one_minus_cos(r, d));
        }
        match &self.surface {
            LightSurface::Mesh(m) => self.mesh_pdf_solid_angle(m, x, y, n_y),
            LightSurface::Sphere { det, .. } => {
                let n_obj = object_normal(ShapeKind::Sphere, self.transform.inverse().point(y));
                self.area_pdf_solid_angle(x, y, n_obj, self.sphere_area(*det, n_obj))
            }
            LightSurface::Cube { .. } => {
                let n_obj = object_normal(ShapeKind::Cube, self.transform.inverse().point(y));
                let faces = self.cube_faces(x, x_shape);
                if !faces.samples(n_obj) {
                    return 0.0;
                }
                let axis = n_obj.abs().max_position();
                match self.solid_angle_face(x, &faces, axis) {
                    Some(rect) => faces.solid_angle_pdf(axis, &rect),
                    None => self.area_pdf_solid_angle(x, y, n_obj, faces.area()),
                }
            }
        }
    }

    /// The face of `axis` that `faces` samples, seen from `x` as a spherical rectangle,
    /// where NEE samples it by solid angle (module documentation): a rectangular face, the
    /// only one of its pair sampled, subtending between [`SOLID_ANGLE_MIN`] and
    /// [`SOLID_ANGLE_MAX`]. `None`: sampled by area (and for a light that is not a cube).
    pub fn solid_angle_face(&self, x: DVec3, faces: &CubeFaces, axis: usize) -> Option<SphericalRectangle> {
        let LightSurface::Cube { rectangular_faces, .. } = self.surface else { return None };
        let side = faces.side[axis];
        if side == 0.0 || !rectangular_faces[axis] {
            return None;
        }
        let (u, v) = face_axes(axis);
        let mut corner = DVec3::splat(-0.5);
        corner[axis] = 0.5 * side;
        let t = &self.transform;
        let (corner, ea, eb) = (t.point(corner), t.vector(DVec3::AXES[u]), t.vector(DVec3::AXES[v]));
        if !may_subtend(x, corner, ea, eb, SOLID_ANGLE_MIN) {
            return None;
        }
        let rect = SphericalRectangle::new(x, corner, ea, eb);
        (SOLID_ANGLE_MIN..=SOLID_ANGLE_MAX).contains(&rect.solid_angle()).then_some(rect)
    }

    /// The cube faces NEE samples from shading point `x` on shape `x_shape` (module
    /// documentation): the ones `x` is in front of, else all; none for a light that is not
    /// a cube.
    pub fn cube_faces(&self, x: DVec3, x_shape: u32) -> CubeFaces {
        let LightSurface::Cube { face_areas, .. } = self.surface else {
            return CubeFaces { weight: [0.0; 3], side: [0.0; 3] };
        };
        if x_shape != self.shape {
            let p = self.transform.inverse().point(x);
            let mut faces = CubeFaces { weight: [0.0; 3], side: [0.0; 3] };
            for axis in 0..3 {
                if p[axis].abs() > 0.5 + CUBE_FACE_MARGIN {
                    faces.weight[axis] = face_areas[axis];
                    faces.side[axis] = p[axis].signum();
                }
            }
            if faces.area() > 0.0 {
                return faces;
            }
        }
        CubeFaces { weight: face_areas.map(|a| 2.0 * a), side: [0.0; 3] }
    }

    /// World area of the unit sphere under the transform (|det| of its linear part: `det`),
    /// by Nanson's formula at `n_obj` (the density of object-uniform points there is its
    /// inverse).
    fn sphere_area(&self, det: f64, n_obj: DVec3) -> f64 {
        4.0 * PI * det * self.transform.normal(n_obj).length()
    }

    /// Radiance the light's material emits at the sampled point (its pigment read at the
    /// point's uv, as a ray hitting it there would see).
    pub fn emission(&self, scene: &Scene, lp: &LightPoint) -> Color {
        let emitted = &scene.material(self.material).emitted;
        if let Pigment::Uniform(c) = emitted {
            return *c;
        }
        // Mesh points carry their uv; the unit shapes' follows from the object point.
        let uv = match (&self.surface, lp.uv) {
            (_, Some(uv)) => uv,
            (LightSurface::Cube { .. }, None) => {
                // Faces are numbered 2·axis + (1 on the + side), as the shapes number them.
                let n = object_normal(ShapeKind::Cube, lp.object_point);
                let axis = n.abs().max_position() as u8;
                let face = 2 * axis + u8::from(n[axis as usize] > 0.0);
                super::shapes::surface(ShapeKind::Cube, lp.object_point, face).uv
            }
            (_, None) => super::shapes::surface(ShapeKind::Sphere, lp.object_point, 0).uv,
        };
        emitted.color_at(uv.x, uv.y)
    }

    /// A triangle by its world-area share (ξ0), a uniform point on it (the rest of ξ0, ξ1).
    fn sample_mesh(&self, m: &MeshLight, x: DVec3, xi0: f64, xi1: f64) -> LightPoint {
        let (t, u) = m.choose(xi0);
        let [p0, p1, p2] = m.mesh.triangle(t);
        let su = u.sqrt();
        let (b0, b1) = (1.0 - su, xi1 * su);
        let b2 = 1.0 - b0 - b1;
        let p_obj = b0 * p0 + b1 * p1 + b2 * p2;
        let y = self.transform.point(p_obj);
        let normal = normalize_scaled(self.transform.normal((p1 - p0).cross(p2 - p0)));
        let [i0, i1, i2] = m.mesh.triangles()[t].map(|i| i as usize);
        let uv = match m.mesh.uvs() {
            Some(uv) => b0 * uv[i0] + b1 * uv[i1] + b2 * uv[i2],
            None => DVec2::new(b1, b2),
        };
        LightPoint {
            point: y,
            scale: error_scale(&self.transform.matrix(), p0.abs().max(p1.abs()).max(p2.abs())),
            normal,
            object_point: p_obj,
            pdf: self.mesh_pdf_solid_angle(m, x, y, normal),
            uv: Some(uv),
        }
    }

    /// 1 / (world area) converted to solid angle at x.
    fn mesh_pdf_solid_angle(&self, m: &MeshLight, x: DVec3, y: DVec3, n: DVec3) -> f64 {
        let to_light = y - x;
        let dist2 = to_light.length_squared();
        let cos_light = normalize_scaled(n).dot(to_light).abs() / dist2.sqrt();
        if !(cos_light > 0.0 && dist2 > 0.0) {
            return 0.0;
        }
        dist2 / (cos_light * m.area)
    }

    /// A point uniform in object space on the unit sphere (area sampling: ellipsoids, and
    /// points inside or on the light).
    fn sample_sphere(&self, det: f64, x: DVec3, xi0: f64, xi1: f64) -> LightPoint {
        let p = uniform_sphere(xi0, xi1);
        let y = self.transform.point(p);
        self.unit_shape_point(p, p, y, self.area_pdf_solid_angle(x, y, p, self.sphere_area(det, p)))
    }

    /// A face by ξ0, then a point on it from the rest of ξ0 and ξ1: by solid angle or by
    /// area (module documentation).
    fn sample_cube(&self, x: DVec3, x_shape: u32, xi0: f64, xi1: f64) -> LightPoint {
        let faces = self.cube_faces(x, x_shape);
        let face = CubeFace::pick(&faces, xi0);
        let rect = self.solid_angle_face(x, &faces, face.axis);
        let (s, t) = rect.map_or((face.u, xi1), |r| r.sample(face.u, xi1));
        let (p, n) = face.point(s, t);
        let y = self.transform.point(p);
        let pdf = match rect {
            Some(r) => faces.solid_angle_pdf(face.axis, &r),
            None => self.area_pdf_solid_angle(x, y, n, faces.area()),
        };
        self.unit_shape_point(p, n, y, pdf)
    }

    /// The sampled point `y` (object point `p_obj`, outward object normal `n_obj`) of a unit
    /// sphere or cube.
    fn unit_shape_point(&self, p_obj: DVec3, n_obj: DVec3, y: DVec3, pdf: f64) -> LightPoint {
        LightPoint {
            point: y,
            scale: error_scale(&self.transform.matrix(), p_obj),
            normal: normalize_scaled(self.transform.normal(n_obj)),
            object_point: p_obj,
            pdf,
            uv: None,
        }
    }

    /// The area density `1 / area` at y (outward object normal `n_obj`) converted to solid
    /// angle at x.
    fn area_pdf_solid_angle(&self, x: DVec3, y: DVec3, n_obj: DVec3, area: f64) -> f64 {
        let n_world = self.transform.normal(n_obj);
        let to_light = y - x;
        let dist2 = to_light.length_squared();
        let cos_light = normalize_scaled(n_world).dot(to_light).abs() / dist2.sqrt();
        if !(cos_light > 0.0 && dist2 > 0.0 && area > 0.0) {
            return 0.0;
        }
        dist2 / (cos_light * area)
    }
}

/// The faces of a cube light that NEE samples from one shading point
/// ([`AreaLight::cube_faces`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CubeFaces {
    /// Per axis, the world area sampled there: one face's, both faces', or 0.
    pub weight: [f64; 3],
    /// Per axis, +1 or −1 where only that side's face is sampled; 0 where both are.
    pub side: [f64; 3],
}

impl CubeFaces {
    /// The world area sampled (the sampling density is its inverse).
    pub fn area(&self) -> f64 {
        self.weight.iter().sum()
    }

    /// The density of a point on the face of `axis` drawn by solid angle from `rect`: the
    /// face's share of the sampled area (the chance of picking it) over its solid angle.
    pub fn solid_angle_pdf(&self, axis: usize, rect: &SphericalRectangle) -> f64 {
        self.weight[axis] / (self.area() * rect.solid_angle())
    }

    /// Whether the face with outward object normal `n_obj` is sampled. n_obj is ±1 on one
    /// axis and 0 on the others, so dot products pick that axis's entries exactly (as
    /// shaders/lights.wgsl `light_pdf` does).
    pub fn samples(&self, n_obj: DVec3) -> bool {
        let axis = n_obj.abs();
        let side = DVec3::from(self.side).dot(axis);
        DVec3::from(self.weight).dot(axis) > 0.0 && (side == 0.0 || side == n_obj.element_sum())
    }
}

/// Unit outward normal of the unit sphere or cube at (or near) object point `p`.
pub fn object_normal(kind: ShapeKind, p: DVec3) -> DVec3 {
    match kind {
        ShapeKind::Sphere => p.normalize(),
        _ => {
            let a = p.abs();
            if a.x >= a.y && a.x >= a.z {
                DVec3::new(p.x.signum(), 0.0, 0.0)
            } else if a.y >= a.z {
                DVec3::new(0.0, p.y.signum(), 0.0)
            } else {
                DVec3::new(0.0, 0.0, p.z.signum())
            }
        }
    }
}

/// The (u, v) axes of a face of `axis`: its point is (s − 0.5, t − 0.5) on them, s along
/// the next axis and t along the one after (x: (y, z), y: (z, x), z: (x, y)).
fn face_axes(axis: usize) -> (usize, usize) {
    ((axis + 1) % 3, (axis + 2) % 3)
}

/// The face of the unit cube [−0.5, 0.5]³ that NEE samples, picked from ξ0.
#[derive(Debug, Clone, Copy, PartialEq)]
struct CubeFace {
    axis: usize,
    /// +1 or −1: which face of the pair.
    side: f64,
    /// The rest of ξ0, uniform in [0, 1) within the face: its first coordinate.
    u: f64,
}

impl CubeFace {
    /// The axis by ξ0 against the faces' weights, then the side (where both are sampled)
    /// and the face's first coordinate from the rest of ξ0: uniform over the sampled area
    /// when the second coordinate is uniform too.
    fn pick(faces: &CubeFaces, xi0: f64) -> Self {
        let w = faces.weight;
        let u = xi0 * faces.area();
        // An axis of weight 0 is never chosen, even where rounding puts u at the end.
        let axis = if u < w[0] || (w[1] == 0.0 && w[2] == 0.0) {
            0
        } else if u < w[0] + w[1] || w[2] == 0.0 {
            1
        } else {
            2
        };
        let lo: f64 = w[..axis].iter().sum();
        let v = ((u - lo) / w[axis]).clamp(0.0, 1.0 - f64::EPSILON / 2.0);
        if faces.side[axis] == 0.0 {
            // Both faces: v rescaled to [0, 2) gives the side (0: +, 1: −), then a coordinate.
            let v2 = 2.0 * v;
            let side = v2.floor();
            Self { axis, side: if side == 0.0 { 1.0 } else { -1.0 }, u: v2 - side }
        } else {
            Self { axis, side: faces.side[axis], u: v }
        }
    }

    /// The object point at fractions (s, t) of the face (`face_axes`), and the outward
    /// normal (unnormalised).
    fn point(&self, s: f64, t: f64) -> (DVec3, DVec3) {
        let (u, v) = face_axes(self.axis);
        let (mut p, mut n) = (DVec3::ZERO, DVec3::ZERO);
        p[self.axis] = 0.5 * self.side;
        p[u] = s - 0.5;
        p[v] = t - 0.5;
        n[self.axis] = self.side;
        (p, n)
    }
}

/// A point uniform over the sampled faces of the cube (the area sampling of
/// [`AreaLight::sample`] when no face is sampled by solid angle). Returns (point, outward
/// normal).
#[cfg(test)]
fn sample_cube_surface(faces: &CubeFaces, xi0: f64, xi1: f64) -> (DVec3, DVec3) {
    let face = CubeFace::pick(faces, xi0);
    face.point(face.u, xi1)
}

/// Cone sampling of the sphere (centre c, radius r, at distance d > r from x): a direction
/// in the subtended cone, then the point where it first meets the sphere, found from the
/// angle α at the centre without a ray–sphere intersection (robust for tiny spheres).
fn sample_cone(c: DVec3, r: f64, d: f64, x: DVec3, xi0: f64, xi1: f64) -> (DVec3, DVec3, f64) {
    let omc_max = cone_one_minus_cos(r, d);
    let (local, cos_theta) = uniform_cone(xi0, xi1, omc_max);
    let sin2_theta = local.x * local.x + local.y * local.y;
    let sin_theta_max = r / d;
    // Law of sines in the triangle (x, c, y): cos α = sin²θ/sinθmax + cosθ·√(1 − sin²θ/sin²θmax).
    let cos_alpha =
        sin2_theta / sin_theta_max + cos_theta * (1.0 - sin2_theta / (sin_theta_max * sin_theta_max)).max(0.0).sqrt();
    let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
    let w = (c - x) / d;
    let (t, b) = super::onb(w);
    let sin_theta = sin2_theta.sqrt();
    // e: the unit sideways direction of the sampled ray; y − c leans the same way.
    let e = if sin_theta > 0.0 { (t * local.x + b * local.y) / sin_theta } else { t };
    let normal = (e * sin_alpha - w * cos_alpha).normalize();
    let point = c + r * normal;
    (point, normal, uniform_cone_pdf(omc_max))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Pcg32;
    use crate::scene::{Material, SceneBuilder, Shape, Transform};

    use crate::color::Color;

    fn scene_with(kind: ShapeKind, t: Transform) -> Scene {
        let mut b = SceneBuilder::new(4, 4);
        let m = b.material(Material::new(
            crate::scene::Brdf::default(),
            crate::scene::Pigment::Uniform(crate::color::Color::WHITE),
        ));
        b.shape(Shape::primitive(kind, t, m));
        b.build().unwrap()
    }

    /// Monte Carlo estimate of the solid angle of the light's visible (front-facing) part:
    /// E[visible / pdf] = Ω. Also checks that `pdf` agrees with the sample's density.
    /// `force_area`: a sphere light sampled by area where it would use its cone.
    fn solid_angle_estimate(light: &AreaLight, x: DVec3, force_area: bool, n: usize) -> f64 {
        let mut rng = Pcg32::new(3, 5);
        let mut sum = 0.0;
        for _ in 0..n {
            let (a, b) = (rng.next_f64(), rng.next_f64());
            let s = match light.surface {
                LightSurface::Sphere { det, .. } if force_area => light.sample_sphere(det, x, a, b),
                _ => light.sample(x, u32::MAX, a, b),
            };
            if s.pdf <= 0.0 {
                continue;
            }
            if !force_area {
                let back = light.pdf(x, u32::MAX, s.point, s.normal);
                assert!((back / s.pdf - 1.0).abs() < 1e-9, "{back} vs {}", s.pdf);
            }
            if (s.point - x).dot(s.normal) < 0.0 {
                sum += 1.0 / s.pdf;
            }
        }
        sum / n as f64
    }

    /// An emissive mesh (a unit square of two triangles, stretched 3 × 1): area sampling
    /// measures its solid angle (Σ 1/pdf of front-facing samples, which only a density
    /// uniform over the world area makes exact), and the pdf reads back.
    #[test]
    fn mesh_lights_are_sampled_uniformly_over_their_world_area() {
        let parts = crate::scene::MeshParts {
            positions: vec![
                DVec3::new(0.0, -0.5, -0.5),
                DVec3::new(0.0, 0.5, -0.5),
                DVec3::new(0.0, 0.5, 0.5),
                DVec3::new(0.0, -0.5, 0.5),
            ],
            normals: None,
            uvs: None,
            triangles: vec![[0, 2, 1], [0, 3, 2]],
            dropped_faces: 0,
        };
        let mesh = std::sync::Arc::new(crate::scene::TriangleMesh::from_parts("panel", parts).unwrap());
        let mut b = SceneBuilder::new(4, 4);
        let lamp = b.material(Material::new(crate::scene::Brdf::default(), Pigment::Uniform(Color::WHITE)));
        let t = Transform::translation(DVec3::new(2.0, 0.0, 0.0)) * Transform::scaling(DVec3::new(1.0, 3.0, 1.0));
        b.shape(Shape::mesh(mesh, "panel", t, lamp, false));
        let scene = b.build().unwrap();
        let light = AreaLight::new(&scene, 0).unwrap();
        let LightSurface::Mesh(m) = &light.surface else { panic!("{light:?}") };
        assert!((m.area - 3.0).abs() < 1e-12);
        let x = DVec3::ZERO;
        let estimate = solid_angle_estimate(&light, x, false, 200_000);
        // A centred rectangle of half-sides a, b at distance d subtends 4 atan(ab / (d√(a²+b²+d²))).
        let (a, bb, d) = (1.5f64, 0.5f64, 2.0f64);
        let exact = 4.0 * (a * bb / (d * (a * a + bb * bb + d * d).sqrt())).atan();
        assert!((estimate / exact - 1.0).abs() < 0.01, "{estimate} vs {exact}");
    }

    #[test]
    fn sphere_cone_and_area_sampling_measure_the_same_solid_angle() {
        let t = Transform::translation(DVec3::new(1.0, 2.0, 3.0)) * Transform::scaling(DVec3::splat(0.5));
        let scene = scene_with(ShapeKind::Sphere, t);
        let light = AreaLight::new(&scene, 0).unwrap();
        let LightSurface::Sphere { round: Some((c, r)), .. } = light.surface else { panic!("{light:?}") };
        assert!((r - 0.5).abs() < 1e-15);
        let x = c + DVec3::new(0.0, 1.5, 0.2);
        let omega = 2.0 * PI * cone_one_minus_cos(r, (c - x).length());
        // Cone: every sample is on the near side and 1/pdf is Ω exactly.
        let cone = solid_angle_estimate(&light, x, false, 2000);
        assert!((cone / omega - 1.0).abs() < 1e-12);
        // Area sampling (uniform on the sphere): relative std ≈ 1 per sample; 4e5 samples.
        let area = solid_angle_estimate(&light, x, true, 400_000);
        assert!((area / omega - 1.0).abs() < 0.01, "{area} vs {omega}");
    }

    #[test]
    fn cone_points_lie_on_the_near_side_within_the_cone() {
        let scene = scene_with(ShapeKind::Sphere, Transform::scaling(DVec3::splat(2.0)));
        let light = AreaLight::new(&scene, 0).unwrap();
        let x = DVec3::new(0.0, 0.0, 5.0);
        let omc = cone_one_minus_cos(2.0, 5.0);
        let mut rng = Pcg32::new(9, 9);
        let mut inner = 0;
        let n = 20_000;
        for _ in 0..n {
            let s = light.sample(x, u32::MAX, rng.next_f64(), rng.next_f64());
            assert!((s.point.length() - 2.0).abs() < 1e-12);
            assert!((s.normal - s.point / 2.0).length() < 1e-12);
            let dir = (s.point - x).normalize();
            let one_minus_cos = 1.0 + dir.z;
            assert!(one_minus_cos <= omc * (1.0 + 1e-9));
            // Near side: nothing of the sphere lies between x and the point.
            assert!((s.point - x).dot(s.normal) < 0.0);
            if one_minus_cos < omc / 2.0 {
                inner += 1;
            }
        }
        // Uniform in the cone: half the solid angle lies within 1 − cos < (1 − cos θmax)/2.
        let frac = inner as f64 / n as f64;
        assert!((frac - 0.5).abs() < 5.0 * (0.25 / n as f64).sqrt(), "{frac}");
    }

    #[test]
    fn stretched_cube_area_sampling_measures_its_face() {
        // A cube scaled to 2 × 0.5 × 1, seen from a point on its +z axis: only the top
        // face (2 × 0.5 at height h above it) is visible.
        let t = Transform::scaling(DVec3::new(2.0, 0.5, 1.0));
        let scene = scene_with(ShapeKind::Cube, t);
        let light = AreaLight::new(&scene, 0).unwrap();
        assert!(matches!(light.surface, LightSurface::Cube { .. }));
        let h = 0.7;
        let x = DVec3::new(0.0, 0.0, 0.5 + h);
        let (a, b) = (2.0f64, 0.5f64);
        let omega = 4.0 * (a * b / (2.0 * h * (4.0 * h * h + a * a + b * b).sqrt())).atan();
        let est = solid_angle_estimate(&light, x, false, 400_000);
        assert!((est / omega - 1.0).abs() < 0.02, "{est} vs {omega}");
    }

    /// From inside the light (or on it), cube samples are uniform over the world surface:
    /// each face gets its area's share (a flat 1 × 1 × 0.02 panel: the two broad faces
    /// 1/1.04 of them), and the density is 1 / area on every face.
    #[test]
    fn cube_faces_are_chosen_by_world_area() {
        let t = Transform::rotation_z(30.0) * Transform::scaling(DVec3::new(1.0, 1.0, 0.02));
        let scene = scene_with(ShapeKind::Cube, t);
        let light = AreaLight::new(&scene, 0).unwrap();
        let LightSurface::Cube { face_areas, .. } = light.surface else { panic!("{light:?}") };
        let area = 2.0 * face_areas.iter().sum::<f64>();
        assert!((area - 2.08).abs() < 1e-12, "{area}");
        let inside = light.transform.point(DVec3::new(0.1, -0.2, 0.3));
        let on = light.transform.point(DVec3::new(0.1, -0.2, 0.5));
        for (x, x_shape) in [(inside, u32::MAX), (on, light.shape)] {
            let faces = light.cube_faces(x, x_shape);
            assert_eq!(faces.side, [0.0; 3]);
            assert!((faces.area() - area).abs() < 1e-12);
        }
        let faces = light.cube_faces(inside, u32::MAX);
        let mut rng = Pcg32::new(1, 2);
        let (n, mut broad, mut top) = (100_000, 0, 0);
        for _ in 0..n {
            let (p_obj, n_obj) = sample_cube_surface(&faces, rng.next_f64(), rng.next_f64());
            assert!(p_obj.abs().max_element() <= 0.5 + 1e-15 && (p_obj.abs().max_element() - 0.5).abs() < 1e-15);
            assert_eq!(object_normal(ShapeKind::Cube, p_obj), n_obj.normalize());
            broad += usize::from(n_obj.z != 0.0);
            top += usize::from(n_obj.z > 0.0);
        }
        let share = broad as f64 / f64::from(n);
        let expected = 2.0 / 2.08;
        assert!((share - expected).abs() < 5.0 * (expected * (1.0 - expected) / f64::from(n)).sqrt(), "{share}");
        let half = top as f64 / broad as f64;
        assert!((half - 0.5).abs() < 5.0 * (0.25 / broad as f64).sqrt(), "{half}");
        // The density at x of a point y, times d²/cos, is 1/area whichever face y is on.
        let x = DVec3::new(0.3, -2.0, 1.5);
        for (p_obj, n_obj) in [(DVec3::new(0.1, 0.2, 0.5), DVec3::Z), (DVec3::new(-0.5, 0.1, 0.0), DVec3::NEG_X)] {
            let y = light.transform.point(p_obj);
            let nw = light.transform.normal(n_obj).normalize();
            let d = y - x;
            let expect = d.length_squared() / (nw.dot(d).abs() / d.length() * area);
            assert!((light.area_pdf_solid_angle(x, y, n_obj, area) / expect - 1.0).abs() < 1e-12);
        }
    }

    /// From outside, only the faces the point is in front of are sampled (the panel lamp
    /// of scenes/cornell.sl seen from below: its bottom face, and a side face where the
    /// point lies beyond that side), each by world area; the density is 1 / (their area)
    /// there and 0 on the other faces, read back by `pdf` for every sample.
    #[test]
    fn cube_lights_sample_only_the_faces_in_front_of_the_point() {
        let t = Transform::translation(DVec3::new(1.0, 0.0, 1.99))
            * Transform::rotation_z(10.0)
            * Transform::scaling(DVec3::new(0.5, 0.4, 0.02));
        let scene = scene_with(ShapeKind::Cube, t);
        let light = AreaLight::new(&scene, 0).unwrap();
        let to_object = light.transform.inverse();
        // Below the lamp's middle: the bottom face only.
        let below = DVec3::new(1.02, 0.05, 1.2);
        let faces = light.cube_faces(below, u32::MAX);
        assert_eq!(faces.side, [0.0, 0.0, -1.0]);
        let LightSurface::Cube { face_areas, .. } = light.surface else { panic!("{light:?}") };
        assert!((faces.area() - face_areas[2]).abs() < 1e-15);
        assert!((face_areas[2] - 0.2).abs() < 1e-12);
        // Below and to the side: the bottom face and the side facing the point.
        let aside = DVec3::new(1.8, -0.9, 0.5);
        let faces = light.cube_faces(aside, u32::MAX);
        let p = to_object.point(aside);
        assert_eq!(faces.side, [p.x.signum(), p.y.signum(), -1.0]);
        let mut by_solid_angle = [0, 0];
        for x in [below, aside] {
            let faces = light.cube_faces(x, u32::MAX);
            let mut rng = Pcg32::new(5, 6);
            for _ in 0..2000 {
                let s = light.sample(x, u32::MAX, rng.next_f64(), rng.next_f64());
                assert!(s.pdf > 0.0);
                // The sampled face faces x: x lies on the outer side of its plane.
                assert!((x - s.point).dot(s.normal) > 0.0, "{x} {}", s.point);
                let n_obj = object_normal(ShapeKind::Cube, s.object_point);
                assert!(faces.samples(n_obj));
                // The face's share of the area, then 1/Ω on it or 1/area there.
                let axis = n_obj.abs().max_position();
                let d = s.point - x;
                let expect = match light.solid_angle_face(x, &faces, axis) {
                    Some(r) => {
                        by_solid_angle[usize::from(axis != 2)] += 1;
                        faces.weight[axis] / faces.area() / r.solid_angle()
                    }
                    None => d.length_squared() / (s.normal.dot(d).abs() / d.length() * faces.area()),
                };
                assert!((s.pdf / expect - 1.0).abs() < 1e-9);
                assert!((light.pdf(x, u32::MAX, s.point, s.normal) / s.pdf - 1.0).abs() < 1e-12);
            }
            // The top face is never sampled from below, so its density is 0.
            let top = light.transform.point(DVec3::new(0.1, 0.1, 0.5));
            assert_eq!(light.pdf(x, u32::MAX, top, light.transform.normal(DVec3::Z)), 0.0);
        }
        // From 0.8 below the lamp's middle, every sample is on the broad bottom face
        // (Ω ≈ 0.3) and drawn by solid angle; from aside, farther and at a slant, every face
        // subtends less than SOLID_ANGLE_MIN (the bottom one about 0.04) and is sampled by
        // area.
        assert_eq!(by_solid_angle, [2000, 0]);
        // A point on the plane of the top face (the ceiling the lamp touches), within the
        // margin, is in front of no face of the z pair: rounding cannot pick the top face.
        let ceiling = light.transform.point(DVec3::new(3.0, 0.2, 0.5 + CUBE_FACE_MARGIN / 2.0));
        let faces = light.cube_faces(ceiling, u32::MAX);
        assert_eq!((faces.weight[2], faces.side[0]), (0.0, 1.0));
    }

    /// Sampling only the visible faces measures the same solid angle as sampling the whole
    /// surface (the estimate of the visible solid angle Σ 1/pdf is unbiased either way).
    #[test]
    fn cube_visible_face_sampling_measures_the_visible_solid_angle() {
        let t =
            Transform::rotation_z(25.0) * Transform::rotation_x(15.0) * Transform::scaling(DVec3::new(1.0, 0.6, 0.3));
        let scene = scene_with(ShapeKind::Cube, t);
        let light = AreaLight::new(&scene, 0).unwrap();
        let x = DVec3::new(1.3, -1.1, 0.9);
        assert!(light.cube_faces(x, u32::MAX).side.iter().all(|&s| s != 0.0));
        let visible = solid_angle_estimate(&light, x, false, 200_000);
        // The whole surface, uniformly: the estimator of before, from a point inside.
        let mut rng = Pcg32::new(8, 9);
        let everything = light.cube_faces(DVec3::ZERO, u32::MAX);
        let n = 400_000;
        let mut sum = 0.0;
        for _ in 0..n {
            let (p_obj, n_obj) = sample_cube_surface(&everything, rng.next_f64(), rng.next_f64());
            let y = light.transform.point(p_obj);
            let normal = light.transform.normal(n_obj).normalize();
            if (y - x).dot(normal) < 0.0 {
                sum += 1.0 / light.area_pdf_solid_angle(x, y, n_obj, everything.area());
            }
        }
        let uniform = sum / f64::from(n);
        assert!((visible / uniform - 1.0).abs() < 0.01, "{visible} vs {uniform}");
    }

    #[test]
    fn sampled_emission_matches_what_a_ray_sees_there() {
        // Checkered emitters: the colour at a sampled point must be the one a ray hitting
        // that point reads through the hit's uv (face numbering and uv agree).
        let mut b = SceneBuilder::new(4, 4);
        let check = Pigment::Checkered { n: 3, on: Color::new(1.0, 2.0, 3.0), off: Color::new(0.5, 0.0, 0.0) };
        let m = b.material(Material::new(crate::scene::Brdf::default(), check));
        b.cube(Transform::rotation_z(20.0) * Transform::scaling(DVec3::new(1.0, 2.0, 0.5)), m)
            .sphere(Transform::translation(DVec3::new(0.0, 0.0, 3.0)) * Transform::rotation_x(30.0), m);
        let scene = b.build().unwrap();
        let world = super::super::World::new(&scene);
        let x = DVec3::new(2.5, -1.5, 1.5);
        let mut rng = Pcg32::new(21, 22);
        let mut checked = 0;
        for shape in 0..2 {
            let light = AreaLight::new(&scene, shape).unwrap();
            for _ in 0..2000 {
                let s = light.sample(x, u32::MAX, rng.next_f64(), rng.next_f64());
                let ray = super::super::Ray::new(x, s.point - x, 0.0, 1.0 + 1e-9);
                let Some(hit) = world.intersect(&ray) else { continue };
                if (hit.surface.point - s.point).length() > 1e-9 {
                    continue; // the sample is hidden behind the shape's near side
                }
                assert_eq!(hit.shape as usize, shape);
                let seen = scene.material(hit.material).emitted.color_at(hit.surface.uv.x, hit.surface.uv.y);
                assert_eq!(light.emission(&scene, &s), seen, "at {}", s.point);
                checked += 1;
            }
        }
        assert!(checked > 1000, "{checked}");
    }

    #[test]
    fn ellipsoids_use_area_sampling_and_points_on_the_light_too() {
        let scene = scene_with(ShapeKind::Sphere, Transform::scaling(DVec3::new(1.0, 2.0, 1.0)));
        let light = AreaLight::new(&scene, 0).unwrap();
        assert!(matches!(light.surface, LightSurface::Sphere { round: None, det } if (det - 2.0).abs() < 1e-15));
        let scene = scene_with(ShapeKind::Sphere, Transform::rotation_x(30.0));
        let light = AreaLight::new(&scene, 0).unwrap();
        assert!(light.uses_cone(DVec3::new(3.0, 0.0, 0.0), 7).is_some());
        assert!(light.uses_cone(DVec3::new(3.0, 0.0, 0.0), 0).is_none());
        assert!(light.uses_cone(DVec3::new(0.5, 0.0, 0.0), 7).is_none());
    }
}
