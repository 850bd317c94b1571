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
use super::layout;
use std::fmt::Write as _;

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

/// Most entries a kernel tests one after another under constant indices ([`Unrolled`]): a
/// list (eight objects when [`prefers_list`] chooses it; measurements force up to sixteen)
/// or the planes' list.
pub const UNROLLED_MAX: usize = 16;

/// The entries of a list the kernels test in turn (the finite objects of an object list,
/// or the unbounded list of planes and unbounded CSG trees), written into the kernels as
/// constants: one test per entry, unrolled ([`unrolled_wgsl`]).
///
/// Why constants: Mesa 25's llvmpipe loads a uniform-buffer word once for the whole SIMD
/// group only when its offset is built from constants and push constants alone
/// (`nir_src_is_always_uniform`); an index from a loop counter or from a table is loaded
/// lane by lane (four loads, three inserts and a bounds clamp per word), although every
/// lane holds the same value. A listed cube's test spent most of its time in those loads.
/// With the object's reference and shape kind as constants, its record is a scalar load
/// per word and only its own kind's code is compiled at that place. The kernel's size is
/// bounded by [`UNROLLED_MAX`] entries; the records themselves stay in the tables, so a
/// scene whose objects move (animation frames) keeps its kernels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Unrolled {
    len: u8,
    /// Object references as `layout` packs them (a shape index, or `CSG_NODE_BIT` | tree).
    refs: [u32; UNROLLED_MAX],
    /// The shape kind (`layout::shape_kind`) of each shape entry; unused for CSG trees.
    kinds: [u32; UNROLLED_MAX],
}

/// One entry of an [`Unrolled`] list.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UnrolledEntry {
    /// Shape `index` of kind `kind` (`layout::shape_kind`).
    Shape {
        /// The shape's index in `shapes` (its object reference).
        index: u32,
        /// Its `layout::shape_kind`.
        kind: u32,
    },
    /// A CSG tree, by its reference (`CSG_NODE_BIT` | tree index).
    Csg(u32),
}

impl Unrolled {
    /// The list of object references `refs` (into `shapes`, the packed shape table) in
    /// ascending order, or `None` beyond [`UNROLLED_MAX`] entries or for a reference beyond
    /// the table.
    ///
    /// ```
    /// use lumen::gpu::layout::{shape_kind, CSG_NODE_BIT};
    /// use lumen::gpu::traversal::{Unrolled, UnrolledEntry};
    /// let mut cube: lumen::gpu::layout::Shape = bytemuck::Zeroable::zeroed();
    /// cube.kind = shape_kind::CUBE;
    /// let list = Unrolled::of(&[CSG_NODE_BIT | 3, 0], &[cube]).unwrap();
    /// let entries: Vec<_> = list.entries().collect();
    /// assert_eq!(entries, [UnrolledEntry::Shape { index: 0, kind: shape_kind::CUBE }, UnrolledEntry::Csg(CSG_NODE_BIT | 3)]);
    /// assert!(Unrolled::of(&[0; 17], &[cube]).is_none());
    /// ```
    pub fn of(refs: &[u32], shapes: &[layout::Shape]) -> Option<Self> {
        if refs.len() > UNROLLED_MAX {
            return None;
        }
        // In reference order: the BVH's leaf order changes as objects move, and with it the
        // kernel's text (the nearest hit does not depend on the order).
        let mut sorted = refs.to_vec();
        sorted.sort_unstable();
        let mut u = Unrolled { len: refs.len() as u8, ..Unrolled::default() };
        for (k, &r) in sorted.iter().enumerate() {
            u.refs[k] = r;
            if r & layout::CSG_NODE_BIT == 0 {
                u.kinds[k] = shapes.get(r as usize)?.kind;
            }
        }
        Some(u)
    }

    /// The entries, in ascending reference order (the order the kernels test them).
    pub fn entries(&self) -> impl Iterator<Item = UnrolledEntry> + '_ {
        (0..usize::from(self.len)).map(|k| {
            let r = self.refs[k];
            if r & layout::CSG_NODE_BIT != 0 {
                UnrolledEntry::Csg(r)
            } else {
                UnrolledEntry::Shape { index: r, kind: self.kinds[k] }
            }
        })
    }
}

