//! Bottom-level BVHs: one binned-SAH BVH per distinct triangle mesh, over its triangles in
//! object space, shared by every instance of the mesh (the top-level BVH holds instances
//! by their world bounds). Both renderers traverse the same nodes.

use std::collections::HashMap;
use std::sync::Arc;

use rayon::prelude::*;

use crate::accel::{Bvh, BvhItem};
use crate::scene::{Aabb, Shape, TriangleMesh};

/// The BVH over `mesh`'s triangles (ids index `TriangleMesh::triangles`).
pub fn mesh_bvh(mesh: &TriangleMesh) -> Bvh {
    let items: Vec<BvhItem> = (0..mesh.triangle_count())
        .into_par_iter()
        .map(|i| {
            let [a, b, c] = mesh.triangle(i);
            BvhItem { id: i as u32, bounds: Aabb::new(a.min(b).min(c), a.max(b).max(c)) }
        })
        .collect();
    Bvh::build(&items)
}

/// The bottom-level BVHs of a scene's meshes, each built once however many instances share
/// its mesh (keyed by the mesh's `Arc`).
#[derive(Debug, Clone, Default)]
pub struct MeshBvhs {
    /// By the address of the mesh's `Arc` allocation (identity, not contents).
    by_mesh: HashMap<usize, Arc<Bvh>>,
    /// The distinct meshes, in order of first use.
    pub meshes: Vec<Arc<TriangleMesh>>,
}

fn key(mesh: &Arc<TriangleMesh>) -> usize {
    Arc::as_ptr(mesh) as usize
}

impl MeshBvhs {
    /// The BVHs of the meshes of the top-level `shapes`, built in parallel, one per distinct
    /// mesh allocation.
    pub fn of(shapes: &[Shape]) -> Self {
        let mut out = Self::default();
        for s in shapes {
            if let Shape::Mesh(m) = s {
                if let std::collections::hash_map::Entry::Vacant(e) = out.by_mesh.entry(key(&m.mesh)) {
                    e.insert(Arc::new(Bvh::default()));
                    out.meshes.push(m.mesh.clone());
                }
            }
        }
        let built: Vec<Bvh> = out.meshes.par_iter().map(|m| mesh_bvh(m)).collect();
        for (m, bvh) in out.meshes.iter().zip(built) {
            out.by_mesh.insert(key(m), Arc::new(bvh));
        }
        out
    }

    /// The BVH of `mesh` (one of the scene's).
    pub fn get(&self, mesh: &Arc<TriangleMesh>) -> Option<&Arc<Bvh>> {
        self.by_mesh.get(&key(mesh))
    }

    /// Index of `mesh` in [`Self::meshes`].
    pub fn index(&self, mesh: &Arc<TriangleMesh>) -> Option<usize> {
        self.meshes.iter().position(|m| Arc::ptr_eq(m, mesh))
    }
}
