//! Whether the kernels walk the scene's BVH or test its finite objects as a list.
//!
//! A BVH walk makes every lane of a SIMD group fetch its own nodes and objects (a gather, or
//! on llvmpipe one scalar load per lane and word) and branch its own way; a list visits the
//! objects in the same order in every lane, so each object's words are loaded once for the
//! whole group and only the code of the object's own shape kind runs. Measured on lavapipe
//! (BENCHMARKS.md "Object list", `lumen bench --shaders`), the list is faster up to about
//! eight objects whatever their layout (a room whose walls' boxes overlap and spheres
//! spread over a floor alike); beyond, it lost in most measurements (spheres on a floor from
//! ten, materials.sl's fifteen, streetlamp.sl's ten) though a cloud of spheres under a sky
//! still gained up to twelve. The surface-area heuristic's expected
//! work did not separate the winners from the losers better than the count did, so the count
//! decides (DESIGN.md "Object list").

use super::features::FeatureSet;

/// Most finite top-level objects a list may hold.
pub const MAX_LIST_OBJECTS: u32 = 8;

/// True when the kernels for a scene with features `f` and `finite` finite top-level objects
/// should test those objects as a list rather than walk the BVH: 1 to [`MAX_LIST_OBJECTS`]
/// objects, none of them a mesh.
///
/// A mesh instance's test is a walk of its own bottom-level BVH, which the top-level walk
/// skips whenever the ray misses the instance's box (measured: a tie at best). A CSG tree in
/// a list goes to the CSG stage only when the ray crosses the tree's own box
/// (`layout::CsgTree::min`/`max`), as a walk hands on only the trees whose leaf it reaches.
///
/// ```
/// use lumen::gpu::features::FeatureSet;
/// use lumen::gpu::traversal::prefers_list;
/// let spheres = FeatureSet { sphere: true, bvh: true, ..FeatureSet::default() };
/// assert!(prefers_list(&spheres, 8));
/// assert!(!prefers_list(&spheres, 9));
/// assert!(prefers_list(&FeatureSet { csg: true, ..spheres }, 2));
/// assert!(!prefers_list(&FeatureSet { mesh: true, ..spheres }, 2));
/// ```
pub fn prefers_list(f: &FeatureSet, finite: u32) -> bool {
    (1..=MAX_LIST_OBJECTS).contains(&finite) && !f.mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_hold_a_handful_of_plain_objects() {
        let plain =
            FeatureSet { sphere: true, cube: true, cylinder: true, plane: true, bvh: true, ..Default::default() };
        assert!(!prefers_list(&plain, 0), "planes only: nothing to list");
        assert!((1..=8).all(|n| prefers_list(&plain, n)));
        assert!(!prefers_list(&plain, 9) && !prefers_list(&plain, 10_000));
        assert!(!prefers_list(&FeatureSet { mesh: true, ..plain }, 3));
        assert!(prefers_list(&FeatureSet { csg: true, ..plain }, 3));
    }
}
