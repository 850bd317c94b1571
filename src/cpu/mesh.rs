//! A placed triangle mesh for ray queries: the ray moves into object space (t is the same
//! there: the direction is transformed without normalising), descends the mesh's
//! bottom-level BVH and meets triangles with the watertight test of `accel::triangle`.

use std::sync::Arc;

use glam::{DVec2, DVec3};

use super::offset::error_scale;
use super::shapes::SurfaceHit;
use super::{normalize_scaled, Ray};
use crate::accel::{Bvh, ShearedRay, Visit};
use crate::scene::{MaterialId, MeshInstance, Transform, TriangleMesh};

/// A mesh instance with its BVH.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshObject {
    /// The triangles in object space, shared with every other instance of the mesh.
    pub mesh: Arc<TriangleMesh>,
    /// Bottom-level BVH over `mesh`'s triangles in object space (ids index its triangles).
    pub bvh: Arc<Bvh>,
    /// Object-to-world transformation of this instance.
    pub to_world: Transform,
    /// Material of every triangle of the instance.
    pub material: MaterialId,
    /// Shade with the mesh's interpolated vertex normals (`MeshInstance::shades_smooth`).
    pub smooth: bool,
}

/// Where a ray meets the mesh: t, the triangle and the barycentric weights of its vertices.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshCrossing {
    /// Ray parameter of the crossing (the same in object and world space).
    pub t: f64,
    /// Index of the triangle in `TriangleMesh::triangles`.
    pub triangle: u32,
    /// Barycentric weights of the triangle's three vertices, in the mesh's vertex order.
    pub b: [f64; 3],
}

impl MeshObject {
    /// Instance `m` for ray queries, with `bvh` the BVH of `m.mesh` (`prepare::mesh_bvh`).
    pub fn new(m: &MeshInstance, bvh: Arc<Bvh>) -> Self {
        Self { mesh: m.mesh.clone(), bvh, to_world: m.transform, material: m.material, smooth: m.shades_smooth() }
    }

    fn local_ray(&self, ray: &Ray) -> (DVec3, DVec3) {
        let inv = self.to_world.inverse_matrix();
        (inv.transform_point3(ray.origin), inv.transform_vector3(ray.dir))
    }

    /// The closest crossing with t in the open range (tmin, tmax).
    pub fn closest(&self, ray: &Ray) -> Option<MeshCrossing> {
        let (o, d) = self.local_ray(ray);
        let sheared = ShearedRay::new(o, d);
        let mut best = None;
        let mut tmax = ray.tmax;
        self.bvh.traverse(o, d, ray.tmin, ray.tmax, |id| {
            let [p0, p1, p2] = self.mesh.triangle(id as usize);
            match sheared.intersect(p0, p1, p2, tmax) {
                Some(h) if h.t > ray.tmin => {
                    tmax = h.t;
                    best = Some(MeshCrossing { t: h.t, triangle: id, b: [h.b0, h.b1, h.b2] });
                    Visit::Closer(h.t)
                }
                _ => Visit::Continue,
            }
        });
        best
    }

    /// Whether some triangle lies on the ray with t in (tmin, tmax).
    pub fn occludes(&self, ray: &Ray) -> bool {
        let (o, d) = self.local_ray(ray);
        let sheared = ShearedRay::new(o, d);
        let mut hit = false;
        self.bvh.traverse(o, d, ray.tmin, ray.tmax, |id| {
            let [p0, p1, p2] = self.mesh.triangle(id as usize);
            if sheared.intersect(p0, p1, p2, ray.tmax).is_some_and(|h| h.t > ray.tmin) {
                hit = true;
                return Visit::Stop;
            }
            Visit::Continue
        });
        hit
    }

    /// The surface record at `c`: the point from the barycentric weights (in object space,
    /// then transformed), the geometric normal of the facet (it decides the side, offsets and
    /// front/back: the winding's normal is the outside), the shading normal (the file's
    /// vertex normals interpolated when smooth, turned to the geometric normal's side), and
    /// uv (the file's, else the barycentric (b1, b2)).
    pub fn surface_hit(&self, ray: &Ray, c: MeshCrossing) -> SurfaceHit {
        let [i0, i1, i2] = self.mesh.triangles()[c.triangle as usize].map(|i| i as usize);
        let [p0, p1, p2] = self.mesh.triangle(c.triangle as usize);
        let [b0, b1, b2] = c.b;
        let p_obj = b0 * p0 + b1 * p1 + b2 * p2;
        let point = self.to_world.point(p_obj);
        // The point is a weighted mean of the vertices: its error is a few ulps of theirs.
        let scale = error_scale(&self.to_world.matrix(), p0.abs().max(p1.abs()).max(p2.abs()));
        let outward = normalize_scaled(self.to_world.normal((p1 - p0).cross(p2 - p0)));
        let front_face = outward.dot(ray.dir) < 0.0;
        let geometric = if front_face { outward } else { -outward };
        let normal = match (self.smooth, self.mesh.normals()) {
            (true, Some(n)) => {
                let s = normalize_scaled(self.to_world.normal(b0 * n[i0] + b1 * n[i1] + b2 * n[i2]));
                if s.is_finite() && s != DVec3::ZERO {
                    if s.dot(geometric) < 0.0 {
                        -s
                    } else {
                        s
                    }
                } else {
                    geometric
                }
            }
            _ => geometric,
        };
        let uv = match self.mesh.uvs() {
            Some(uv) => b0 * uv[i0] + b1 * uv[i1] + b2 * uv[i2],
            None => DVec2::new(b1, b2),
        };
        SurfaceHit { point, scale, normal, geometric, front_face, uv }
    }
}