/// The generated WGSL module `unrolled` (`// #provides unrolled`): for a scene with `f`,
/// `listed_nearest` tests the object list's entries in turn (OBJECT_LIST) and
/// `unrolled_planes` the planes' list (UNROLLED_PLANES), each entry under its constant
/// reference and, for a shape, its own kind's code (see [`Unrolled`]). Both take the query's
/// ray, inverse direction, best candidate and occlusion flag as `traverse` holds them, and
/// return true when an occlusion query may stop.
pub fn unrolled_wgsl(f: &FeatureSet) -> String {
    let mut out = String::from(
        "// #provides unrolled\n// The scene's listed objects and planes, one test each under a constant index\n\
         // (generated by src/gpu/traversal.rs, Unrolled).\n",
    );
    let head =
        "(ray: ptr<function, Ray>, inv_dir: vec3<f32>, best: ptr<function, Candidate>, any_hit: bool) -> bool {\n";
    let test = |out: &mut String, call: String| {
        let _ = writeln!(out, "    if ({call} && any_hit) {{\n        return true;\n    }}");
    };
    if let Some(list) = f.listed.filter(|_| f.lists_objects()) {
        let mut primitives = false;
        let _ = write!(out, "fn listed_nearest{head}");
        for e in list.entries() {
            let call = match e {
                UnrolledEntry::Csg(r) => format!("csg_nearer(0x{r:08X}u, ray, inv_dir, best)"),
                // No meshes here (FeatureSet::lists_objects).
                UnrolledEntry::Shape { index, kind } => {
                    primitives = true;
                    format!("listed_shape({index}u, {}, ray, best)", layout::shape_kind_wgsl(kind))
                }
            };
            test(&mut out, call);
        }
        out.push_str("    return false;\n}\n");
        if primitives {
            out.push_str(
                "\n// Listed shape `i` of kind `kind` (both constants) along the ray, as keep_nearer.\n\
                 fn listed_shape(i: u32, kind: u32, ray: ptr<function, Ray>, best: ptr<function, Candidate>) -> bool {\n\
                 \x20   let sp = record_span(shape_at(i), kind, *ray);\n\
                 \x20   return keep_nearer(Candidate(span_first_crossing(sp, *ray), i, false, i), ray, best);\n\
                 }\n",
            );
        }
    }
    if let Some(planes) = f.planes_listed.filter(|_| f.unrolls_planes()) {
        let _ = write!(out, "\nfn unrolled_planes{head}");
        for e in planes.entries() {
            let r = match e {
                UnrolledEntry::Csg(r) => r,
                UnrolledEntry::Shape { index, .. } => index,
            };
            test(&mut out, format!("nearer_unbounded(0x{r:08X}u, ray, inv_dir, best)"));
        }
        out.push_str("    return false;\n}\n");
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shape(kind: u32) -> layout::Shape {
        let mut s: layout::Shape = bytemuck::Zeroable::zeroed();
        s.kind = kind;
        s
    }

    #[test]
    fn unrolled_lists_name_each_entry_by_a_constant() {
        use layout::{shape_kind, CSG_NODE_BIT};
        let shapes = [shape(shape_kind::PLANE), shape(shape_kind::CUBE), shape(shape_kind::SPHERE)];
        let f = FeatureSet {
            sphere: true,
            cube: true,
            plane: true,
            csg: true,
            bvh: true,
            object_list: true,
            listed: Unrolled::of(&[2, CSG_NODE_BIT | 4, 1], &shapes),
            planes_listed: Unrolled::of(&[0, CSG_NODE_BIT | 5], &shapes),
            ..FeatureSet::default()
        };
        let w = unrolled_wgsl(&f);
        let at = |needle: &str| w.find(needle).unwrap_or_else(|| panic!("{needle} missing from\n{w}"));
        // In reference order, each with its own kind.
        assert!(at("listed_shape(1u, SHAPE_CUBE, ray, best)") < at("listed_shape(2u, SHAPE_SPHERE, ray, best)"));
        assert!(at("listed_shape(2u, SHAPE_SPHERE") < at("csg_nearer(0x80000004u, ray, inv_dir, best)"));
        assert!(at("nearer_unbounded(0x00000000u") < at("nearer_unbounded(0x80000005u"));
        assert!(w.contains("fn listed_shape("));
        // Nothing reads a reference from the tables.
        assert!(!w.contains("object_ref"));
        // Only trees listed: no shape helper. Lists unknown or too long: no functions.
        let trees = FeatureSet { listed: Unrolled::of(&[CSG_NODE_BIT], &shapes), planes_listed: None, ..f };
        assert!(
            unrolled_wgsl(&trees).contains("fn listed_nearest") && !unrolled_wgsl(&trees).contains("fn listed_shape")
        );
        assert!(!unrolled_wgsl(&trees).contains("fn unrolled_planes"));
        let long = FeatureSet { listed: Unrolled::of(&[1; UNROLLED_MAX + 1], &shapes), planes_listed: None, ..f };
        assert!(long.listed.is_none() && !unrolled_wgsl(&long).contains("fn "));
        assert!(!long.names().contains(&"OBJECT_LIST") && long.names().contains(&"BVH_WALK"));
        // A mesh scene walks its objects whatever the list says.
        assert!(!FeatureSet { mesh: true, ..f }.lists_objects());
        // A reference beyond the shape table is refused, not guessed.
        assert!(Unrolled::of(&[7], &shapes).is_none());
    }

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
